"""What the fit check costs against output-error's fit, side by side (issue 18: <= 20 %).

Run by hand from the repository root::

    python benchmarks/bench_fitcheck.py            # writes benchmarks/results/fitcheck.md
    python benchmarks/bench_fitcheck.py --quick    # 3 flights, prints only

On the reference flight (paper noise, flight seeds 0..N-1, prior = truth) each round
times, in one process and alternating, output-error's method alone (``Estimator.run``:
the fit without any check) and the fit check on its raw result: the data's noise levels
(4th differences between switches), the residual size, the whiteness tests (18 score
tests) and the identifiability findings (:func:`apply_fit_check`); separately the
Cramér-Rao floor check that :meth:`Estimator.fit` runs after it (``floor_warnings``:
a model sensitivity pass). CPU time (``time.process_time``) after one warm-up fit; the
machine is shared, so medians over the rounds and each check's ratio to its own round's
fit.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import datetime as dt  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import aeroid  # noqa: E402
from aeroid.estimation._fitcheck import (  # noqa: E402
    apply_fit_check,
    data_noise_levels,
    floor_warnings,
)

RESULTS = Path(__file__).parent / "results" / "fitcheck.md"
REPEATS = 5  # each check is repeated (it is fast): the CPU clock's tick is coarse


def round_times(flight: aeroid.Flight, est: aeroid.Estimator) -> tuple[float, float, float]:
    """Return (fit, check, floor check) CPU seconds on one flight."""
    start = time.process_time()
    raw = est.run(flight, np.random.default_rng(0))
    fit = time.process_time() - start
    options = est.options()
    start = time.process_time()
    for _ in range(REPEATS):
        checked = apply_fit_check(raw, flight, data_noise_levels(flight), options)
    check = (time.process_time() - start) / REPEATS
    import dataclasses

    # what Estimator.fit records before the floor check: the input and noise model used
    choice = est.input_choice(flight)
    checked = dataclasses.replace(checked, input=None if choice is None else choice.input,
                                  noise_model=est.noise_model_used())
    start = time.process_time()
    for _ in range(REPEATS):
        floor_warnings(checked, flight, data_noise_levels(flight))
    floor = (time.process_time() - start) / REPEATS
    return fit, check, floor


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--flights", type=int, default=10)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    n = 3 if args.quick else args.flights
    scenario = aeroid.load_scenario(None)
    est = aeroid.make_estimator("output-error")
    flights = [aeroid.simulate_scenario(scenario, aeroid.make_noise("paper"), rng=seed)
               for seed in range(n)]
    round_times(flights[0], est)  # warm-up: CasADi build, numba compilation
    rows = np.array([round_times(f, est) for f in flights])
    fit, check, floor = np.median(rows, axis=0)
    share = np.median(rows[:, 1] / rows[:, 0])
    share_floor = np.median((rows[:, 1] + rows[:, 2]) / rows[:, 0])
    lines = [
        f"fit check against output-error's fit, reference flight (paper noise), {n} flights",
        f"- output-error fit (method alone), median CPU: {1e3 * fit:.1f} ms",
        f"- fit check (noise levels, size, whiteness, identifiability): {1e3 * check:.2f} ms "
        f"= {100 * share:.1f} % of the fit (median of per-flight ratios)",
        f"- with the Cramér-Rao floor check: {1e3 * (check + floor):.1f} ms "
        f"= {100 * share_floor:.1f} % of the fit",
    ]
    print("\n".join(lines))
    if args.quick:
        return
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, cwd=Path(__file__).parent).stdout.strip()
    head = (f"# Fit check cost\n\n`python benchmarks/bench_fitcheck.py` at {commit}, "
            f"{dt.date.today()}, {platform.processor() or platform.machine()}, "
            "CPU time (shared machine: medians).\n\n")
    RESULTS.write_text(head + "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
