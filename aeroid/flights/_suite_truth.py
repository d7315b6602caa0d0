"""The truth a sensor suite logs: the manoeuvre at the IMU's rate, in the scenario's air.

:func:`imu_manoeuvre` (moved here from :mod:`._suite` unchanged) samples the manoeuvre at
the IMU's rate with the same flight. :func:`suite_truth` integrates it in the
manoeuvre's ``wind`` (the scenario's ``[wind]``, :class:`aeroid.flights.Wind`): a steady
wind as the model's constants, Dryden gusts drawn first from the suite's generator on the
IMU's grid (so a still-air or steady-wind suite log of a seed draws what it drew before).
Turbulence is simulated with the latched relay only (:func:`aeroid.flights.simulate_truth`):
where the IMU's rate differs from the manoeuvre's, the relay is then latched at the IMU's
instants instead of the manoeuvre's own clock, and the sampling line says so.
"""

from __future__ import annotations

import dataclasses
from typing import Any, NamedTuple

import numpy as np

from aeroid.flights._scenario import Manoeuvre
from aeroid.flights._simulate import simulate_truth
from aeroid.flights._truth import Truth
from aeroid.model import Airframe, Constants

__all__ = ["SuiteTruth", "imu_manoeuvre", "suite_truth", "wind_constants"]


class SuiteTruth(NamedTuple):
    """The integrated truth, the manoeuvre it flew and one line saying how it was sampled."""

    truth: Truth
    sampled: Manoeuvre
    sampling: str


def imu_manoeuvre(manoeuvre: Manoeuvre, imu_rate_hz: float) -> Manoeuvre:
    """Return ``manoeuvre`` sampled at the IMU's rate with the same flight (module docstring)."""
    if manoeuvre.sample_rate_hz == imu_rate_hz:
        return manoeuvre
    changes: dict[str, Any] = {
        "sample_rate_hz": imu_rate_hz,
        "truth_substeps": max(1, round(manoeuvre.truth_substeps * manoeuvre.sample_rate_hz
                                       / imu_rate_hz))}
    if manoeuvre.evaluation == "latched":
        changes.update(evaluation="control_rate", control_rate_hz=manoeuvre.sample_rate_hz)
    return dataclasses.replace(manoeuvre, **changes)


def suite_truth(airframe: Airframe, coefficients: np.ndarray, manoeuvre: Manoeuvre,
                imu_rate_hz: float, rng: np.random.Generator, backend: str) -> SuiteTruth:
    """The truth at the IMU's rate in the manoeuvre's air (module docstring)."""
    sampled = imu_manoeuvre(manoeuvre, imu_rate_hz)
    turbulent = manoeuvre.wind is not None and manoeuvre.wind.turbulent
    relay = ""
    if turbulent and sampled.evaluation == "control_rate" and manoeuvre.evaluation == "latched":
        sampled = dataclasses.replace(sampled, evaluation="latched", control_rate_hz=None)
        relay = (f" (Dryden turbulence needs the latched relay: latched at the IMU's "
                 f"{imu_rate_hz:g} Hz, not the manoeuvre's {manoeuvre.sample_rate_hz:g} Hz)")
    truth = simulate_truth(airframe, coefficients, sampled, backend=backend,
                           rng=rng if turbulent else None)
    sampling = (f"truth simulated at {imu_rate_hz:g} Hz with {sampled.truth_substeps} RK4 "
                f"substeps, relay {sampled.evaluation}"
                + (f" at {sampled.control_rate_hz:g} Hz" if sampled.control_rate_hz else "")
                + relay)
    if manoeuvre.wind is not None:
        w = manoeuvre.wind
        sampling += (f"; in wind N {w.steady_ned_mps[0]:+g}, E {w.steady_ned_mps[1]:+g}, "
                     f"D {w.steady_ned_mps[2]:+g} m/s"
                     + (f", Dryden sd {w.turbulence_sd_mps:g} m/s, scale length "
                        f"{w.scale_length_m:g} m" if turbulent else ""))
    return SuiteTruth(truth, sampled, sampling)


def wind_constants(const: Constants, wind: np.ndarray | None) -> Constants:
    """``const`` with the wind per sample ``wind`` (n, 3) NED [m/s] (None: unchanged)."""
    if wind is None:
        return const
    return const._replace(wind_n=wind[:, 0], wind_e=wind[:, 1], wind_d=wind[:, 2])
