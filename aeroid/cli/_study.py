"""``aeroid study [STUDY.toml] [--runs N] [--jobs N] [--scheduler ADDR | --dask-local N]
[--out DIR] [--resume] [--no-progress]``.

Without a file it runs the quick default study (``aeroid/data/quick_study.toml``);
estimators of the quick study that are not installed are skipped with a warning line
(a user's study with an unknown estimator fails on load instead). The report goes to
``results/<study name>/`` unless ``--out`` says otherwise; the last line printed says
where it is.
"""

from __future__ import annotations

import argparse
import shlex
import sys

from aeroid.errors import StudyError


def study(args: argparse.Namespace) -> int:
    """Run ``aeroid study``; return the exit status (0 also when some fits failed)."""
    from pathlib import Path

    from aeroid.study._design import load_study
    from aeroid.study._report import write_report
    from aeroid.study._runner import run_study

    design = load_study(args.study)
    for item in design.skipped:
        print(f"warning: quick study: estimator {item} is not installed; skipped",
              file=sys.stderr)
    if args.runs is not None:
        if args.runs < 1:
            raise StudyError(f"--runs must be >= 1, got {args.runs}")
        design = design.with_runs(args.runs)
    out = args.out if args.out is not None else Path("results") / design.name
    where = ("Dask scheduler " + args.scheduler if args.scheduler else
             f"local Dask cluster of {args.dask_local}" if args.dask_local else
             f"{args.jobs} process(es)")
    print(f"study {design.name}: {design.runs} runs x {len(design.noise)} noise x "
          f"{len(design.estimators)} estimators = {design.n_fits} fits on {where}",
          file=sys.stderr)
    outcome = run_study(design, out, jobs=args.jobs, scheduler=args.scheduler,
                        dask_local=args.dask_local, resume=args.resume,
                        progress=False if args.no_progress else None)
    command = "aeroid " + " ".join(shlex.quote(a) for a in sys.argv[1:]) \
        if Path(sys.argv[0]).name == "aeroid" else ""
    report = write_report(design, out, outcome.records, command=command)
    print(f"{outcome.n_new} new fits in {outcome.wall_time_s:.1f} s; "
          f"{outcome.n_failed} of {len(outcome.records)} fits failed", file=sys.stderr)
    print(f"report: {report}")
    return 0


__all__ = ["study"]
