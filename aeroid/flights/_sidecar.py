"""The JSON sidecar of a flight file: the airframe and metadata beside the data.

``<name>.json`` holds ``{"format": "aeroid-flight/1", "airframe": {...}, "metadata":
{...}}``: the airframe in the airframe file's form (:meth:`Airframe.to_dict`) and the
flight's metadata. A same-stem JSON file without the ``aeroid-flight/`` format tag is
another tool's: it is not read (its name is given when an airframe is missing). A tagged
sidecar is checked strictly: unknown keys, another format version, and metadata that
aeroid writes with the wrong type are one-line errors naming the file.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from aeroid.errors import AirframeError, FlightError
from aeroid.flights._declared_air import declared_wind
from aeroid.flights._noise import noise_from_dict
from aeroid.model import NAMES, Airframe, fileform

#: The sidecar's format tag; a same-stem JSON file without it is not a sidecar.
FORMAT = "aeroid-flight/1"
#: The keys of a sidecar.
SIDECAR_KEYS = ("format", "airframe", "metadata")
#: Largest sidecar read beyond the size of its data file [bytes]. A sidecar holds the
#: airframe (0.5 kB), the truth and settings (~1 kB) and, for a simulated flight, the
#: fin's switch knots (``delta_knots``, ``command_switches``): those grow with the
#: flight (measured on the reference scenario from 0 s: 97 kB for 20 s, 2.6 % of its
#: 3.8 MB CSV; 5.3 MB for 10 minutes, 4.7 % of its 113 MB CSV), each knot a few numbers
#: where each sample's row holds 20. So a sidecar may be as large as its data file plus
#: this; a bigger same-stem JSON file is another tool's and is not opened.
MAX_SIDECAR_BYTES = 1 << 20


def sidecar_path(path: str | Path) -> Path:
    """Return the JSON sidecar path of a flight file (``f.csv`` -> ``f.json``)."""
    return Path(path).with_suffix(".json")


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    return value


def sidecar_payload(airframe: Airframe, metadata: Mapping[str, Any]) -> dict[str, Any]:
    """Return the sidecar of a flight's ``airframe`` and ``metadata`` as a JSON-ready dict
    (``source`` left out)."""
    meta = {k: v for k, v in metadata.items() if k != "source"}
    return {"format": FORMAT, "airframe": airframe.to_dict(), "metadata": _jsonable(meta)}


def sidecar_limit(path: str | Path) -> int:
    """Return the largest sidecar of the data file ``path`` that is read [bytes]:
    its size plus :data:`MAX_SIDECAR_BYTES` (the knots grow with the flight)."""
    try:
        data = os.stat(path).st_size
    except OSError:  # the data file is checked by its reader
        data = 0
    return data + MAX_SIDECAR_BYTES


def read_sidecar(path: Path, *, need_airframe: bool
                 ) -> tuple[dict[str, Any], Airframe | None, str]:
    """Return ``(metadata, airframe or None, note)`` from the sidecar of ``path``.

    ``note`` says why there is no airframe when there is none. The airframe is read
    only when ``need_airframe``.
    """
    sidecar = sidecar_path(path)
    if sidecar == path or not sidecar.exists():
        return {}, None, f"no sidecar {sidecar.name}"
    try:
        size = fileform.regular_file_size(sidecar, FlightError)
    except FlightError as exc:
        return {}, None, f"{sidecar.name} is not an aeroid sidecar: {exc}"
    limit = sidecar_limit(path)
    if size > limit:
        return {}, None, (f"{sidecar.name} is not an aeroid sidecar: {size} bytes, more than "
                          f"its data file plus {MAX_SIDECAR_BYTES} ({limit})")
    try:
        raw = sidecar.read_bytes()
    except OSError as exc:  # it may be this flight's sidecar: say why it is not read
        raise FlightError(f"{sidecar}: cannot read the sidecar ({exc.strerror or exc}); "
                          "make it readable, or move it away if it is not aeroid's") from None
    try:
        payload = json.loads(raw)
    except ValueError:
        return {}, None, f"{sidecar.name} is not an aeroid sidecar: not JSON"
    except RecursionError:  # json's parser recurses once per nested array or object
        raise FlightError(f"{sidecar}: JSON nested too deeply to read (thousands of levels; "
                          "aeroid's nest a few); move it away if it is not aeroid's"
                          ) from None
    tag = payload.get("format") if isinstance(payload, dict) else None
    if not (isinstance(tag, str) and tag.startswith("aeroid-flight/")):
        return {}, None, (f"{sidecar.name} is not an aeroid sidecar: no \"format\": "
                          f"\"{FORMAT}\"")
    if tag != FORMAT:
        raise FlightError(f"{sidecar}: sidecar format {tag!r} is not supported "
                          f"(this aeroid reads {FORMAT})")
    try:
        fileform.check_keys(payload, SIDECAR_KEYS, f"{sidecar}", required=SIDECAR_KEYS)
        metadata = sidecar_metadata(payload["metadata"], str(sidecar))
        airframe = (Airframe.from_dict(payload["airframe"], source=f"{sidecar} airframe")
                    if need_airframe else None)
    except AirframeError as exc:
        raise FlightError(str(exc)) from None
    return metadata, airframe, ""


def sidecar_metadata(metadata: Any, source: str) -> dict[str, Any]:
    """Check the types of the metadata keys aeroid writes and return a copy.

    Raises
    ------
    AirframeError
        One line naming ``source`` and the key of the wrong type.
    """
    where = f"{source}: metadata"
    metadata = dict(fileform.check_table(metadata, where))
    if "seed" in metadata and metadata["seed"] is not None and (
            isinstance(metadata["seed"], bool) or not isinstance(metadata["seed"], int)):
        raise AirframeError(f"{where} seed must be an integer or null, "
                            f"got {metadata['seed']!r}")
    if "noise" in metadata:
        try:
            noise_from_dict(dict(fileform.check_table(metadata["noise"], f"{where} noise")))
        except AirframeError as exc:
            message = str(exc)
            raise AirframeError(message if message.startswith(where)
                                else f"{where} noise: {message}") from None
    if metadata.get("true_coefficients") is not None:
        truth = fileform.check_table(metadata["true_coefficients"], f"{where} true_coefficients")
        fileform.check_keys(truth, NAMES, f"{where} true_coefficients", required=NAMES)
        fileform.numbers([truth[n] for n in NAMES], len(NAMES), f"{where} true_coefficients")
    if metadata.get("true_accel_positions_m") is not None:
        rows = metadata["true_accel_positions_m"]
        if not isinstance(rows, list) or len(rows) != 2:
            raise AirframeError(f"{where} true_accel_positions_m must be 2 x 3 numbers, "
                                f"got {rows!r}")
        for row in rows:
            fileform.numbers(row, 3, f"{where} true_accel_positions_m")
    try:  # "still" or a [wind] table: the air the log declares (_declared_air)
        declared_wind(metadata, source)
    except FlightError as exc:
        raise AirframeError(str(exc)) from None
    if "manoeuvre" in metadata:
        table = fileform.check_table(metadata["manoeuvre"], f"{where} manoeuvre")
        for key, value in table.items():
            ok = (fileform.is_number(value) and math.isfinite(value)) or (
                isinstance(value, list) and all(fileform.is_number(x) for x in value))
            if not ok:
                raise AirframeError(f"{where} manoeuvre {key} must be a number, got {value!r}")
    return metadata


__all__ = ["FORMAT", "MAX_SIDECAR_BYTES", "read_sidecar", "sidecar_limit", "sidecar_metadata",
           "sidecar_path", "sidecar_payload"]
