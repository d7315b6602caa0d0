"""Flight-path reconstruction: from a sensor-suite log to states and instrument errors.

A layer between :mod:`aeroid.flights` (the suite log) and :mod:`aeroid.estimation`
(which runs on the reconstruction's single-rate :class:`~aeroid.flights.Flight`): a
kinematic extended Kalman filter and RTS smoother driven by the IMU, without
aerodynamics, aided by GNSS, barometer and INS (:func:`reconstruct`).
"""

from aeroid.reconstruction._kinematics import IMU_CHANNELS, N_STATES, STATES
from aeroid.reconstruction._reconstruct import Reconstruction, reconstruct

__all__ = ["IMU_CHANNELS", "N_STATES", "STATES", "Reconstruction", "reconstruct"]
