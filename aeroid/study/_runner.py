"""Run a study: seeded, resumable, in-process or parallel (local processes or Dask).

The unit of work is one fit ``(run, noise, estimator)`` (:mod:`aeroid.study._fits`:
seeds, flights, records). :func:`run_study` opens the study's folder
(:mod:`aeroid.study._store`: refuses to write over another study, checks design and
code on ``resume``), stores the Cramér-Rao floors of every noise condition
(``floors.json``, :mod:`aeroid.study._floors`; kept on resume), runs the missing fits
on an executor (:mod:`aeroid.study._executors`) and stores each finished fit at once:
first its run-0 history file, then its record, so a killed study loses nothing
finished and ``resume=True`` runs only what is missing.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aeroid.errors import StudyError
from aeroid.study._executors import check_scheduler, run_dask, run_processes, run_serial
from aeroid.study._fits import (
    HISTORY_RUN,
    Task,
    estimator_seed,
    fit_task,
    flight_seed,
    simulate_run,
)
from aeroid.study._floors import read_floors, study_floors, write_floors
from aeroid.study._folder import open_store
from aeroid.study._histories import history_name, load_history, save_history
from aeroid.study._progress import Progress
from aeroid.study._provenance import code_identity
from aeroid.study._spec import Study
from aeroid.study._store import RESULTS_FILE, RecordWriter, read_results


@dataclass(frozen=True)
class StudyOutcome:
    """What :func:`run_study` did.

    Attributes
    ----------
    out_dir : Path
    records : list of dict
        Every fit of the study (old and new), sorted by run, noise, estimator.
    n_new : int
        Fits run by this call.
    n_failed : int
        Fits with ``success: false`` among all records.
    wall_time_s : float
        Wall time of this call [s].
    """

    out_dir: Path
    records: list[dict[str, Any]]
    n_new: int
    n_failed: int
    wall_time_s: float

    @property
    def results_path(self) -> Path:
        """The results file."""
        return self.out_dir / RESULTS_FILE


def all_tasks(study: Study) -> list[Task]:
    """Return every fit of the study in run-major order."""
    return [(i, k, e) for i in range(study.runs) for k in range(len(study.noise))
            for e in range(len(study.estimators))]


def study_design(study: Study) -> dict[str, Any]:
    """Return what ``study.json`` holds: the design and the code that runs it."""
    return {**study.describe(),
            "code": code_identity(type(e.estimator) for e in study.estimators)}


def _check_settings(jobs: Any, scheduler: str | None, dask_local: Any) -> None:
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise StudyError(f"--jobs must be an integer >= 1, got {jobs!r}")
    if scheduler is not None and dask_local is not None:
        raise StudyError("give either --scheduler or --dask-local, not both")
    if dask_local is not None and (isinstance(dask_local, bool)
                                   or not isinstance(dask_local, int) or dask_local < 1):
        raise StudyError(f"--dask-local must be >= 1, got {dask_local}")
    if scheduler is not None:
        check_scheduler(scheduler)


def _key(record: dict[str, Any]) -> tuple[int, str, str]:
    return int(record["run"]), str(record["noise"]), str(record["estimator"])


def run_study(study: Study, out_dir: str | Path, *, jobs: int = 1,
              scheduler: str | None = None, dask_local: int | None = None,
              resume: bool = False, overwrite: bool = False, progress: bool | None = None,
              on_record: Callable[[dict[str, Any]], None] | None = None) -> StudyOutcome:
    """Run every missing fit of ``study`` and append each to ``out_dir/results.jsonl``.

    Parameters
    ----------
    study : Study
        A validated design (:func:`aeroid.study.load_study`).
    out_dir : path-like
        Output folder; created if needed. Holds ``study.json``, ``results.jsonl`` and
        ``histories/`` (:mod:`aeroid.study._store`). Not the working directory.
    jobs : int
        Local worker processes (1: in this process; > 1: a spawn-context process pool
        whose workers run numba and BLAS with one thread each).
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://HOST:PORT``): run the fits on that cluster.
    dask_local : int, optional
        Start a local Dask cluster with this many single-threaded worker processes.
    resume : bool
        Keep the fits already in ``out_dir`` (same design and same code, checked
        against its ``study.json``) and run only the missing ones.
    overwrite : bool
        Move a previous study's files in ``out_dir`` into a new ``previous-<N>/``.
        Without ``resume`` or ``overwrite`` a folder holding a study's files is refused.
    progress : bool, optional
        Show a progress bar on stderr (None: only when stderr is a terminal).
    on_record : callable, optional
        Called with each new record after it is written (tests, embedding programs).

    Returns
    -------
    StudyOutcome

    Raises
    ------
    StudyError
        Bad executor settings; a folder holding another study; resuming another
        design or other code; a write that failed (a full disk); a worker that runs
        other code.
    KeyboardInterrupt
        Passed on after cancelling what has not started; finished fits are on disk.
    """
    start = time.perf_counter()
    _check_settings(jobs, scheduler, dask_local)
    out_dir = Path(out_dir)
    design = study_design(study)
    found, notes = open_store(out_dir, design, resume=resume, overwrite=overwrite)
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
    if read_floors(out_dir, design["fingerprint"]) is None:
        write_floors(out_dir, study_floors(study))
    wanted = {(i, study.noise[k].label, study.estimators[j].label)
              for i, k, j in all_tasks(study)}
    unique: dict[tuple[int, str, str], dict[str, Any]] = {}
    for r in found:  # keep the first record of a fit (a fit is never stored twice)
        if _key(r) in wanted:
            unique.setdefault(_key(r), r)
    records = list(unique.values())
    tasks = [t for t in all_tasks(study)
             if (t[0], study.noise[t[1]].label, study.estimators[t[2]].label) not in unique]

    if scheduler is not None or dask_local is not None:
        stream: Iterable = run_dask(study, tasks, scheduler, dask_local)
    elif jobs > 1 and len(tasks) > 1:
        stream = run_processes(study, tasks, jobs)
    else:
        stream = run_serial(study, tasks)

    code = design["code"]["id"]
    index = {(n.label, e.label): (k, j) for k, n in enumerate(study.noise)
             for j, e in enumerate(study.estimators)}
    bar = Progress(study.n_fits, study.n_fits - len(tasks),
                   (study.estimators[t[2]].label for t in tasks), study.name, progress)
    try:
        with RecordWriter(out_dir / RESULTS_FILE) as writer:
            for record, history in stream:
                if record.get("code") != code:
                    raise StudyError(f"worker {record.get('worker')} runs other code than "
                                     f"this process ({record.get('code')} vs {code}): "
                                     "install the same aeroid on every worker")
                record["history"] = None
                if history and record["run"] == HISTORY_RUN:
                    name = history_name(*index[record["noise"], record["estimator"]])
                    save_history(out_dir, name, history)  # before the record names it
                    record["history"] = name
                writer.append(record)
                records.append(record)
                bar.update(record)
                if on_record is not None:
                    on_record(record)
    finally:
        bar.close()
        if hasattr(stream, "close"):
            stream.close()
    records.sort(key=_sort_key(study))
    n_failed = sum(not r["success"] for r in records)
    return StudyOutcome(out_dir=out_dir, records=records, n_new=len(tasks), n_failed=n_failed,
                        wall_time_s=time.perf_counter() - start)


def _sort_key(study: Study) -> Callable[[dict[str, Any]], tuple[int, int, int]]:
    noise = {n.label: k for k, n in enumerate(study.noise)}
    est = {e.label: k for k, e in enumerate(study.estimators)}
    return lambda r: (int(r["run"]), noise.get(r["noise"], -1), est.get(r["estimator"], -1))


__all__ = ["StudyOutcome", "all_tasks", "estimator_seed", "fit_task", "flight_seed",
           "load_history", "read_results", "run_study", "simulate_run", "study_design"]
