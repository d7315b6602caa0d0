"""The aiding samples a reconstruction passes to its flight (``to_flight(aiding=True)``).

The reconstruction uses GNSS velocity and INS attitude only to aid its kinematics; an
estimator can also put them in its own likelihood (output-error's ``aiding =
"gnss-velocity"`` or ``"gnss-velocity+ins-attitude"``). The flight then carries the samples
as logged, at their own times (offset applied), nothing resampled:
``metadata["aiding"]["gnss"] = {"t", "vn", "ve", "vd", "sd", "source"}`` (times [s], NED
velocity [m/s], the log's stated white-noise sd per channel [m/s]) and
``metadata["aiding"]["ins"] = {"t", "phi", "theta", "psi", "sd", "source"}`` (Euler angles
as logged, possibly wrapped [rad], their stated sd [rad]).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from aeroid.errors import FlightError
from aeroid.flights import SuiteLog

#: The GNSS channels passed: NED velocity (the model has no position states).
GNSS_VELOCITY = ("vn", "ve", "vd")
#: The INS channels passed: the Euler angles.
INS_ATTITUDE = ("phi", "theta", "psi")
#: Each source passed: its log group (and key in ``metadata["aiding"]``), its channels and
#: what the notes call it.
SOURCES = {"gnss": (GNSS_VELOCITY, "GNSS velocity"), "ins": (INS_ATTITUDE, "INS attitude")}
#: A sample this fraction of the IMU interval beyond the first or last IMU time is still
#: inside the flight (rounding of times written in ms).
EDGE_RTOL = 1e-6
#: The reconstruction's metadata key holding the log's samples until ``to_flight``.
LOG_KEY = "aiding_log"


def logged_aiding(log: SuiteLog) -> dict[str, Any]:
    """The log's GNSS velocity and INS attitude samples for :func:`flight_aiding` (empty
    without either; a group without all three channels is not a source)."""
    found = {}
    for name, (channels, _) in SOURCES.items():
        if name not in log or not all(c in log[name].channels for c in channels):
            continue
        group = log[name]
        no_sd = [c for c in channels if c not in group.noise_sd]
        if no_sd:
            raise FlightError(f"{group.source}: no noise_sd for {', '.join(no_sd)} (each "
                              "aiding channel needs one)")
        found[name] = {"t": np.asarray(group.t, float).copy(),
                       **{c: np.asarray(group.channels[c], float).copy() for c in channels},
                       "sd": {c: float(group.noise_sd[c]) for c in channels},
                       "source": group.source}
    return {LOG_KEY: found} if found else {}


def flight_aiding(metadata: dict[str, Any], t: np.ndarray, aiding: bool,
                  notes: list[str]) -> dict[str, Any]:
    """The flight's metadata: ``metadata`` without the log's samples, with ``aiding`` those
    of each source within the flight's times as ``metadata["aiding"]`` (a note per source
    says how many)."""
    meta = {k: v for k, v in metadata.items() if k != LOG_KEY}
    if not aiding:
        return meta
    where = metadata.get("source", "suite log")
    logged = metadata.get(LOG_KEY, {})
    if not logged:
        raise FlightError(f"{where}: aiding=True needs GNSS velocity (vn ve vd) or INS "
                          "attitude (phi theta psi) with their noise_sd in the log; it has "
                          "neither")
    tol = EDGE_RTOL * float(t[1] - t[0])
    meta["aiding"] = {}
    for name, group in logged.items():
        channels, label = SOURCES[name]
        inside = (group["t"] >= t[0] - tol) & (group["t"] <= t[-1] + tol)
        if not inside.any():
            raise FlightError(f"{where}: no {label} sample within the flight's "
                              f"{t[0]:.6g}-{t[-1]:.6g} s")
        meta["aiding"][name] = {"t": group["t"][inside], "sd": dict(group["sd"]),
                                "source": group["source"],
                                **{c: group[c][inside] for c in channels}}
        notes.append(f"aiding: {int(inside.sum())} {label} samples ({' '.join(channels)}) at "
                     "their own times in metadata['aiding'] (output-error aiding = "
                     + ("gnss-velocity)" if name == "gnss" else
                        "gnss-velocity+ins-attitude; as logged, wrapped angles compared on "
                        "the circle)")
                     + (f"; {int((~inside).sum())} outside the flight's times left out"
                        if not inside.all() else ""))
    return meta
