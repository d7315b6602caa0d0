"""The EKF and UKF with Mach tables beside output-error on the Mach sweep (issue 23).

Run by hand from the repository root (one process; the seeds one after another)::

    python benchmarks/bench_kalman_tables.py --seeds 0 1 2 3 4 --out /tmp/kt.jsonl
    python benchmarks/bench_kalman_tables.py --summary /tmp/kt.jsonl
    python benchmarks/bench_kalman_tables.py --seeds 0 1 --window 6 --methods ekf ukf

The truth of ``studies/mach_sweep.toml``'s scenario (a coast through Mach 2.19 -> 1.11
in 20 s, Cx and Cmq tables at 5 knots, +-15 %) is integrated once (``--window S``: only
its first S seconds from 0.5 s, the fits' knots then the truth's knots within that
Mach range); each seed records it with the scenario's tactical-IMU noise and fits it with
each method at ``--substeps`` RK4 steps per sample (default 4, the study's output-error:
at the 60-90 rad/s roll rate 2 bias Cma, Cl0, Clp by 1-1.7 se, and the EKF's default 1
puts Cma 15 se off on the first 6 s). One JSON line per fit: success, message, wall time
(``time.perf_counter`` around ``fit``, this process, the machine's other load included)
and each parameter's error in its own standard errors. ``--summary`` prints per method
each table point's |error| / se (mean, max) and its coverage of the 95 % intervals (with
the exact binomial interval), and the median wall time.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import aeroid  # noqa: E402
from aeroid.flights import load_scenario, noise_for, record_flight, simulate_truth  # noqa: E402
from aeroid.model import TableSpec  # noqa: E402

SCENARIO = Path(__file__).parents[1] / "studies" / "scenarios" / "mach_sweep.toml"
METHODS = ("ekf", "output-error", "ukf")


def _flights(window: float | None):
    """The scenario, its truth (first ``window`` s) and the fits' knots within it."""
    scenario = load_scenario(SCENARIO)
    manoeuvre = scenario.manoeuvre
    if window is not None:
        start = manoeuvre.window_s[0]
        manoeuvre = dataclasses.replace(manoeuvre, window_s=(start, start + window))
    true_p = np.array(scenario.coefficients, dtype=float)
    truth = simulate_truth(scenario.airframe, true_p, manoeuvre, tables=scenario.tables)
    return scenario, manoeuvre, true_p, truth


def run(seeds: list[int], out: Path, methods: tuple[str, ...], substeps: int,
        window: float | None) -> None:
    """Fit every seed with every method; one JSON line per fit appended to ``out``."""
    start = time.perf_counter()
    scenario, manoeuvre, true_p, truth = _flights(window)
    noise = noise_for(aeroid.model.read_toml(SCENARIO), "gaussian")
    print(f"truth integrated in {time.perf_counter() - start:.1f} s", flush=True)
    names = scenario.tables.parameter_names()
    truth_of = dict(zip(names, true_p, strict=True))
    for seed in seeds:
        flight = record_flight(scenario.airframe, true_p, manoeuvre, truth, noise, rng=seed,
                               tables=scenario.tables)
        if window is not None:  # the truth's knots within the window's Mach range
            mach = flight.airframe.mach_tables(flight.states()).mach(flight.states())
            knots = tuple((n, tuple(k for j, k in enumerate(ks)
                                    if k > mach.min() or ks[min(j + 1, len(ks) - 1)] > mach.min()))
                          for n, ks in scenario.tables.knots)  # the last knot below, then
            flight = dataclasses.replace(flight, airframe=flight.airframe.replace(
                tables=TableSpec(knots)))
        for method in methods:
            t0 = time.perf_counter()
            result = aeroid.make_estimator(method, {"substeps": substeps}).fit(flight, rng=seed)
            wall = time.perf_counter() - t0
            row = {"seed": seed, "method": method, "substeps": substeps, "window": window,
                   "success": bool(result.success), "message": result.message,
                   "wall_s": wall, "names": list(result.names), "theta": result.theta.tolist(),
                   "stderr": result.stderr.tolist(),
                   "z": ((result.theta - np.array([truth_of[n] for n in result.names]))
                         / result.stderr).tolist(),
                   "floor": [result.info.get("table_floor", {}).get(n, float("nan"))
                             for n in result.names]}
            with out.open("a") as f:
                f.write(json.dumps(row) + "\n")
            worst = max(abs(z) for z, n in zip(row["z"], row["names"], strict=True) if "@" in n)
            print(f"seed {seed} {method:13s} {'ok' if result.success else 'refused':8s} "
                  f"{wall:6.1f} s  max |z| of the points {worst:.2f}  {result.message[:80]}",
                  flush=True)


def summary(path: Path) -> None:
    """Print per method each table point's |z| and coverage, and the wall time."""
    from scipy.stats import binomtest

    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    for method in METHODS:
        these = [r for r in rows if r["method"] == method]
        if not these:
            continue
        ok = [r for r in these if r["success"]]
        wall = np.array([r["wall_s"] for r in these])
        print(f"{method}: {len(ok)} of {len(these)} fits successful; wall time median "
              f"{np.median(wall):.1f} s (range {wall.min():.1f}-{wall.max():.1f})")
        if not ok:
            continue
        names = ok[0]["names"]
        z = np.abs(np.array([r["z"] for r in ok]))
        ratio = np.array([r["stderr"] for r in ok]) / np.array([r["floor"] for r in ok])
        for j, name in enumerate(names):
            k = int(np.sum(z[:, j] <= 1.96))
            ci = binomtest(k, len(ok)).proportion_ci(method="exact")
            print(f"    {name:12s} |z| mean {z[:, j].mean():.2f} max {z[:, j].max():.2f}  "
                  f"within 1.96 se {k} of {len(ok)} ({ci.low:.2f}-{ci.high:.2f})  "
                  f"se/floor {np.median(ratio[:, j]):.2f}"
                  + ("" if "@" in name else "  (constant)"))
        points = [j for j, n in enumerate(names) if "@" in n]
        k, n = int(np.sum(z[:, points] <= 1.96)), z[:, points].size
        ci = binomtest(k, n).proportion_ci(method="exact")
        print(f"    table points pooled: {k} of {n} = {k / n:.3f} ({ci.low:.3f}-{ci.high:.3f})"
              f", within 3 se {np.mean(z[:, points] <= 3.0):.3f}")


def main() -> None:
    """Command line (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="*", default=[0, 1, 2, 3, 4])
    parser.add_argument("--out", type=Path, default=Path("kalman_tables.jsonl"))
    parser.add_argument("--methods", nargs="*", default=["ekf", "output-error"],
                        choices=METHODS)
    parser.add_argument("--substeps", type=int, default=4, help="RK4 steps per sample")
    parser.add_argument("--window", type=float, help="record only the first S seconds")
    parser.add_argument("--summary", type=Path)
    args = parser.parse_args()
    if args.summary:
        summary(args.summary)
    else:
        run(args.seeds, args.out, tuple(args.methods), args.substeps, args.window)


if __name__ == "__main__":
    main()
