"""Peak memory of one equation-error fit on a long log, old tree vs new (issue 21).

Run by hand from the repository root::

    python benchmarks/bench_memory.py --old /work/main --seconds 60 240 1120

For each length the reference scenario is recorded from 0 s for that long at 500 Hz
with the paper's noise (seed 1) and written as CSV with its sidecar (airframe only: the
metadata outgrow the sidecar's size limit), by this tree. Then
each tree, in a fresh interpreter with ``PYTHONPATH`` set to it, reads the CSV, fits
``equation-error`` (defaults, ``Estimator.fit``: validation, the fit, the fit check and
the floor warnings) and reports its peak resident memory (``ru_maxrss``) before and
after the fit: the difference is what the fit added on top of reading the log. The
numbers go to ``benchmarks/results/memory.md``.

With ``--stages`` (this tree only) each length is fitted once more under ``tracemalloc``
(numpy's arrays are traced) with every stage of the fit wrapped: the peak a stage
allocates above what was held when it started, and its growth per sample between the
shortest and the longest log (what is left per sample, stage by stage). Those go to
``benchmarks/results/memory_stages.md``::

    python benchmarks/bench_memory.py --stages --seconds 60 240
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "memory.md"
STAGE_RESULTS = ROOT / "benchmarks" / "results" / "memory_stages.md"

SIMULATE = """
import sys
from aeroid.flights import Manoeuvre, PaperNoise, load_scenario, simulate
s = load_scenario(None)
import dataclasses
flight = simulate(s.airframe, s.coefficient_vector, Manoeuvre(window_s=(0.0, float(sys.argv[1]))),
                  PaperNoise(), rng=1)
# the metadata (switch knots) grow with the flight beyond the old tree's sidecar size
# limit (1 MB; now the CSV's size plus 1 MB); the fit uses none of it (input = "hold")
dataclasses.replace(flight, metadata={}).write(sys.argv[2])
print(flight.n_samples)
"""

FIT = """
import resource, sys, time, warnings
from aeroid.estimation import make_estimator
from aeroid.flights import read_flight
warnings.simplefilter("ignore")
flight = read_flight(sys.argv[1])
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
start = time.perf_counter()
result = make_estimator("equation-error").fit(flight, rng=0)
wall = time.perf_counter() - start
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(before / 1024, after / 1024, wall, result.success, float(result.theta[0]))
"""

STAGES = """
import functools, json, sys, tracemalloc, warnings
import aeroid.estimation as rc
import aeroid.estimation._estimator as est
import aeroid.estimation._fitcheck as fc
import aeroid.estimation._reconstruct as rcm
try:  # the blocked regressors' module (this tree); the old tree calls them from rcm
    import aeroid.estimation._regression as rgm
except ImportError:
    rgm = rcm
import baselines.equation_error as ee
from aeroid.estimation import make_estimator
from aeroid.flights import Flight, read_flight
warnings.simplefilter("ignore")
flight = read_flight(sys.argv[1])
peaks, stack = {}, []

def wrap(owner, name, label):
    inner = getattr(owner, name)

    @functools.wraps(inner)
    def traced(*args, **kwargs):
        now, peak = tracemalloc.get_traced_memory()
        if stack:
            stack[-1][1] = max(stack[-1][1], peak)
        tracemalloc.reset_peak()
        stack.append([now, 0])
        try:
            return inner(*args, **kwargs)
        finally:
            _, peak = tracemalloc.get_traced_memory()
            entry, inside = stack.pop()
            top = max(inside, peak)
            peaks[label] = max(peaks.get(label, 0), top - entry)
            if stack:
                stack[-1][1] = max(stack[-1][1], top)
    setattr(owner, name, traced)

for owner, name, label in [
        (Flight, "validate", "validate"), (ee.EquationErrorEstimator, "run", "run (the fit)"),
        (rc, "reconstruct", "run: reconstruct"), (rc, "ebm_regression", "run: ebm_regression"),
        (rgm, "regressors", "run: regressors (of one time block, or all: old tree)"),
        (ee, "solve_subproblems", "run: solve_subproblems"),
        (rc, "regression_fit", "run: regression_fit"),
        (ee, "roll_floor", "run: roll_floor (gyro-only floor)"),
        (est, "data_noise_levels", "data_noise_levels"),
        (est, "apply_fit_check", "apply_fit_check"),
        (fc, "fit_check", "apply_fit_check: fit_check"),
        (est, "floor_warnings", "floor_warnings"),
        (fc, "data_floor", "floor_warnings: data_floor")]:
    wrap(owner, name, label)
estimator = make_estimator("equation-error")
tracemalloc.start()
wrap(type(estimator), "fit", "fit (all)")
estimator.fit(flight, rng=0)
print(json.dumps({"n": flight.n_samples, "peaks": peaks}))
"""


def _python(code: str, tree: Path, *args: str) -> str:
    env = {**os.environ, "PYTHONPATH": str(tree)}
    done = subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True,
                          text=True, cwd=tempfile.gettempdir())  # not a tree's root: "-c"
    # puts the working directory first on sys.path, ahead of PYTHONPATH
    if done.returncode:
        raise SystemExit(f"{tree}: {done.stderr.strip().splitlines()[-1]}")
    return done.stdout.strip().splitlines()[-1]


def main() -> None:
    """Measure and write the results file."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", type=Path, help="checkout of the old tree")
    parser.add_argument("--seconds", type=float, nargs="+", default=[60.0, 240.0])
    parser.add_argument("--stages", action="store_true",
                        help="this tree's stages under tracemalloc (no --old)")
    args = parser.parse_args()
    if args.stages:
        stages(args.seconds)
        return
    if args.old is None:
        parser.error("--old is required (or --stages)")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seconds in args.seconds:
            path = Path(tmp) / f"flight{seconds:g}.csv"
            n = int(_python(SIMULATE, ROOT, f"{seconds}", str(path)))
            size_mb = path.stat().st_size / 1e6
            for label, tree in (("old", args.old), ("new", ROOT)):
                before, after, wall, ok, cx = _python(FIT, tree, str(path)).split()
                rows.append((n, size_mb, label, float(before), float(after), float(wall),
                             ok, float(cx)))
                print(rows[-1], flush=True)
    lines = [
        "# Peak memory of an equation-error fit on long logs (benchmarks/bench_memory.py)",
        "",
        f"{dt.date.today()}, {platform.processor() or platform.machine()}, Python "
        f"{platform.python_version()}; old tree {args.old}.",
        "",
        "| samples | CSV MB | tree | RSS before fit MB | peak RSS MB | fit adds MB "
        "| fit adds B/sample | wall s | success | Cx |",
        "|---:|---:|---|---:|---:|---:|---:|---:|---|---:|",
    ]
    for n, size_mb, label, before, after, wall, ok, cx in rows:
        added = max(after - before, 0.0)
        lines.append(f"| {n} | {size_mb:.1f} | {label} | {before:.0f} | {after:.0f} | "
                     f"{added:.0f} | {added * 2**20 / n:.0f} | {wall:.1f} | {ok} | {cx:.5f} |")
    RESULTS.write_text("\n".join(lines) + "\n")
    print(RESULTS.read_text())


def stages(seconds: list[float]) -> None:
    """Measure each stage's traced peak on logs of these lengths; write the results file."""
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        for length in seconds:
            path = Path(tmp) / f"flight{length:g}.csv"
            _python(SIMULATE, ROOT, f"{length}", str(path))
            runs.append(json.loads(_python(STAGES, ROOT, str(path))))
            print(runs[-1], flush=True)
    first, last = runs[0], runs[-1]
    lines = [
        "# Peak traced memory of each stage of an equation-error fit "
        "(benchmarks/bench_memory.py --stages)",
        "",
        f"{dt.date.today()}, Python {platform.python_version()}, numpy arrays traced by "
        "tracemalloc; a stage's peak is what it allocates above what was held when it "
        "started (nested stages are inside their parent's figure).",
        "",
        "| stage | " + " | ".join(f"{r['n']} samples MB" for r in runs)
        + " | B/sample (slope) |",
        "|---|" + "---:|" * (len(runs) + 1),
    ]
    for label in first["peaks"]:
        values = [r["peaks"].get(label, 0) for r in runs]
        slope = ((last["peaks"].get(label, 0) - first["peaks"].get(label, 0))
                 / max(last["n"] - first["n"], 1))
        lines.append(f"| {label} | " + " | ".join(f"{v / 2**20:.1f}" for v in values)
                     + f" | {slope:.0f} |")
    STAGE_RESULTS.write_text("\n".join(lines) + "\n")
    print(STAGE_RESULTS.read_text())


if __name__ == "__main__":
    main()
