"""Run a study: seeded, resumable, in-process or parallel (local processes or Dask).

Seeding (``notes`` on randomness): run ``i`` owns the stream
``SeedSequence(seed, spawn_key=(i,))``. Its flights draw from the child
``spawn_key=(i, 0)`` and its estimators from ``spawn_key=(i, 1)``, so a fit depends only
on (seed, run index, noise condition, estimator), never on the number or kind of
workers. Decisions:

- Every estimator of a run gets a fresh generator from the same seed, so all of them
  draw the same starting guess (and the same first random numbers).
- All noise conditions of a run use the same flight seed (common random numbers): in
  a sweep of the paper's xi the same uniform draws are scaled, so the conditions
  differ by the noise level only, not by luck.

The unit of work is one fit ``(run, noise, estimator)``. The noise-free truth of the
scenario is deterministic, so each worker process integrates it once and caches it;
a fit then costs the sensor noise plus the estimator. Every finished fit is appended
at once to ``results.jsonl`` (one JSON object per line, flushed and fsynced), so a
killed study loses nothing finished, and ``resume=True`` runs only what is missing
(a partly written last line is dropped). Convergence histories (and the
reconstructed forces of EBM-type methods) are kept for run 0 only, as
``histories/<noise>__<estimator>.npz``.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import pickle
import re
import shutil
import socket
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aeroid.errors import StudyError
from aeroid.study._design import Study

RESULTS_FILE = "results.jsonl"
DESIGN_FILE = "study.json"
HISTORY_DIR = "histories"
HISTORY_RUN = 0
INFO_ARRAYS = ("t", "fm_raw", "fm_smooth")
WORKER_ENV = {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
              "MKL_NUM_THREADS": "1"}

Task = tuple[int, int, int]
"""(run index, noise index, estimator index)."""


# --------------------------------------------------------------------------------------
# Seeds and flights
# --------------------------------------------------------------------------------------
def flight_seed(seed: int, run: int) -> np.random.SeedSequence:
    """Return the seed of run ``run``'s flights (every noise condition)."""
    return np.random.SeedSequence(seed, spawn_key=(run, 0))


def estimator_seed(seed: int, run: int) -> np.random.SeedSequence:
    """Return the seed every estimator of run ``run`` starts from."""
    return np.random.SeedSequence(seed, spawn_key=(run, 1))


_TRUTH_CACHE: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def _truth(scenario: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return (t, states, delta) of the scenario's noise-free truth, cached per process."""
    from aeroid.flights._simulate import simulate_truth

    key = hashlib.sha256(pickle.dumps((scenario.airframe, scenario.coefficients,
                                       scenario.manoeuvre))).hexdigest()
    if key not in _TRUTH_CACHE:
        _TRUTH_CACHE.clear()
        _TRUTH_CACHE[key] = simulate_truth(scenario.airframe, scenario.coefficient_vector,
                                           scenario.manoeuvre)
    return _TRUTH_CACHE[key]


def simulate_run(study: Study, run: int, noise_index: int) -> Any:
    """Return the flight of ``run`` under noise condition ``noise_index``.

    Equal to ``aeroid.simulate(airframe, coefficients, manoeuvre, noise,
    rng=default_rng(flight_seed(seed, run)))`` (a test checks it), but the truth is
    integrated once per process (:func:`aeroid.flights.record_flight` does the rest).
    """
    from aeroid.flights._simulate import record_flight

    scenario = study.scenario
    noise = study.noise[noise_index].model
    rng = np.random.default_rng(flight_seed(study.seed, run))
    return record_flight(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         _truth(scenario), noise, rng=rng)


# --------------------------------------------------------------------------------------
# One fit (runs in any worker)
# --------------------------------------------------------------------------------------
def _clean(x: Any) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _vector(x: Any) -> list[float | None] | None:
    return None if x is None else [_clean(v) for v in np.asarray(x, dtype=float).ravel()]


def fit_task(study: Study, task: Task) -> tuple[dict[str, Any], dict[str, np.ndarray] | None]:
    """Run one fit; return its JSON record and, for run 0, its history arrays.

    An estimator that raises (anything but ``KeyboardInterrupt``/``SystemExit``) or
    returns ``success=False`` gives a record with ``success: false`` and the message.
    """
    run, k_noise, k_est = task
    spec = study.estimators[k_est]
    flight = simulate_run(study, run, k_noise)
    truth = flight.true_coefficients
    try:
        result = spec.estimator.fit(flight, rng=np.random.default_rng(
            estimator_seed(study.seed, run)))
    except Exception as exc:  # failure is data: record it, the study goes on
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        record = _record(study, task, truth, None)
        record.update(success=False, message=f"{type(exc).__name__}: {text}".rstrip(": "))
        return record, None
    record = _record(study, task, truth, result)
    history = None
    if run == HISTORY_RUN:
        history = {}
        for key, value in (result.history or {}).items():
            history[f"history_{key}"] = np.asarray(value)
        for key in INFO_ARRAYS:
            if key in (result.info or {}):
                history[f"info_{key}"] = np.asarray(result.info[key], dtype=float)
    return record, history


def _record(study: Study, task: Task, truth: np.ndarray, result: Any) -> dict[str, Any]:
    run, k_noise, k_est = task
    spec = study.estimators[k_est]
    record: dict[str, Any] = {
        "run": run, "noise": study.noise[k_noise].label, "estimator": spec.label,
        "method": spec.method, "truth": _vector(truth), "theta": [None] * len(truth),
        "stderr": None, "success": False, "message": "", "cost": None,
        "n_evaluations": 0, "n_iterations": 0, "wall_time_s": None,
        "worker": f"{socket.gethostname()}:{os.getpid()}",
    }
    if result is not None:
        record.update(theta=_vector(result.theta), stderr=_vector(result.stderr),
                      success=bool(result.success), message=str(result.message),
                      cost=_clean(result.cost), n_evaluations=int(result.n_evaluations),
                      n_iterations=int(result.n_iterations),
                      wall_time_s=_clean(result.wall_time_s))
    return record


# --------------------------------------------------------------------------------------
# Executors
# --------------------------------------------------------------------------------------
def _init_worker() -> None:
    """Process-pool initializer: one numba thread per worker (no oversubscription)."""
    os.environ.update(WORKER_ENV)
    with contextlib.suppress(Exception):  # numba missing or threads fixed already
        import numba

        numba.set_num_threads(1)


@contextlib.contextmanager
def _environment(values: dict[str, str]) -> Iterator[None]:
    """Set environment variables for processes started inside the block."""
    old = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _run_serial(study: Study, tasks: list[Task]) -> Iterator[tuple[dict, dict | None]]:
    for task in tasks:
        yield fit_task(study, task)


def _run_processes(study: Study, tasks: list[Task], jobs: int
                   ) -> Iterator[tuple[dict, dict | None]]:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    context = multiprocessing.get_context("spawn")
    pool = ProcessPoolExecutor(max_workers=jobs, mp_context=context, initializer=_init_worker)
    try:
        with _environment(WORKER_ENV):  # spawned children inherit it before importing numba
            futures = [pool.submit(fit_task, study, task) for task in tasks]
        for future in as_completed(futures):
            yield future.result()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _run_dask(study: Study, tasks: list[Task], scheduler: str | None, n_local: int | None
              ) -> Iterator[tuple[dict, dict | None]]:
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise StudyError("Dask is not installed (pip install 'dask[distributed]')") from None
    cluster = None
    if scheduler is None:
        cluster = LocalCluster(n_workers=n_local, threads_per_worker=1, processes=True,
                               dashboard_address=None, env=dict(WORKER_ENV))
        client = Client(cluster)
    else:
        try:
            client = Client(scheduler, timeout=30)
        except OSError as exc:
            raise StudyError(f"cannot reach the Dask scheduler {scheduler}: {exc}") from None
    try:
        shared = client.scatter(study, broadcast=True)
        futures = [client.submit(fit_task, shared, task, pure=False) for task in tasks]
        try:
            for future in as_completed(futures):
                yield future.result()
        finally:
            client.cancel(futures)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


# --------------------------------------------------------------------------------------
# Results file
# --------------------------------------------------------------------------------------
def read_results(path: str | Path, *, repair: bool = False) -> list[dict[str, Any]]:
    """Return the records of a results file (one JSON object per line).

    A partly written last line (a study killed while writing) is ignored, and removed
    from the file when ``repair`` is true, so that appending goes on cleanly.

    Raises
    ------
    StudyError
        When a line other than the last is not valid JSON (the file is damaged).
    """
    path = Path(path)
    if not path.exists():
        return []
    raw = path.read_bytes()
    lines = raw.split(b"\n")  # the last element is what follows the last newline
    records, good_bytes = [], 0
    for k, line in enumerate(lines[:-1]):
        if line.strip():
            try:
                records.append(json.loads(line))
            except json.JSONDecodeError:
                raise StudyError(f"{path}: line {k + 1} is not valid JSON (damaged file)"
                                 ) from None
        good_bytes += len(line) + 1
    if repair and good_bytes < len(raw):
        with path.open("r+b") as fh:  # drop the partly written last line
            fh.truncate(good_bytes)
    return records


def _key(record: dict[str, Any]) -> tuple[int, str, str]:
    return (int(record["run"]), str(record["noise"]), str(record["estimator"]))


def slug(text: str) -> str:
    """Return ``text`` as a file-name-safe slug."""
    return re.sub(r"[^A-Za-z0-9.=+-]+", "_", text).strip("_") or "x"


def history_path(out_dir: str | Path, noise: str, estimator: str) -> Path:
    """Return the history file of (noise label, estimator label) of run 0."""
    return Path(out_dir) / HISTORY_DIR / f"{slug(noise)}__{slug(estimator)}.npz"


def load_history(out_dir: str | Path, noise: str, estimator: str) -> dict[str, Any] | None:
    """Return the run-0 history arrays (``history_*`` and ``info_*`` keys), or None."""
    path = history_path(out_dir, noise, estimator)
    if not path.exists():
        return None
    with np.load(path, allow_pickle=False) as data:
        out = {k: data[k] for k in data.files}
    if "history_axis" in out:
        out["history_axis"] = str(out["history_axis"])
    return out


# --------------------------------------------------------------------------------------
# The study
# --------------------------------------------------------------------------------------
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


def _prepare(study: Study, out_dir: Path, resume: bool) -> list[dict[str, Any]]:
    out_dir.mkdir(parents=True, exist_ok=True)
    results = out_dir / RESULTS_FILE
    design = out_dir / DESIGN_FILE
    if resume and results.exists():
        if design.exists():
            old = json.loads(design.read_text()).get("fingerprint")
            if old != study.fingerprint():
                raise StudyError(f"{out_dir}: the results there come from another study design "
                                 "(different seed, scenario, noise or estimators); "
                                 "use another --out")
        records = read_results(results, repair=True)
    else:
        if results.exists() and results.stat().st_size > 0:
            shutil.move(results, out_dir / "results.previous.jsonl")
            print(f"note: moved the previous results in {out_dir} to results.previous.jsonl "
                  "(use --resume to complete them instead)", file=sys.stderr)
        if (out_dir / HISTORY_DIR).exists():
            shutil.rmtree(out_dir / HISTORY_DIR)
        results.write_bytes(b"")
        records = []
    design.write_text(json.dumps(study.describe(), indent=2) + "\n")
    return records


def _append(fh: Any, record: dict[str, Any]) -> None:
    fh.write(json.dumps(record, allow_nan=False) + "\n")
    fh.flush()
    os.fsync(fh.fileno())


def _save_history(out_dir: Path, record: dict[str, Any], history: dict[str, np.ndarray]
                  ) -> None:
    if not history:
        return
    path = history_path(out_dir, record["noise"], record["estimator"])
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {k: (np.asarray(str(v)) if k == "history_axis" else np.asarray(v))
              for k, v in history.items()}
    tmp = path.with_suffix(".tmp.npz")
    np.savez_compressed(tmp, **arrays)
    os.replace(tmp, path)


def run_study(study: Study, out_dir: str | Path, *, jobs: int = 1,
              scheduler: str | None = None, dask_local: int | None = None,
              resume: bool = False, progress: bool | None = None,
              on_record: Callable[[dict[str, Any]], None] | None = None) -> StudyOutcome:
    """Run every missing fit of ``study`` and append each to ``out_dir/results.jsonl``.

    Parameters
    ----------
    study : Study
        A validated design (:func:`aeroid.study.load_study`).
    out_dir : path-like
        Output folder; created if needed. Holds ``results.jsonl``, ``study.json`` and
        ``histories/``.
    jobs : int
        Local worker processes (1: in this process; > 1: a spawn-context process pool
        whose workers run numba and BLAS with one thread each).
    scheduler : str, optional
        Address of a Dask scheduler: run the fits on that cluster.
    dask_local : int, optional
        Start a local Dask cluster with this many single-threaded worker processes.
    resume : bool
        Keep the fits already in ``out_dir`` (same design, checked by fingerprint) and
        run only the missing ones. Without it, previous results are moved to
        ``results.previous.jsonl``.
    progress : bool, optional
        Show a tqdm progress bar (None: only when stderr is a terminal).
    on_record : callable, optional
        Called with each new record after it is written (tests, embedding programs).

    Returns
    -------
    StudyOutcome

    Raises
    ------
    StudyError
        Bad executor settings, or resuming results of another design.
    KeyboardInterrupt
        Passed on after cancelling what has not started; finished fits are on disk.
    """
    start = time.perf_counter()
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise StudyError(f"--jobs must be an integer >= 1, got {jobs!r}")
    if scheduler is not None and dask_local is not None:
        raise StudyError("give either --scheduler or --dask-local, not both")
    if dask_local is not None and dask_local < 1:
        raise StudyError(f"--dask-local must be >= 1, got {dask_local}")
    out_dir = Path(out_dir)
    records = _prepare(study, out_dir, resume)
    wanted = {(i, n.label, e.label) for i, k, j in all_tasks(study)
              for n, e in [(study.noise[k], study.estimators[j])]}
    unique: dict[tuple[int, str, str], dict[str, Any]] = {}
    for r in records:  # keep the first record of a fit (a file is never written twice)
        if _key(r) in wanted:
            unique.setdefault(_key(r), r)
    done, records = set(unique), list(unique.values())
    tasks = [t for t in all_tasks(study)
             if (t[0], study.noise[t[1]].label, study.estimators[t[2]].label) not in done]

    if scheduler is not None or dask_local is not None:
        stream: Iterable = _run_dask(study, tasks, scheduler, dask_local)
    elif jobs > 1 and len(tasks) > 1:
        stream = _run_processes(study, tasks, jobs)
    else:
        stream = _run_serial(study, tasks)

    from tqdm.auto import tqdm

    n_failed_new = 0
    bar = tqdm(total=study.n_fits, initial=study.n_fits - len(tasks), unit="fit",
               desc=study.name, disable=None if progress is None else not progress,
               dynamic_ncols=True)
    try:
        with (out_dir / RESULTS_FILE).open("a") as fh:
            for record, history in stream:
                _append(fh, record)
                if history is not None:
                    _save_history(out_dir, record, history)
                records.append(record)
                n_failed_new += not record["success"]
                bar.update(1)
                bar.set_postfix(failed=n_failed_new, refresh=False)
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
           "load_history", "read_results", "run_study", "simulate_run"]
