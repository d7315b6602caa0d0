"""The EKF/UKF's passes against one pass and output-error, from a prior off the truth.

Run by hand from the repository root::

    python benchmarks/bench_filter_passes.py            # writes benchmarks/results/filter_passes.md
    python benchmarks/bench_filter_passes.py --quick    # 4 flights, prints only

On seeded flights of the reference scenario (flight seed 0..N-1), each with the prior
truth x (1 + s U(0.10, 0.25)), s a random sign per coefficient (issue 11's study set-up),
every estimator below fits the same flight. Conditions: the paper's noise (eq. 43 with
its 10 % sensor-position error) and the Gaussian IMU (``make_noise("gaussian")``
defaults, positions exact). Reported: mean |error| in % of the truth over the nine
coefficients and the flights, the coverage of the 95 % intervals (share of
coefficient-flights with ``|theta - truth| <= 1.96 stderr``), median wall time per fit
(indicative: the machine is shared), mean number of passes, and fits that warned or
failed.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # see bench_baselines.py
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import datetime as dt  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

import aeroid  # noqa: E402

Z95 = 1.959963984540054
ESTIMATORS = {
    "EKF, one pass": ("ekf", {"max_passes": 1}),
    "EKF (passes, default)": ("ekf", {}),
    "UKF, one pass": ("ukf", {"max_passes": 1}),
    "UKF (passes, default)": ("ukf", {}),
    "output-error": ("output-error", {}),
}
NOISES = {"paper (xi 0.05, 10 % positions)": "paper", "Gaussian IMU": "gaussian"}
OUT = Path(__file__).parent / "results" / "filter_passes.md"


def flight_with_prior(noise: str, seed: int) -> aeroid.Flight:
    """The reference flight under ``noise`` (seed) with the prior 10-25 % off."""
    scenario = aeroid.reference_scenario()
    truth = scenario.coefficient_vector
    flight = aeroid.simulate_scenario(scenario, aeroid.make_noise(noise), rng=seed)
    rng = np.random.default_rng(1000 + seed)
    prior = truth * (1 + rng.choice([-1.0, 1.0], 9) * rng.uniform(0.10, 0.25, 9))
    return dataclasses.replace(flight, airframe=flight.airframe.replace(prior=tuple(prior)))


def measure(n_flights: int) -> list[dict]:
    truth = aeroid.reference_scenario().coefficient_vector
    rows = []
    for noise_label, noise in NOISES.items():
        rec = {label: [] for label in ESTIMATORS}
        for seed in tqdm(range(n_flights), desc=noise_label):
            flight = flight_with_prior(noise, seed)
            for label, (name, options) in ESTIMATORS.items():
                start = time.perf_counter()
                res = aeroid.make_estimator(name, options).fit(flight, rng=0)
                rec[label].append((res, time.perf_counter() - start))
        for label, fits in rec.items():
            good = [r for r, _ in fits if r.success]
            err = np.array([np.abs(r.theta / truth - 1) * 100 for r in good])
            cov = np.array([np.abs(r.theta - truth) <= Z95 * r.stderr for r in good])
            rows.append({
                "noise": noise_label, "estimator": label,
                "error": err.mean(), "coverage": cov.mean(),
                "per_coef": np.round(err.mean(axis=0), 2),
                "time": float(np.median([t for _, t in fits])),
                "passes": float(np.mean([r.info.get("passes", 0) for r in good])),
                "warned": sum(bool(r.warnings) for r, _ in fits),
                "failed": len(fits) - len(good),
            })
    return rows


def table(rows: list[dict]) -> str:
    lines = ["| noise | estimator | mean abs error [%] | coverage | median time [s] "
             "| passes | warned | failed |", "|---|---|---:|---:|---:|---:|---:|---:|"]
    lines += [f"| {r['noise']} | {r['estimator']} | {r['error']:.3f} | {r['coverage']:.3f} "
              f"| {r['time']:.2f} | {r['passes']:.1f} | {r['warned']} | {r['failed']} |"
              for r in rows]
    lines += ["", "Mean |error| per coefficient [%] (" + ", ".join(aeroid.NAMES) + "):", ""]
    lines += [f"- {r['noise']}, {r['estimator']}: "
              + ", ".join(f"{v:.2f}" for v in r["per_coef"]) for r in rows]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--flights", type=int, default=20)
    parser.add_argument("--quick", action="store_true", help="4 flights, print only")
    args = parser.parse_args()
    n = 4 if args.quick else args.flights
    start = time.perf_counter()
    text = table(measure(n))
    took = time.perf_counter() - start
    print(text)
    if args.quick:
        return
    stamp = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    OUT.write_text(
        "# EKF/UKF passes vs one pass vs output-error\n\n"
        f"Measured {stamp} on {platform.machine()}, {os.cpu_count()} cores (shared), "
        f"{n} flights per noise, {took:.0f} s, with "
        f"`python benchmarks/bench_filter_passes.py --flights {n}`. "
        "Prior 10-25 % off the truth per flight; see the script's docstring.\n\n"
        + text + "\n")
    print(f"written: {OUT}")


if __name__ == "__main__":
    main()
