"""Benchmark the README main job on a fresh clone: first run (empty caches) and warm.

Run by hand from the repository root (commit first: the clone is of HEAD)::

    python benchmarks/bench_first_run.py            # writes benchmarks/results/first_run.md
    python benchmarks/bench_first_run.py --rounds 1 --no-write

What it does, per round: ``git clone`` this repository into a temporary folder, then
runs the README main job's command, ``aeroid study`` (the quick default study), twice in
the clone with the clone first on ``PYTHONPATH`` (the ``pip install -e .`` of the README
is left out: it installs, it does not compile; here it would re-point the shared
environment's install):

1. cold: ``NUMBA_CACHE_DIR`` and ``AEROID_CASADI_CACHE`` are new empty folders and the
   clone has no ``__pycache__`` (Python's bytecode, numba's kernels and the C model are
   all built on this run);
2. warm: the same command again with the same folders.

Wall time, CPU time of the child process, and the compile notices the command printed
(``aeroid: compiled NAME in S s``: numba's kernels and the C model) are recorded. The
machine may be shared: the load average before and after each run is recorded beside it.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import platform
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "first_run.md"
COMMAND = ["-c", "import sys; from aeroid.cli import main; sys.exit(main())", "study"]
COMPILED = re.compile(r"^aeroid: compiled (.+) in ([0-9.]+) s$", re.MULTILINE)
#: The target of issue 19: the README main job's first run on a fresh clone.
TARGET_S = 60.0


def _run(clone: Path, caches: Path, out: Path) -> dict[str, object]:
    env = {**os.environ, "PYTHONPATH": str(clone), "NUMBA_CACHE_DIR": str(caches / "numba"),
           "AEROID_CASADI_CACHE": str(caches / "casadi")}
    load = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, *COMMAND, "--out", str(out)], cwd=clone, env=env,
                          capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    load_after = os.getloadavg()[0]
    if done.returncode != 0:
        raise SystemExit(f"the main job failed ({done.returncode}): {done.stderr[-2000:]}")
    return {"wall": wall, "cpu": (after.ru_utime - before.ru_utime)
            + (after.ru_stime - before.ru_stime), "load": load, "load_after": load_after,
            "compiled": COMPILED.findall(done.stderr)}


def measure(rounds: int) -> list[tuple[str, dict[str, object]]]:
    """Return (kind, measurement) for ``rounds`` x (cold, warm) on fresh clones."""
    rows = []
    for _ in range(rounds):
        with tempfile.TemporaryDirectory(prefix="aeroid-first-run-") as tmp:
            clone = Path(tmp) / "clone"
            subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
            for kind in ("cold", "warm"):
                rows.append((kind, _run(clone, Path(tmp) / "caches", Path(tmp) / kind)))
                print(kind, rows[-1], file=sys.stderr)
    return rows


def report(rows: list[tuple[str, dict[str, object]]]) -> str:
    """Return the markdown of the measurements."""
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, text=True,
                          capture_output=True, check=False).stdout.strip()
    lines = ["# First run of the README main job (benchmarks/bench_first_run.py)", "",
             f"- date: {dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC; commit {head}; "
             f"machine: {platform.machine()}, {os.cpu_count()} CPU cores, Python "
             f"{platform.python_version()}; shared with other work (1-minute load average "
             "before and after each run in the table)",
             "- command: `python benchmarks/bench_first_run.py`: a fresh `git clone`, then "
             "`aeroid study` with empty NUMBA_CACHE_DIR and AEROID_CASADI_CACHE (cold) "
             "and again (warm)", "",
             "| run | wall [s] | CPU [s] | load before / after | compiled (s) |",
             "|:---|---:|---:|---:|:---|"]
    for kind, m in rows:
        compiled = ", ".join(f"{n} {float(s):.1f}" for n, s in m["compiled"]) or "-"
        lines.append(f"| {kind} | {m['wall']:.1f} | {m['cpu']:.1f} | {m['load']:.2f} / "
                     f"{m['load_after']:.2f} | "
                     f"{compiled} |")
    cold = [m for k, m in rows if k == "cold"]
    wall = max(float(m["wall"]) for m in cold)
    cpu = max(float(m["cpu"]) for m in cold)
    lines += ["", f"- cold: worst wall {wall:.1f} s of {len(cold)} (target <= "
              f"{TARGET_S:.0f} s: {'met' if wall <= TARGET_S else 'MISSED'} at this load); "
              f"worst CPU time {cpu:.1f} s (the wall time on an idle machine is about "
              "the CPU time: the run is one process, numba's threads aside)"]
    return "\n".join(lines) + "\n"


def main() -> int:
    """Measure and print (and write :data:`RESULTS`)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=2, help="fresh clones (default 2)")
    parser.add_argument("--no-write", action="store_true", help="print only")
    args = parser.parse_args()
    text = report(measure(args.rounds))
    print(text)
    if not args.no_write:
        RESULTS.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
