"""``aeroid study [STUDY.toml] [--runs N] [--jobs N] [--scheduler ADDR | --dask-local N]
[--out DIR] [--resume | --overwrite] [--no-progress] [--quiet]``.

Without a file it runs the quick default study (``aeroid/data/quick_study.toml``);
estimators of the quick study that are not installed are skipped with a warning line
(a user's study with an unknown estimator fails on load instead). The report goes to
``results/<study name>/`` unless ``--out`` says otherwise; the last line printed says
where it is. A folder that already holds a study's results is refused unless
``--resume`` (complete it) or ``--overwrite`` (move it aside into ``previous-N/``).
One study writes a folder at a time (``study.lock``, :mod:`aeroid.study._lock`); a
report that cannot be written (a full disk) keeps the records and says so in one line.
"""

from __future__ import annotations

import argparse
import logging
import re
import shlex
import sys
from pathlib import Path

from aeroid.errors import StudyError


def default_out(name: str) -> Path:
    """Return ``results/<name>`` with the name reduced to letters, digits and ``_+=-``.

    The folder is always a child of ``results/``, whatever the study's name.
    """
    return Path("results") / (re.sub(r"[^A-Za-z0-9_+=-]+", "_", name).strip("_") or "study")


def study(args: argparse.Namespace) -> int:
    """Run ``aeroid study``; return the exit status (0 also when some fits failed)."""
    from aeroid.study import (
        check_out_dir,
        check_scheduler,
        load_study,
        run_study,
        study_lock,
        write_report,
    )

    if args.scheduler is not None:
        check_scheduler(args.scheduler)
    if args.resume and args.overwrite:
        raise StudyError("give --resume or --overwrite, not both")
    if args.out is not None:
        check_out_dir(args.out)
    design = load_study(args.study)
    for item in design.skipped:
        print(f"warning: quick study: estimator {item} is not installed; skipped",
              file=sys.stderr)
    if args.runs is not None:
        if args.runs < 1:
            raise StudyError(f"--runs must be >= 1, got {args.runs}")
        design = design.with_runs(args.runs)
    out = args.out if args.out is not None else default_out(design.name)
    where = ("Dask scheduler " + args.scheduler if args.scheduler else
             f"local Dask cluster of {args.dask_local}" if args.dask_local else
             f"{args.jobs} process(es)")
    print(f"study {design.name}: {design.runs} runs x {len(design.noise)} noise x "
          f"{len(design.estimators)} estimators = {design.n_fits} fits on {where}",
          file=sys.stderr)
    with study_lock(out) as notes:
        for note in notes:
            print(f"aeroid: {note}", file=sys.stderr)
        outcome = run_study(design, out, jobs=args.jobs, scheduler=args.scheduler,
                            dask_local=args.dask_local, resume=args.resume,
                            overwrite=args.overwrite,
                            progress=False if args.no_progress or getattr(args, "quiet", False)
                            else None)
        command = "aeroid " + " ".join(shlex.quote(a) for a in sys.argv[1:]) \
            if Path(sys.argv[0]).name == "aeroid" else ""
        try:
            report = write_report(design, out, outcome.records, command=command)
        except (StudyError, OSError) as exc:  # a full disk: the records are safe already
            reason = " ".join(str(exc).split()) if isinstance(exc, StudyError) else \
                f"{exc.filename or out}: {exc.strerror or exc}"
            raise StudyError(f"the report was not written ({reason}); all "
                             f"{len(outcome.records)} fit records are kept in "
                             f"{out / 'results.jsonl'}: free some space, then run the same "
                             "command with --resume to write the report") from None
    print(f"{outcome.n_new} new fits in {outcome.wall_time_s:.1f} s; "
          f"{outcome.n_failed} of {len(outcome.records)} fits failed", file=sys.stderr)
    compiled = sum(r.get("compile_time_s") or 0.0 for r in outcome.records)
    if outcome.n_new and compiled > 0:
        logging.getLogger("aeroid").info(
            "numba compiled kernels for %.1f s during the fits: left out of their runtimes "
            "(results.jsonl: compile_time_s)", compiled)
    print(f"report: {report}")
    return 0


__all__ = ["default_out", "study"]
