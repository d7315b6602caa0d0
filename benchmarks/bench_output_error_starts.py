"""Output-error's fit time, this tree against another checkout, side by side.

Run by hand from the repository root::

    python benchmarks/bench_output_error_starts.py --old ../old-checkout
    python benchmarks/bench_output_error_starts.py --old ../old-checkout --quick  # prints only

Issue 18 changed how output-error starts and how it refits its noise law (the law's
likelihood maximum, :func:`baselines._gauss_newton.most_likely_law`, and a second start
at equation-error's estimate). This times the cost of that: on the paper-noise flights of
the reference scenario with the prior 10-25 % off (``bench_filter_passes.
flight_with_prior``, flight seeds 0..N-1), each round starts one fresh process per tree in
alternating order (both see the same machine load); each process fits every flight after
one warm-up fit and reports the CPU time of each fit (``time.process_time``). The old
tree runs output-error's defaults; this tree its defaults and
``equation_error_start = False`` (the prior start alone). Written to
``results/output_error_starts.md``: the median per configuration over all rounds, and
the median of the per-round ratio to the old defaults.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # see bench_baselines.py
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from bench_filter_passes import write  # noqa: E402

OUT = Path(__file__).parent / "results" / "output_error_starts.md"
#: Configurations timed per tree: label -> output-error options.
CONFIGS = {"old": {"defaults": {}},
           "new": {"defaults": {}, "prior start only": {"equation_error_start": False}}}
#: One timing process: aeroid from the tree on PYTHONPATH, the flights from this folder.
TIMING_CHILD = """
import json, sys, time
import aeroid
from bench_filter_passes import flight_with_prior
flights = [flight_with_prior("paper", seed) for seed in range(int(sys.argv[1]))]
out = {}
for label, options in json.loads(sys.argv[2]).items():
    estimator = aeroid.make_estimator("output-error", options)
    estimator.fit(flights[0], rng=0)  # build, compile and warm up
    out[label] = []
    for flight in flights:
        start = time.process_time()
        estimator.fit(flight, rng=0)
        out[label].append(time.process_time() - start)
print(json.dumps({"aeroid": aeroid.__file__, **out}))
"""


def time_trees(old: Path, n_flights: int, rounds: int) -> dict:
    """CPU time per fit in this tree and in ``old``, alternating; per-round medians."""
    here = Path(__file__).resolve().parent
    trees = {"new": here.parent, "old": old.resolve()}
    times: dict = {tree: {k: [] for k in CONFIGS[tree]} for tree in trees}
    ratios: dict = {k: [] for k in CONFIGS["new"]}
    for r in range(rounds):
        medians = {}
        for tree in (["old", "new"] if r % 2 == 0 else ["new", "old"]):
            env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(trees[tree]), str(here)])}
            done = subprocess.run(
                [sys.executable, "-c", TIMING_CHILD, str(n_flights), json.dumps(CONFIGS[tree])],
                env=env, cwd=trees[tree], capture_output=True, text=True, check=True)
            got = json.loads(done.stdout.strip().splitlines()[-1])
            if not Path(got.pop("aeroid")).is_relative_to(trees[tree]):
                raise SystemExit(f"the {tree} process did not import aeroid from {trees[tree]}")
            for k, v in got.items():
                times[tree][k] += v
                medians[(tree, k)] = float(np.median(v))
        for k in ratios:
            ratios[k].append(medians[("new", k)] / medians[("old", "defaults")])
        print(f"round {r + 1}/{rounds}: " + ", ".join(
            f"{tree} {k} {v:.3f} s" for (tree, k), v in medians.items()), flush=True)
    return {"times": times, "ratios": ratios}


def table(measured: dict) -> str:
    lines = ["| tree | output-error | median CPU time per fit [s] | / old defaults "
             "(median of rounds) |", "|---|---|---:|---:|"]
    old = float(np.median(measured["times"]["old"]["defaults"]))
    lines.append(f"| old | defaults (one start) | {old:.3f} | 1 |")
    for k, v in measured["times"]["new"].items():
        lines.append(f"| new | {k} | {np.median(v):.3f} "
                     f"| {np.median(measured['ratios'][k]):.2f} |")
    return "\n".join(lines)


def main() -> None:
    """Parse the arguments, time both trees, write or print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", type=Path, required=True, help="the checkout to time against")
    parser.add_argument("--flights", type=int, default=10)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="4 flights, 1 round, print only")
    parser.add_argument("--old-label", help="how to name the old tree (default: its commit)")
    args = parser.parse_args()
    n, rounds = (4, 1) if args.quick else (args.flights, args.rounds)
    measured = time_trees(args.old, n, rounds)
    text = table(measured)
    if args.quick:
        print(text)
        return
    old, new = (subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"],
                               capture_output=True, text=True).stdout.strip() or str(tree)
                for tree in (args.old, Path(__file__).resolve().parents[1]))
    old = args.old_label or f"commit {old}"
    write(OUT, "Output-error time per fit, old against new code",
          f"`python benchmarks/bench_output_error_starts.py --old <checkout> --flights {n} "
          f"--rounds {rounds}`; old = {old}, new = commit {new}. CPU time per fit on {n} "
          "paper-noise reference flights with the prior 10-25 % off", text)


if __name__ == "__main__":
    main()
