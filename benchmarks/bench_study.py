"""Benchmark the study runner on the paper's Table 5 study (studies/paper_table5.toml).

Run by hand from the repository root::

    python benchmarks/bench_study.py            # writes benchmarks/results/study.md
    python benchmarks/bench_study.py --quick    # a few runs, prints only

Measured (wall clock, including process start-up, JIT cache loading and the truth
integration in every worker):

1. the study without EAM-PSO, ``--runs`` runs (default 100) with 2 local processes
   (target <= 5 min);
2. the speed-up of 2 local processes over 1 on the same ``--speedup-runs`` runs (default
   60) of the study without EAM-PSO (target >= 1.7x); each process pays a fixed start-up
   (spawn, imports, JIT cache, truth integration: a few seconds), so short studies gain
   less;
3. EAM-PSO alone on ``--eam-runs`` runs with 2 processes; the full study's time with
   EAM-PSO is extrapolated as (1) + 100 x (3) per run, and said so (target <= 30 min).

The machine may be shared: the load average before each measurement is recorded.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STUDY_FILE = ROOT / "studies" / "paper_table5.toml"
RESULTS = ROOT / "benchmarks" / "results" / "study.md"
FULL_RUNS = 100


def _subset(study, keep):
    specs = tuple(e for e in study.estimators if keep(e))
    return dataclasses.replace(study, estimators=specs)


def _timed(study, jobs):
    from aeroid.study import run_study

    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        outcome = run_study(study, tmp, jobs=jobs, progress=False)
        wall = time.perf_counter() - start
    fit_time = sum(r["wall_time_s"] or 0.0 for r in outcome.records)
    return {"runs": study.runs, "fits": len(outcome.records), "jobs": jobs, "wall_s": wall,
            "fit_time_s": fit_time, "failed": outcome.n_failed, "load": load}


def _line(name, m):
    return (f"| {name} | {m['runs']} | {m['fits']} | {m['jobs']} | {m['wall_s']:.1f} | "
            f"{m['fit_time_s']:.1f} | {m['failed']} | {m['load']:.2f} |")


def main(argv=None) -> int:
    """Run the benchmark; write ``benchmarks/results/study.md`` unless ``--quick``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=FULL_RUNS)
    parser.add_argument("--speedup-runs", type=int, default=60)
    parser.add_argument("--eam-runs", type=int, default=4)
    parser.add_argument("--quick", action="store_true", help="3/3/1 runs, print only")
    args = parser.parse_args(argv)
    if args.quick:
        args.runs, args.speedup_runs, args.eam_runs = 3, 3, 1

    from aeroid.study import load_study

    study = load_study(STUDY_FILE)
    fast = _subset(study, lambda e: e.method != "eam-pso")
    eam = _subset(study, lambda e: e.method == "eam-pso")

    rows = []
    print("warming the JIT cache...", file=sys.stderr)
    _timed(fast.with_runs(1), 1)
    m_fast = _timed(fast.with_runs(args.runs), 2)
    rows.append(_line("without EAM-PSO", m_fast))
    print(rows[-1], file=sys.stderr)
    m1 = _timed(fast.with_runs(args.speedup_runs), 1)
    rows.append(_line("without EAM-PSO (speed-up, 1 process)", m1))
    print(rows[-1], file=sys.stderr)
    m2 = _timed(fast.with_runs(args.speedup_runs), 2)
    rows.append(_line("without EAM-PSO (speed-up, 2 processes)", m2))
    print(rows[-1], file=sys.stderr)
    m_eam = _timed(eam.with_runs(args.eam_runs), 2)
    rows.append(_line("EAM-PSO only", m_eam))
    print(rows[-1], file=sys.stderr)

    speedup = m1["wall_s"] / m2["wall_s"]
    fast_100 = m_fast["wall_s"] * FULL_RUNS / args.runs
    eam_per_run = m_eam["wall_s"] / args.eam_runs
    full = fast_100 + FULL_RUNS * eam_per_run
    text = [
        "# Study runner benchmark (benchmarks/bench_study.py)",
        "",
        f"- date: {dt.datetime.now(dt.UTC).strftime('%Y-%m-%d %H:%M UTC')}; machine: "
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPU cores, "
        f"Python {platform.python_version()}; the machine was shared with other work "
        "(load average at the start of each measurement in the table)",
        f"- command: `python benchmarks/bench_study.py"
        f"{'' if args.runs == FULL_RUNS else f' --runs {args.runs}'}"
        f"{'' if args.speedup_runs == 60 else f' --speedup-runs {args.speedup_runs}'}"
        f"{'' if args.eam_runs == 4 else f' --eam-runs {args.eam_runs}'}`",
        f"- study: {STUDY_FILE.relative_to(ROOT)} (paper noise xi = 0.05, default options); "
        "wall time includes worker start-up, JIT cache loading and the truth integration",
        "",
        "| measurement | runs | fits | processes | wall [s] | sum of fit times [s] | "
        "failed | load |",
        "|:---|---:|---:|---:|---:|---:|---:|---:|",
        *rows,
        "",
        f"- {FULL_RUNS} runs without EAM-PSO, 2 processes: **{fast_100:.0f} s** "
        + ("(measured)" if args.runs == FULL_RUNS else f"(extrapolated from {args.runs} runs)")
        + " — target <= 300 s",
        f"- speed-up of 2 processes over 1 ({args.speedup_runs} runs): **{speedup:.2f}x** "
        "— target >= 1.7x",
        f"- EAM-PSO: {eam_per_run:.1f} s per run with 2 processes (measured on "
        f"{args.eam_runs} runs); the full study with EAM-PSO, {FULL_RUNS} runs: "
        f"**{full / 60:.1f} min** (extrapolated: {fast_100:.0f} s + {FULL_RUNS} x "
        f"{eam_per_run:.1f} s) — target <= 30 min",
    ]
    busy = max(m1["load"], m2["load"])
    if busy > (os.cpu_count() or 1):  # the 1-min average also holds our previous phase
        text.append(f"- caution: the load average was {busy:.1f} on {os.cpu_count()} cores during "
                    "the speed-up measurement (other work on the machine): the 2 processes "
                    "competed with it for the cores, so this speed-up says little about the "
                    "runner (compare the sum of fit times: each fit ran "
                    f"{m2['fit_time_s'] / max(m1['fit_time_s'], 1e-9):.2f}x slower with 2 "
                    "processes)")
    text.append("")
    report = "\n".join(text)
    print(report)
    if not args.quick:
        RESULTS.parent.mkdir(parents=True, exist_ok=True)
        RESULTS.write_text(report)
        print(f"wrote {RESULTS}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
