"""Equation-error and output-error on the JSBSim suite log's reconstruction (issue 22).

``python -m tests.crossengine.suite_estimators [SEED]`` reconstructs the 1000 Hz JSBSim
climb logged through the default sensor suite (:func:`.test_suite_log.jsbsim_suite_log`)
and prints each estimator's error against JSBSim's true coefficients and its verdict:

* equation-error on the corrected reconstruction (the airframe's one density, and the ISA
  density of the reconstructed altitude per sample);
* output-error on the raw IMU with ``imu_errors=bias+scale`` and the reconstruction's
  initial velocity as a prior (per-sample density);
* for reference, the same estimators on JSBSim's ideal 500 Hz log of the same flight.
"""

from __future__ import annotations

import sys

import numpy as np

from aeroid.estimation import make_estimator
from aeroid.reconstruction import reconstruct

from .jsbsim_flight import FlightConfig, make_flight
from .test_suite_log import jsbsim_suite_log

OE_SUITE = {"imu_errors": "bias+scale", "estimate_initial_velocity": True,
            "initial_velocity_prior": "flight"}


def _line(label: str, fit, truth: np.ndarray) -> str:
    error = np.abs(np.asarray(fit.theta) / truth - 1.0) * 100.0
    return (f"{label}: mean |error| {error.mean():.3g} %, max {error.max():.3g} %, "
            f"success {fit.success}, {fit.wall_time_s:.0f} s; {fit.message.split(';')[0]}")


def main(seed: int) -> None:
    """Print the estimators' errors on the suite log of sensor seed ``seed``."""
    ideal, truth = make_flight(FlightConfig())
    sim, _ = jsbsim_suite_log(seed)
    rec = reconstruct(sim.log)
    runs = [("equation-error, ideal 500 Hz log", "equation-error", {}, ideal),
            ("equation-error, suite, corrected IMU, one density", "equation-error", {},
             rec.to_flight()),
            ("equation-error, suite, corrected IMU, per-sample density", "equation-error", {},
             rec.to_flight(atmosphere="altitude")),
            ("output-error, ideal 500 Hz log", "output-error", {}, ideal),
            ("output-error, suite, raw IMU, imu_errors=bias+scale, per-sample density",
             "output-error", OE_SUITE, rec.to_flight(imu="raw", atmosphere="altitude"))]
    for label, method, options, flight in runs:
        fit = make_estimator(method, options).fit(flight, rng=1)
        print(_line(label, fit, truth.coefficients), flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1)
