"""Output-error's fin delay as the time skew between a suite log's fin and IMU clocks.

The fin group's logged times are shifted by SKEW (the log claims the fin switched SKEW
earlier than it did, and says nothing of it: ``offset_s = 0``); the flight is reconstructed,
its raw IMU fitted by output-error with the IMU's errors and the initial velocity's prior,
without and with ``estimate_delay``. Prints the mean |relative error| of the coefficients,
the estimated delay and its standard error, and the verdict::

    python benchmarks/suite_fin_skew.py 0.002 1       # SKEW [s], sensor seed
"""

from __future__ import annotations

import dataclasses
import sys

import numpy as np

from aeroid.estimation import make_estimator
from aeroid.flights import SensorSuite, reference_scenario, simulate_suite
from aeroid.reconstruction import reconstruct


def main(skew: float, seed: int) -> None:
    """Fit a skewed suite log without and with the delay, and print what came out."""
    sc = reference_scenario()
    log = simulate_suite(sc.airframe, sc.coefficient_vector, sc.manoeuvre, SensorSuite(),
                         rng=seed).log
    fin = log.groups["fin"]
    late = dataclasses.replace(fin, t=fin.t - skew)
    log = dataclasses.replace(log, groups={**log.groups, "fin": late})
    flight = reconstruct(log).to_flight(imu="raw")
    options = {"imu_errors": "bias+scale", "estimate_initial_velocity": True,
               "initial_velocity_prior": "flight", "max_iterations": 150}
    for delay in (False, True):
        fit = make_estimator("output-error", {**options, "estimate_delay": delay}).fit(
            flight, rng=0)
        err = 100 * np.mean(np.abs(fit.theta / sc.coefficient_vector - 1))
        print(f"skew {1e3 * skew:g} ms, estimate_delay={delay}: mean |error| {err:.3f} %, "
              f"delay {fit.info.get('delay_s')} s (sd {fit.info.get('delay_stderr_s')}), "
              f"success {fit.success}: {fit.message}")


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 0.002,
         int(sys.argv[2]) if len(sys.argv) > 2 else 1)
