"""The EKF/UKF's passes against one pass and output-error, from a prior off the truth.

Run by hand from the repository root::

    python benchmarks/bench_filter_passes.py            # writes benchmarks/results/filter_passes.md
    python benchmarks/bench_filter_passes.py --quick    # 4 flights, prints only
    python benchmarks/bench_filter_passes.py --old ../old-checkout   # time, old vs new


On seeded flights of the reference scenario (flight seed 0..N-1), each with the prior
truth x (1 + s U(0.10, 0.25)), s a random sign per coefficient (issue 11's study set-up),
every estimator below fits the same flight. Conditions: the paper's noise (eq. 43 with
its 10 % sensor-position error) and the Gaussian IMU (``make_noise("gaussian")``
defaults, positions exact). Reported: mean |error| in % of the truth over the nine
coefficients and the flights, the coverage of the 95 % intervals (share of
coefficient-flights with ``|theta - truth| <= 1.96 stderr``), median wall time per fit
(indicative: the machine is shared), mean number of passes, and fits that warned or
failed.

``--old PATH`` times the EKF and UKF defaults instead, this tree against the checkout at
PATH, side by side: each round starts one fresh process per tree in alternating order
(so both see the same machine load); each process fits ``--flights`` paper-noise flights
(the flights above) after one warm-up fit and reports the CPU time of each fit
(``time.process_time``). Written to ``results/filter_speed.md``: the median per
estimator and tree over all rounds, and the median of the per-round ratio new / old.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # see bench_baselines.py
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import datetime as dt  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
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
SPEED_OUT = Path(__file__).parent / "results" / "filter_speed.md"
#: One timing process: aeroid from the tree on PYTHONPATH, the flights from this file.
TIMING_CHILD = """
import json, sys, time
import aeroid
from bench_filter_passes import flight_with_prior
flights = [flight_with_prior("paper", seed) for seed in range(int(sys.argv[1]))]
out = {}
for name in ("ekf", "ukf"):
    estimator = aeroid.make_estimator(name)
    estimator.fit(flights[0], rng=0)  # compile and warm up
    out[name] = []
    for flight in flights:
        start = time.process_time()
        estimator.fit(flight, rng=0)
        out[name].append(time.process_time() - start)
print(json.dumps({"aeroid": aeroid.__file__, **out}))
"""


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


def time_trees(old: Path, n_flights: int, rounds: int) -> dict:
    """CPU time per fit of the EKF/UKF defaults in this tree and in ``old``, alternating."""
    here = Path(__file__).resolve().parent
    trees = {"new": here.parent, "old": old.resolve()}
    times: dict = {tree: {"ekf": [], "ukf": []} for tree in trees}
    ratios: dict = {"ekf": [], "ukf": []}
    for r in tqdm(range(rounds), desc="rounds"):
        order = ["old", "new"] if r % 2 == 0 else ["new", "old"]
        median = {}
        for tree in order:
            env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(trees[tree]), str(here)])}
            # run in the tree: ``-c`` puts the working directory first on sys.path
            done = subprocess.run([sys.executable, "-c", TIMING_CHILD, str(n_flights)],
                                  env=env, cwd=trees[tree], capture_output=True, text=True,
                                  check=True)
            got = json.loads(done.stdout.strip().splitlines()[-1])
            if not Path(got.pop("aeroid")).is_relative_to(trees[tree]):
                raise SystemExit(f"the {tree} process did not import aeroid from {trees[tree]}")
            median[tree] = {k: float(np.median(v)) for k, v in got.items()}
            for k, v in got.items():
                times[tree][k] += v
        for k in ratios:
            ratios[k].append(median["new"][k] / median["old"][k])
    return {"times": times, "ratios": ratios}


def speed_table(measured: dict) -> str:
    lines = ["| estimator | old: median CPU time per fit [s] | new [s] | new / old "
             "(median of rounds) |", "|---|---:|---:|---:|"]
    for k in ("ekf", "ukf"):
        lines.append(f"| {k.upper()} (defaults, passes) "
                     f"| {np.median(measured['times']['old'][k]):.2f} "
                     f"| {np.median(measured['times']['new'][k]):.2f} "
                     f"| {np.median(measured['ratios'][k]):.2f} |")
    return "\n".join(lines)


def write(path: Path, title: str, how: str, text: str) -> None:
    """Write a results file: title, when, where and how it was measured, the table."""
    stamp = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    path.write_text(f"# {title}\n\nMeasured {stamp} on {platform.machine()}, "
                    f"{os.cpu_count()} cores (shared), {how}; see the script's docstring."
                    f"\n\n{text}\n")
    print(f"written: {path}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--flights", type=int, default=20)
    parser.add_argument("--quick", action="store_true", help="4 flights, print only")
    parser.add_argument("--old", type=Path, help="a checkout to time against (see above)")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    if args.old is not None:
        n = 4 if args.quick else min(args.flights, 5)
        measured = time_trees(args.old, n, args.rounds)
        old, new = (subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"],
                                   capture_output=True, text=True).stdout.strip() or "?"
                    for tree in (args.old, Path(__file__).resolve().parents[1]))
        text = speed_table(measured)
        print(text)
        if args.quick:
            return
        write(SPEED_OUT, "EKF/UKF time per fit, old against new code",
              f"{args.rounds} rounds x {n} paper-noise flights per tree, with "
              f"`python benchmarks/bench_filter_passes.py --old <checkout> --flights {n} "
              f"--rounds {args.rounds}`; old = commit {old}, new = commit {new}. CPU time "
              "of the fitting "
              "process (all its threads), so a loaded machine inflates both columns alike",
              text)
        return
    n = 4 if args.quick else args.flights
    start = time.perf_counter()
    text = table(measure(n))
    took = time.perf_counter() - start
    print(text)
    if args.quick:
        return
    write(OUT, "EKF/UKF passes vs one pass vs output-error",
          f"{n} flights per noise, {took:.0f} s, with "
          f"`python benchmarks/bench_filter_passes.py --flights {n}`. Prior 10-25 % off "
          "the truth per flight", text)


if __name__ == "__main__":
    main()
