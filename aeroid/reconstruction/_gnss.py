"""A GNSS that logs positions only (issue 25: a flight computer's GNSS).

Without a GNSS velocity (and without ``initial_velocity``) the reconstruction's prior
velocity and position at the first IMU sample come from a quadratic least-squares fit of
the GNSS positions within :data:`TRACK_SPAN_S` of it, weighted by their noise sd
(``numpy.polyfit`` and its covariance); a quadratic leaves out the jerk, whose bound
:data:`JERK_BOUND_MPS3` adds to the sd. Those positions set the prior and are not used
again as measurements (their information would count twice). A note says so.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from aeroid.errors import FlightError
from aeroid.flights import SuiteLog

#: GNSS positions within this time of the first IMU sample set the start [s].
TRACK_SPAN_S = 1.0
#: Fewest positions for the quadratic fit (three coefficients and one degree of freedom).
MIN_TRACK_SAMPLES = 4
#: A bound on the jerk [m/s^3] the quadratic leaves out: a coasting rocket's drag changes
#: its deceleration by a few m/s^3; 20 m/s^3 leaves a margin.
JERK_BOUND_MPS3 = 20.0
POSITIONS = ("pn", "pe", "pd")
VELOCITIES = ("vn", "ve", "vd")


class TrackStart(NamedTuple):
    """The NED velocity [m/s] and position [m] at the first IMU sample, sd and samples."""

    velocity: np.ndarray
    velocity_sd: np.ndarray
    position: np.ndarray
    position_sd: np.ndarray
    samples: np.ndarray


def gnss_track_start(log: SuiteLog, t0: float, used: dict[str, Any], notes: list[str]
                     ) -> TrackStart | None:
    """Return the start fitted to the GNSS positions, or None (no GNSS, or it has velocity).

    ``used["gnss"]`` becomes the indices of the positions fitted (not used again).

    Raises
    ------
    FlightError
        One line: a position channel without a noise sd, or fewer than
        :data:`MIN_TRACK_SAMPLES` positions within :data:`TRACK_SPAN_S` of ``t0``.
    """
    if "gnss" not in log:
        return None
    group = log["gnss"]
    if (not all(c in group.channels for c in POSITIONS)
            or any(c in group.channels for c in VELOCITIES)):
        return None
    no_sd = [c for c in POSITIONS if c not in group.noise_sd]
    if no_sd:
        raise FlightError(f"{group.source}: no noise_sd for {', '.join(no_sd)} (each "
                          "aiding channel needs one)")
    tau = group.t - t0
    near = np.flatnonzero(np.abs(tau) <= TRACK_SPAN_S)
    if near.size < MIN_TRACK_SAMPLES:
        raise FlightError(f"{group.source}: GNSS positions only (no velocity): "
                          f"{near.size} position(s) within {TRACK_SPAN_S:g} s of the first "
                          f"IMU sample, the initial velocity needs {MIN_TRACK_SAMPLES}; "
                          "give initial_velocity")
    span = float(np.max(np.abs(tau[near])))
    velocity, position, v_sd, p_sd = (np.empty(3) for _ in range(4))
    for j, c in enumerate(POSITIONS):
        coef, cov = np.polyfit(tau[near], group.channels[c][near], 2,
                               w=np.full(near.size, 1.0 / group.noise_sd[c]), cov="unscaled")
        velocity[j], position[j] = coef[1], coef[2]
        v_sd[j] = np.sqrt(cov[1, 1]) + JERK_BOUND_MPS3 * span**2 / 6.0
        p_sd[j] = np.sqrt(cov[2, 2]) + JERK_BOUND_MPS3 * span**3 / 6.0
    notes.append(f"gnss: positions only: the initial velocity and position from a quadratic "
                 f"fit of the {near.size} positions within {TRACK_SPAN_S:g} s of the first IMU "
                 f"sample (velocity sd {v_sd.max():.3g} m/s); they are not used again")
    used["gnss"] = near
    return TrackStart(velocity, v_sd, position, p_sd, near)
