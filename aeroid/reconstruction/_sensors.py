"""The reconstruction's use of a sensor's mounting and range (:mod:`aeroid.flights._mounting`).

:func:`mounted_positions`: the imu mounting's triad positions become the airframe's
(eq. 28's positions, for the reconstruction's lever arm and the estimators' model);
:func:`saturated_samples`: saturated IMU readings get a larger sd in the kinematics and
are named for the estimators, which leave them out of their likelihood.
"""

from __future__ import annotations

import numpy as np

from aeroid.errors import FlightError
from aeroid.flights import SensorGroup
from aeroid.model import Airframe
from aeroid.reconstruction._kinematics import IMU_CHANNELS

#: A saturated IMU reading is integrated at the range with this fraction of the range as
#: its sd (the truth lies beyond the range by an unknown amount; see
#: :func:`saturated_samples`).
SATURATED_SD_REL = 0.05


def mounted_positions(airframe: Airframe, imu: SensorGroup, notes: list[str]) -> Airframe:
    """The airframe with the triads' positions of the imu group's mounting, if it gives them.

    The positions enter eq. 28 through the airframe (``accel_positions``): here in the
    reconstruction's lever arm, and in the estimators' model through the flight's airframe.
    """
    if imu.mounting is None or imu.mounting.positions_m is None:
        return airframe
    positions = imu.mounting.positions_m
    if np.array_equal(positions, airframe.accel_positions):
        return airframe
    notes.append(f"{imu.source}: accelerometer positions from the imu mounting "
                 f"{positions.tolist()} m replace the airframe's "
                 f"{airframe.accel_positions.tolist()} m")
    return airframe.replace(accel1_position_m=tuple(map(float, positions[0])),
                            accel2_position_m=tuple(map(float, positions[1])))


def saturated_samples(imu: SensorGroup, imu_sd: np.ndarray, notes: list[str]
               ) -> tuple[dict[str, list[int]], np.ndarray | None]:
    """The saturated IMU samples (channel -> indices) and the per-sample IMU sd.

    The IMU drives the kinematics (it is no measurement here), so a saturated reading
    cannot leave a likelihood: it is integrated as read (the range) with its sd raised to
    :data:`SATURATED_SD_REL` of the range, so the states' covariance grows by what the
    reading leaves unknown and the aiding pulls them back; the estimators leave those
    samples out (``to_flight``'s ``metadata["saturated"]``). Measured on the reference
    flight logged by a board with a 52 rad/s gyro range (the roll peaks at 53: 322 roll
    samples saturated, seeds 11 and 12): every source's residual check consistent and
    phi within 3 sd at every sample; with 0.01 the INS check failed (mean NIS 2.2 and
    1.7) and phi left 3 sd. A truth far beyond the range (more than a few percent) needs
    a larger value: the INS check then says so.
    """
    saturated = {c: np.flatnonzero(imu.saturated[c]).tolist() for c in IMU_CHANNELS
                 if c in imu.saturated and imu.saturated[c].any()}
    if not saturated:
        return {}, None
    sd = np.tile(imu_sd, (len(imu.t), 1))
    for c, k in saturated.items():
        key = "gyro_range" if c in ("p", "q", "r") else "accel_range"
        sd[k, IMU_CHANNELS.index(c)] = max(SATURATED_SD_REL * imu.ranges[key],
                                           imu_sd[IMU_CHANNELS.index(c)])
    notes.append("saturated IMU samples (" + ", ".join(f"{c} {len(k)}" for c, k in
                                                       saturated.items())
                 + f"): integrated at the range with {SATURATED_SD_REL:g} of the range as "
                 "their sd; left out of the estimators' likelihood (flight metadata "
                 "'saturated')")
    return saturated, sd


def held_fin(fin: tuple[np.ndarray, np.ndarray], t: np.ndarray, meta: dict) -> np.ndarray:
    """The fin's deflection at times ``t``: its latest sample at or before each (a relay)."""
    ft, delta = fin
    k = np.searchsorted(ft, t + 1e-9 * (t[1] - t[0]), side="right") - 1
    if k[0] < 0:
        raise FlightError(f"{meta.get('source', 'suite log')}: the fin log starts at "
                          f"{ft[0]:.6g} s, after the IMU's first sample at {t[0]:.6g} s")
    return delta[k]
