"""Output-error's fin delay as the time skew between a suite log's fin and IMU clocks.

The fin group's logged times are shifted by SKEW (the log claims the fin switched SKEW
earlier than it did, and says nothing of it: ``offset_s = 0``; with a negative skew the
IMU samples before the fin log's first are dropped); the flight is reconstructed,
its raw IMU fitted by output-error with the IMU's errors and the initial velocity's prior,
without and with ``estimate_delay``. Prints the mean |relative error| of the coefficients,
the estimated delay and its standard error, and the verdict::

    python benchmarks/suite_fin_skew.py 0.002 1       # SKEW [s], sensor seed

or, with ``estimate_delay`` only, a table over skews and sensor seeds (markdown rows)::

    python benchmarks/suite_fin_skew.py table 0,0.001,0.002,-0.001 1,2,3,4,5
"""

from __future__ import annotations

import dataclasses
import sys
import time

import numpy as np

from aeroid.estimation import EstimationResult, make_estimator
from aeroid.flights import SensorSuite, reference_scenario, simulate_suite
from aeroid.reconstruction import reconstruct

OPTIONS = {"imu_errors": "bias+scale", "estimate_initial_velocity": True,
           "initial_velocity_prior": "flight", "max_iterations": 150}


def fit(skew: float, seed: int, delay: bool) -> tuple[EstimationResult, float]:
    """Fit the suite log of ``seed`` with its fin clock ``skew`` [s] early; mean |error| [%]."""
    sc = reference_scenario()
    log = simulate_suite(sc.airframe, sc.coefficient_vector, sc.manoeuvre, SensorSuite(),
                         rng=seed).log
    fin = log.groups["fin"]
    late = dataclasses.replace(fin, t=fin.t - skew)
    imu = log.groups["imu"]
    keep = imu.t >= late.t[0]  # a negative skew: the fin log starts after the IMU's
    imu = dataclasses.replace(imu, t=imu.t[keep],
                              channels={k: v[keep] for k, v in imu.channels.items()})
    log = dataclasses.replace(log, groups={**log.groups, "fin": late, "imu": imu})
    flight = reconstruct(log).to_flight(imu="raw")
    result = make_estimator("output-error", {**OPTIONS, "estimate_delay": delay}).fit(
        flight, rng=0)
    return result, float(100 * np.mean(np.abs(result.theta / sc.coefficient_vector - 1)))


def main(skew: float, seed: int) -> None:
    """Fit a skewed suite log without and with the delay, and print what came out."""
    for delay in (False, True):
        result, err = fit(skew, seed, delay)
        print(f"skew {1e3 * skew:g} ms, estimate_delay={delay}: mean |error| {err:.3f} %, "
              f"delay {result.info.get('delay_s')} s (sd {result.info.get('delay_stderr_s')}), "
              f"success {result.success}: {result.message}")


def table(skews: list[float], seeds: list[int]) -> None:
    """Print a markdown row per (skew, seed) of the fit with ``estimate_delay``."""
    print("| skew [ms] | seed | delay [ms] | sd [ms] | (delay - skew) / sd | mean abs error "
          "[%] | success | iterations | wall [s] | message |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for skew in skews:
        for seed in seeds:
            start = time.perf_counter()
            result, err = fit(skew, seed, True)
            d, sd = result.info["delay_s"], result.info["delay_stderr_s"]
            print(f"| {1e3 * skew:g} | {seed} | {1e3 * d:.6f} | {1e3 * sd:.6f} | "
                  f"{(d - skew) / sd:+.3f} | {err:.3f} | {result.success} | "
                  f"{result.n_iterations} | {time.perf_counter() - start:.1f} | "
                  f"{result.message} |", flush=True)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "table":
        table([float(s) for s in sys.argv[2].split(",")],
              [int(s) for s in sys.argv[3].split(",")])
    else:
        main(float(sys.argv[1]) if len(sys.argv) > 1 else 0.002,
             int(sys.argv[2]) if len(sys.argv) > 2 else 1)
