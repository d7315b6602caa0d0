"""Benchmark the paper's three estimators: wall time and accuracy on the reference flight.

Run by hand from the repository root::

    python benchmarks/bench_estimators.py            # writes benchmarks/results/estimators.md
    python benchmarks/bench_estimators.py --quick    # 1 timing run, 3 flights, prints only

Timing: the paper's configuration (EAM-PSO and EBM-PSO 450 particles x 200 iterations;
SEBM-PSO 50/150/100/150 x 200) on the reference flight with the paper's noise (eq. 43,
seed 1), the median of ``--runs`` fits per method (each fit's ``wall_time_s``; the first
EAM fit of the process, which loads the numba kernels, is not timed).

Accuracy: ``--flights`` flights simulated with the paper's noise (seeds 0..N-1), each
method fitted with the flight's seed; mean |error| % per coefficient, beside the paper's
single-run Tables 3-4 (``aeroid/data/paper-results.csv``), labelled as the paper's.
EAM-PSO takes ``--eam-flights`` of them (its fits are ~50x slower), with both initial-
state options (``smoothed``, the default, and ``kinematic``).
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from aeroid.estimation import make_estimator
from aeroid.flights._noise import PaperNoise
from aeroid.flights._scenario import reference_scenario
from aeroid.flights._simulate import simulate_scenario
from aeroid.model._coefficients import NAMES

ROOT = Path(__file__).resolve().parents[1]
PAPER_RESULTS = ROOT / "aeroid" / "data" / "paper-results.csv"
PAPER_CONFIGS = ROOT / "aeroid" / "data" / "paper-configs.csv"
METHODS = ("eam-pso", "ebm-pso", "sebm-pso")
#: Accuracy-only variant: EAM-PSO with the initial roll rate from the roll angle.
EAM_KINEMATIC = "eam-pso kinematic"
PAPER_NAME = {"eam-pso": "EAM-PSO", "ebm-pso": "EBM-PSO", "sebm-pso": "SEBM-PSO"}
TARGET_S = {"eam-pso": 10.0, "ebm-pso": 1.0, "sebm-pso": 1.0}


def timings(runs: int, options: dict[str, dict]) -> dict[str, list[float]]:
    flight = simulate_scenario(reference_scenario(), PaperNoise(), rng=1)
    make_estimator("eam-pso", {"n_particles": 5, "n_iterations": 1}).fit(flight, rng=0)  # JIT
    out: dict[str, list[float]] = {}
    for method in METHODS:
        est = make_estimator(method, options.get(method))
        out[method] = [est.fit(flight, rng=k).wall_time_s for k in range(runs)]
        print(f"{method}: median {statistics.median(out[method]):.3f} s over {runs}",
              flush=True)
    return out


def accuracy(n_flights: int, n_eam: int, options: dict[str, dict]
             ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], dict[str, int]]:
    errors: dict[str, list[np.ndarray]] = {m: [] for m in (*METHODS, EAM_KINEMATIC)}
    closed: dict[str, list[np.ndarray]] = {m: [] for m in METHODS if m != "eam-pso"}
    failures = dict.fromkeys((*METHODS, EAM_KINEMATIC), 0)
    sc = reference_scenario()
    for seed in range(n_flights):
        flight = simulate_scenario(sc, PaperNoise(), rng=seed)
        truth = flight.true_coefficients
        for method in (*METHODS, EAM_KINEMATIC):
            if method.startswith("eam-pso") and seed >= n_eam:
                continue
            if method == EAM_KINEMATIC:
                opts = {**options.get("eam-pso", {}), "initial_state": "kinematic"}
                res = make_estimator("eam-pso", opts).fit(flight, rng=seed)
            else:
                res = make_estimator(method, options.get(method)).fit(flight, rng=seed)
            failures[method] += not res.success
            errors[method].append(res.relative_error_pct(truth))
            if method in closed:
                ls = np.asarray(res.info["closed_form_theta"])
                closed[method].append(np.abs(ls - truth) / np.abs(truth) * 100)
        print(f"flight {seed + 1}/{n_flights} done", flush=True)
    mean = {m: np.mean(v, axis=0) for m, v in errors.items() if v}
    mean_closed = {m: np.mean(v, axis=0) for m, v in closed.items() if v}
    return mean, mean_closed, failures


def paper_tables() -> pd.DataFrame:
    table = pd.read_csv(PAPER_RESULTS)
    table = table[table["table"].isin([3, 4])]
    return table.pivot(index="coefficient", columns="method", values="error_pct").loc[list(NAMES)]


def report(args: argparse.Namespace, times: dict[str, list[float]],
           mean: dict[str, np.ndarray], mean_closed: dict[str, np.ndarray],
           failures: dict[str, int], command: str) -> str:
    paper = paper_tables()
    configs = pd.read_csv(PAPER_CONFIGS).set_index("method")
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    lines = [
        "# Benchmark: the paper's estimators (EAM-PSO, EBM-PSO, SEBM-PSO)",
        "",
        f"Command: `{command}`  ",
        f"Date: {dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC; "
        f"{platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cores, Python {platform.python_version()}, numpy {np.__version__}; "
        f"load average at the end {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} "
        "(the machine is shared: timings are upper bounds).",
        "",
        "Default options (noise weighting, smoothing of both sides); reference flight with "
        "the paper's noise (eq. 43, xi = 0.05, position error 0.1).",
        "",
        f"## Wall time, paper configuration (median of {args.runs} fits, flight seed 1)",
        "",
        "| method | configuration | median [s] | min [s] | max [s] | target [s] "
        "| paper's time per run [s] (2.0 GHz PC) |",
        "|---|---|---|---|---|---|---|",
    ]
    conf = {"eam-pso": "450 x 200", "ebm-pso": "450 x 200", "sebm-pso": "50/150/100/150 x 200"}
    for m in METHODS:
        t = times[m]
        paper_t = configs.loc[PAPER_NAME[m], "average_time_s"]
        lines.append(f"| {m} | {conf[m]} | {statistics.median(t):.3f} | {min(t):.3f} | "
                     f"{max(t):.3f} | {TARGET_S[m]:g} | {paper_t:g} |")
    n_eam = min(args.eam_flights, args.flights)
    lines += [
        "",
        f"## Accuracy: mean |error| % over {args.flights} seeded flights "
        f"(EAM-PSO: {n_eam} flights)",
        "",
        "`LS` = the closed-form least-squares optimum of the same objective (unbounded; the "
        "PSO is held to the +-50 % box, so where LS lies outside, the PSO sits on the bound "
        "at exactly 50 %). The paper's columns are the PAPER's single-run Tables 3-4, not "
        "ours.",
        "",
        "| coef | eam-pso | eam-pso kinematic p0 | ebm-pso | ebm LS | sebm-pso | sebm LS "
        "| paper EAM-PSO (T3) | paper EBM-PSO (T4) | paper SEBM-PSO (T4) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for j, name in enumerate(NAMES):
        row = [name]
        for key, src in (("eam-pso", mean), (EAM_KINEMATIC, mean), ("ebm-pso", mean),
                         ("ebm-pso", mean_closed),
                         ("sebm-pso", mean), ("sebm-pso", mean_closed)):
            row.append(f"{src[key][j]:.2f}" if key in src else "-")
        row += [f"{paper.loc[name, PAPER_NAME[m]]:g}" for m in METHODS]
        lines.append("| " + " | ".join(row) + " |")
    lines += ["", "Failures (success=False): " + ", ".join(f"{m} {n}" for m, n in
                                                          failures.items()), ""]
    lines += [
        "## Reading the table",
        "",
        "- EBM-PSO and SEBM-PSO minimise the same quadratic objective; where the LS optimum "
        "is inside the box the PSO reaches it (test_paper_estimators checks 0.1 % against "
        "scipy's bounded least squares), so their errors are those of the objective, not "
        "of the optimiser.",
        "- Czq, Cl0, Clp and Cmq are noise-limited in the two-step method (reference "
        "README: the +-5 % roll-rate noise swamps the ~4 rad/s^2 roll acceleration, and "
        "the Czq, Cmq terms are 1-2 % of F_AZ, M_Y while step 1 carries the 10 % sensor "
        "position error): the LS column shows errors of 70-180 %, clipped at the +-50 % "
        "bound by the PSO.",
        "- EAM-PSO's Czd error comes from the 10 % position error of triad 1 (the "
        "lever-arm term R_x1 qdot in a_z1): with the true positions it falls below 1 % "
        "(checked by hand on seeds 1 and 3). The 'kinematic p0' column starts the "
        "simulation from a roll rate derived from the (noise-free) roll angle instead of "
        "the smoothed measured p (option initial_state).",
        "- The paper's numbers are single runs; ours are means over seeded flights.",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1 run, 3 flights, reduced EAM")
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--flights", type=int, default=20)
    parser.add_argument("--eam-flights", type=int, default=20)
    parser.add_argument("--output", type=Path, default=ROOT / "benchmarks" / "results" /
                        "estimators.md")
    args = parser.parse_args(argv)
    options: dict[str, dict] = {}
    if args.quick:
        args.runs, args.flights, args.eam_flights = 1, 3, 3
        options["eam-pso"] = {"n_particles": 60, "n_iterations": 40}
    command = "python benchmarks/bench_estimators.py " + " ".join(argv or sys.argv[1:])
    start = time.perf_counter()
    times = timings(args.runs, options)
    mean, mean_closed, failures = accuracy(args.flights, args.eam_flights, options)
    text = report(args, times, mean, mean_closed, failures, command.strip())
    text += f"Total benchmark time {time.perf_counter() - start:.0f} s.\n"
    print(text)
    if not args.quick:
        args.output.parent.mkdir(parents=True, exist_ok=True)
        args.output.write_text(text)
        print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
