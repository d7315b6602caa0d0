"""Output-error's equation-error start given up early (baselines._oe_starts.give_up).

Run by hand from the repository root::

    nice -n 10 python benchmarks/bench_oe_give_up.py            # prints
    nice -n 10 python benchmarks/bench_oe_give_up.py --write    # and writes the results

The fits of the tests on noise-free sensor-suite flights with ``imu_errors`` (seed 3 of
``tests/suite_flights.py``), each twice in one session, alternating: with ``give_up``
(now) and without it (before: every start runs to convergence or its iteration limit).
What the fit reports must be the same, asserted: the estimate, standard errors,
covariance, success, message, warnings and the best start's parameters; only the given-up
start's own lines in ``info`` (its cost, ``start_stopped``) and the iteration and
evaluation counts differ. The last fit is one where the given-up start would have
converged (at the same optimum as the prior's, less likely than it): given up, its end is
no longer in ``info`` as converged, and what the fit reports is still the same. Reported
per fit: the CPU seconds of the process (one BLAS
thread: on a shared machine they move less with the load than wall time) and the
iterations of each, after one untimed fit (the model's compilation), and what the
given-up start says.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # CPU time of one thread
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from unittest import mock  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT / "tests") not in sys.path:
    sys.path.insert(0, str(ROOT / "tests"))

from _before_after import assert_same_result, measured, timed_fit  # noqa: E402
from suite_flights import clean_suite_flight, gnss_aiding, suite_flight  # noqa: E402

import baselines.output_error as oe  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "oe_give_up.md"


def _cases() -> dict[str, tuple]:
    """Test fit -> (flight, options): the tests' own."""
    _, flight = clean_suite_flight(seed=3)
    sd = {"u": 0.04, "v": 0.1, "w": 0.16}
    held = dataclasses.replace(flight, metadata={**flight.metadata, "initial_state_sd": sd})
    sim, aided = suite_flight(seed=3, accel_noise_mps2=0.0, gyro_noise_radps=0.0,
                              gnss_velocity_sd_mps=0.0)
    aided = gnss_aiding(sim, aided, sd=1e-3)
    imu = {"imu_errors": "bias+scale"}
    return {
        "imu errors (test_output_error_imu_errors, test_predict_imu_errors)": (flight, imu),
        "initial velocity held, its sd stated (test_a_reconstructed_velocity...)": (held, imu),
        "initial velocity free, its prior, 200 iterations (left out of that test)": (
            held, {**imu, "estimate_initial_velocity": True,
                   "initial_velocity_prior": "flight", "max_iterations": 200}),
        "GNSS velocity (test_noise_free_suite_flight_with_gnss...)": (
            aided, {**imu, "aiding": "gnss-velocity"}),
        "imu errors, 200 iterations (the equation-error start converges at 72 before)": (
            flight, {**imu, "max_iterations": 200}),
    }


def _fit(flight, options: dict, before: bool):
    patch = mock.patch.object(oe, "give_up", lambda ends, est: None) if before else None
    return timed_fit(oe.OutputErrorEstimator(**options), flight, patch, time.process_time)


def _same(a, b) -> None:
    assert_same_result(a, b)
    np.testing.assert_array_equal(a.info["parameters"], b.info["parameters"])
    assert a.info["start_labels"] == b.info["start_labels"]


def measure() -> list[str]:
    lines = ["| fit | before [CPU s] | now [CPU s] | before: iterations | now: iterations | "
             "given up |", "|---|---:|---:|---:|---:|---|"]
    cases = _cases()
    _fit(*next(iter(cases.values())), False)  # compiles the model: not timed
    for label, (flight, options) in cases.items():
        old, t_old = _fit(flight, options, True)
        new, t_new = _fit(flight, options, False)
        _same(old, new)
        said = "; ".join(f"{k}: {v}" for k, v in new.info.get("start_stopped", {}).items())
        lines.append(f"| {label} | {t_old:.1f} | {t_new:.1f} | {old.n_iterations} | "
                     f"{new.n_iterations} | {said or '-'} |")
        print(lines[-1], flush=True)
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help=f"write {RESULTS.name}")
    args = parser.parse_args(argv)
    measured("Output-error: the equation-error start given up early", measure, RESULTS,
             args.write,
             "Noise-free default-suite flights (seed 3), output-error with `imu_errors = "
             "bias+scale`; each fit before (no give-up) and now in one session; the estimate, "
             "standard errors, covariance, success, message, warnings and parameters asserted "
             "identical.")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
