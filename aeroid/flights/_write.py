"""Writing a flight: CSV (lossless, 17 digits) or Parquet, plus the JSON sidecar."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

from aeroid.errors import FlightError
from aeroid.flights._sidecar import sidecar_path, sidecar_payload

if TYPE_CHECKING:  # the Flight type only annotates here (Flight.write calls this module)
    from aeroid.flights._flight import Flight


def write_flight(flight: Flight, path: str | Path) -> Path:
    """Write ``flight`` as CSV (Parquet for a ``.parquet`` path) plus its JSON sidecar.

    CSV values are written with 17 significant digits (a lossless round trip).

    Returns
    -------
    Path
        The sidecar written.

    Raises
    ------
    FlightError
        A ``.json`` data path (the sidecar's own name), or Parquet without pyarrow.
    """
    path = Path(path)
    sidecar = sidecar_path(path)
    if sidecar == path:
        raise FlightError(f"{path}: a flight's data cannot be .json (that is its sidecar's "
                          "name); use .csv or .parquet")
    if path.suffix == ".parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            raise FlightError(f"{path}: writing Parquet needs pyarrow "
                              "(pip install 'aeroid-toolkit[parquet]'); or write .csv") from None
        flight.data.to_parquet(path, index=False, engine="pyarrow")
    else:
        flight.data.to_csv(path, index=False, float_format="%.17g")
    sidecar.write_text(json.dumps(sidecar_payload(flight), indent=2))
    return sidecar
