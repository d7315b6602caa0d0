"""The aiding samples a reconstruction passes to its flight (``to_flight(aiding=True)``).

The reconstruction uses GNSS velocity only to aid its kinematics; an estimator can also
put it in its own likelihood (output-error's ``aiding = "gnss-velocity"``). The flight
then carries the samples as logged, at their own times (offset applied), nothing
resampled: ``metadata["aiding"]["gnss"] = {"t", "vn", "ve", "vd", "sd", "source"}``
(times [s], NED velocity [m/s], the log's stated white-noise sd per channel [m/s]).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from aeroid.errors import FlightError
from aeroid.flights import SuiteLog

#: The GNSS channels passed: NED velocity (the model has no position states).
GNSS_VELOCITY = ("vn", "ve", "vd")
#: A sample this fraction of the IMU interval beyond the first or last IMU time is still
#: inside the flight (rounding of times written in ms).
EDGE_RTOL = 1e-6
#: The reconstruction's metadata key holding the log's samples until ``to_flight``.
LOG_KEY = "aiding_log"


def logged_aiding(log: SuiteLog) -> dict[str, Any]:
    """The log's GNSS velocity samples for :func:`flight_aiding` (empty without them)."""
    if "gnss" not in log or not all(c in log["gnss"].channels for c in GNSS_VELOCITY):
        return {}
    group = log["gnss"]
    no_sd = [c for c in GNSS_VELOCITY if c not in group.noise_sd]
    if no_sd:
        raise FlightError(f"{group.source}: no noise_sd for {', '.join(no_sd)} (each "
                          "aiding channel needs one)")
    return {LOG_KEY: {"gnss": {"t": np.asarray(group.t, float).copy(),
                               **{c: np.asarray(group.channels[c], float).copy()
                                  for c in GNSS_VELOCITY},
                               "sd": {c: float(group.noise_sd[c]) for c in GNSS_VELOCITY},
                               "source": group.source}}}


def flight_aiding(metadata: dict[str, Any], t: np.ndarray, aiding: bool,
                  notes: list[str]) -> dict[str, Any]:
    """The flight's metadata: ``metadata`` without the log's samples, with ``aiding`` those
    within the flight's times as ``metadata["aiding"]`` (a note says how many)."""
    meta = {k: v for k, v in metadata.items() if k != LOG_KEY}
    if not aiding:
        return meta
    where = metadata.get("source", "suite log")
    gnss = metadata.get(LOG_KEY, {}).get("gnss")
    if gnss is None:
        raise FlightError(f"{where}: aiding=True needs GNSS velocity (vn ve vd with their "
                          "noise_sd) in the log; it has none")
    tol = EDGE_RTOL * float(t[1] - t[0])
    inside = (gnss["t"] >= t[0] - tol) & (gnss["t"] <= t[-1] + tol)
    if not inside.any():
        raise FlightError(f"{where}: no GNSS velocity sample within the flight's "
                          f"{t[0]:.6g}-{t[-1]:.6g} s")
    meta["aiding"] = {"gnss": {"t": gnss["t"][inside], "sd": dict(gnss["sd"]),
                               "source": gnss["source"],
                               **{c: gnss[c][inside] for c in GNSS_VELOCITY}}}
    notes.append(f"aiding: {int(inside.sum())} GNSS velocity samples (vn ve vd) at their own "
                 "times in metadata['aiding'] (output-error aiding = gnss-velocity)"
                 + (f"; {int((~inside).sum())} outside the flight's times left out"
                    if not inside.all() else ""))
    return meta
