"""Where a flight's air-data probe sits: ``metadata["air_data_probe"]["position_m"]``.

Body axes from the c.g. [m], the flight's sidecar (or the reconstruction's ``to_flight``,
from a suite log's ``probe_position_m``). A probe off the c.g. reads the air-relative
velocity plus the rotation's ``omega x r``; every method that uses the logged air data
takes the position from here (output-error, the EKF/UKF and filter-error as a term of their
predicted air data; equation-error and the PSO methods by removing ``omega x r`` from the
probe's air velocity before the wind they imply). Without the entry the probe is taken at
the c.g., and the methods say so.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from aeroid.errors import FlightError
from aeroid.flights._flight import Flight

#: The metadata key of the probe's description.
AIR_DATA_PROBE_KEY = "air_data_probe"


def air_data_probe_position(flight: Flight) -> tuple[np.ndarray, str]:
    """The probe's position (3,) [m] (body axes, from the c.g.) and how it was found.

    Raises
    ------
    FlightError
        ``metadata["air_data_probe"]`` that is not ``{"position_m": [x, y, z]}``.
    """
    where = flight.metadata.get("source", "flight")
    probe = flight.metadata.get(AIR_DATA_PROBE_KEY)
    if probe is None:
        return np.zeros(3), "probe at the c.g. (no metadata air_data_probe.position_m: assumed)"
    try:
        if not isinstance(probe, Mapping):
            raise TypeError("not a table")
        r = np.asarray(probe["position_m"], dtype=float).reshape(-1)
        if r.size != 3 or not np.all(np.isfinite(r)):
            raise ValueError(f"{r.size} values")
    except (KeyError, TypeError, ValueError) as exc:
        raise FlightError(f"{where}: metadata air_data_probe must be {{\"position_m\": "
                          f"[x, y, z]}} (finite numbers, body axes from the c.g. [m]): "
                          f"{exc}") from None
    return r, f"probe at [{', '.join(f'{v:.4g}' for v in r)}] m (metadata)"


__all__ = ["AIR_DATA_PROBE_KEY", "air_data_probe_position"]
