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
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "memory.md"

SIMULATE = """
import sys
from aeroid.flights import Manoeuvre, PaperNoise, load_scenario, simulate
s = load_scenario(None)
import dataclasses
flight = simulate(s.airframe, s.coefficient_vector, Manoeuvre(window_s=(0.0, float(sys.argv[1]))),
                  PaperNoise(), rng=1)
# the metadata (switch knots, the manoeuvre's record) grow with the flight beyond the
# sidecar's size limit; the fit uses none of it (input = "hold")
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
    parser.add_argument("--old", type=Path, required=True, help="checkout of the old tree")
    parser.add_argument("--seconds", type=float, nargs="+", default=[60.0, 240.0])
    args = parser.parse_args()
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


if __name__ == "__main__":
    main()
