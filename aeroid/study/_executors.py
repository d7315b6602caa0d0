"""Where a study's fits run: in this process, in local worker processes, or on Dask.

Each executor takes the study and the fits to run and yields ``(record, history)`` for
every fit as it finishes, in any order (the records carry their own keys). Failure of
an estimator is data inside the record (:func:`aeroid.study._fits.fit_task`); what an
executor itself must handle is a worker that dies:

- local processes (:func:`run_processes`): a worker killed by a signal or the kernel's
  out-of-memory killer breaks the whole process pool. The fits that were running or
  queued then are retried once, each alone in a fresh one-worker pool (so an
  innocent fit that shared the pool is not blamed); a fit whose worker dies again is
  recorded as failed, and the study goes on with a fresh pool.
- Dask (:func:`run_dask`): the scheduler already retries a task whose worker died; a
  task that exhausts its retries (``KilledWorker``) is recorded as failed.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import sys
import threading
import time
from collections import deque
from collections.abc import Iterator
from typing import Any

from aeroid.errors import StudyError
from aeroid.study._fits import Task, failed_record, fit_task
from aeroid.study._spec import Study

WORKER_ENV = {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
              "MKL_NUM_THREADS": "1"}
#: Fits queued per worker process beyond the one it runs (keeps workers busy while the
#: parent writes; bounds what a dying worker takes down with it).
QUEUE_PER_WORKER = 1
WORKER_DIED = ("the worker process died running this fit twice (killed by a signal or "
               "out of memory); recorded as failed after one retry")
#: How often a worker process checks that the study process is alive [s].
PARENT_POLL_S = 1.0
SCHEDULER_ADDRESS = re.compile(r"(tcp|tls)://[^/\s:]+:[0-9]{1,5}")

Finished = tuple[dict[str, Any], dict[str, Any] | None]


def _exit_with(parent: int) -> None:
    while True:
        time.sleep(PARENT_POLL_S)
        if os.getppid() != parent:  # reparented: the study process is gone
            os._exit(1)


def init_worker(parent: int | None = None) -> None:
    """Process-pool initializer: one numba thread per worker, and exit with the parent.

    A worker of a study killed with SIGKILL would otherwise wait forever for work (each
    worker holds the task queue's write end, so the queue never closes): a watcher
    thread ends the worker within :data:`PARENT_POLL_S` of the death of ``parent`` (the
    study process's id, passed by it: a worker orphaned before this runs exits too).
    """
    env = dict(WORKER_ENV)
    if "numba" in sys.modules and os.environ.get("NUMBA_NUM_THREADS") != env[
            "NUMBA_NUM_THREADS"]:
        # numba read NUMBA_NUM_THREADS when it was imported (a spawned process imports
        # the parent's main module first); changed now, numba's next compilation raises
        # "Cannot set NUMBA_NUM_THREADS to a different value once the threads have been
        # launched": every fit that compiled a kernel in a worker failed so (a study
        # without numba's cache, --jobs 2). set_num_threads below limits the threads.
        del env["NUMBA_NUM_THREADS"]
    os.environ.update(env)
    with contextlib.suppress(Exception):  # numba missing or threads fixed already
        import numba

        numba.set_num_threads(1)
    threading.Thread(target=_exit_with, args=(parent or os.getppid(),), daemon=True,
                     name="aeroid-exit-with-parent").start()


@contextlib.contextmanager
def environment(values: dict[str, str]) -> Iterator[None]:
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


def run_serial(study: Study, tasks: list[Task]) -> Iterator[Finished]:
    """Run the fits one after the other in this process."""
    for task in tasks:
        yield fit_task(study, task)


def _pool(workers: int) -> Any:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    context = multiprocessing.get_context("spawn")
    return ProcessPoolExecutor(max_workers=workers, mp_context=context,
                               initializer=init_worker, initargs=(os.getpid(),))


def submit(pool: Any, fn: Any, *args: Any) -> Any:
    """``pool.submit(fn, *args)`` with :data:`WORKER_ENV` set while it runs: the pool
    starts its worker processes inside ``submit`` (not when it is made), and a spawned
    process reads the variables as it starts, before it imports numpy and numba."""
    with environment(WORKER_ENV):
        return pool.submit(fn, *args)


def _drive(study: Study, pool: Any, queue: deque[Task], in_flight: int,
           suspects: list[Task]) -> Iterator[Finished]:
    """Run ``queue`` on ``pool``, ``in_flight`` fits at a time, until done or broken.

    On a broken pool the fits that were submitted but not finished are moved to
    ``suspects`` and the generator returns.
    """
    from concurrent.futures import FIRST_COMPLETED, wait
    from concurrent.futures.process import BrokenProcessPool

    running: dict[Any, Task] = {}
    while queue or running:
        while queue and len(running) < in_flight:
            task = queue.popleft()
            try:
                running[submit(pool, fit_task, study, task)] = task
            except BrokenProcessPool:
                queue.appendleft(task)
                suspects.extend(running.values())
                return
        finished, _ = wait(running, return_when=FIRST_COMPLETED)
        broken = False
        for future in finished:
            task = running.pop(future)
            try:
                result = future.result()
            except BrokenProcessPool:
                suspects.append(task)
                broken = True
                continue
            yield result
        if broken:  # every other future ends now too: keep what finished first
            for future, task in running.items():
                if future.exception() is None:
                    yield future.result()
                else:
                    suspects.append(task)
            return


def run_processes(study: Study, tasks: list[Task], jobs: int) -> Iterator[Finished]:
    """Run the fits in ``jobs`` spawned worker processes; survive workers that die."""
    queue = deque(tasks)
    pool = None
    try:
        while queue:
            suspects: list[Task] = []
            pool = _pool(jobs)
            yield from _drive(study, pool, queue, jobs * (1 + QUEUE_PER_WORKER), suspects)
            pool.shutdown(wait=True, cancel_futures=True)
            pool = None
            suspects.sort()
            while suspects:  # retry each alone: a second death is that fit's own
                pool = _pool(1)
                again: list[Task] = []
                alone = deque(suspects)
                yield from _drive(study, pool, alone, 1, again)
                pool.shutdown(wait=True, cancel_futures=True)
                pool = None
                if again:
                    (dead,) = again
                    yield failed_record(study, dead, WORKER_DIED), None
                suspects = list(alone)
    finally:
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)


def check_scheduler(address: str) -> None:
    """Refuse a Dask scheduler address that is not ``tcp://HOST:PORT`` or ``tls://...``."""
    if not isinstance(address, str) or not SCHEDULER_ADDRESS.fullmatch(address.strip()):
        raise StudyError(f"--scheduler {address!r}: expected a Dask scheduler address like "
                         "tcp://HOST:8786 (or tls://HOST:PORT)")


@contextlib.contextmanager
def _quiet_distributed(level: int = logging.ERROR) -> Iterator[None]:
    """Raise the ``distributed`` loggers of this process to ``level`` inside the block.

    A local cluster's scheduler runs in this process; on shutdown (after an interrupt
    above all) it logs each message it can no longer send to the closed client, and
    the nannies warn about workers they stop: noise, not news.
    """
    logger = logging.getLogger("distributed")
    old = logger.level
    logger.setLevel(level)
    try:
        yield
    finally:
        logger.setLevel(old)


def run_dask(study: Study, tasks: list[Task], scheduler: str | None, n_local: int | None
             ) -> Iterator[Finished]:
    """Run the fits on a Dask cluster (``scheduler``) or a local one of ``n_local`` workers."""
    if scheduler is not None:
        check_scheduler(scheduler)
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise StudyError("Dask is not installed (pip install 'dask[distributed]')") from None
    with contextlib.ExitStack() as stack:
        stack.enter_context(_quiet_distributed())
        if scheduler is None:
            cluster = stack.enter_context(LocalCluster(
                n_workers=n_local, threads_per_worker=1, processes=True,
                # workers log CRITICAL only: one whose scheduler closed first logs an ERROR
                # with a traceback for its heartbeat (seen once on a loaded machine,
                # an interrupted study); a worker's real failure reaches the study through
                # its future (a failed record), not through its log
                dashboard_address=None, env=dict(WORKER_ENV), silence_logs=logging.CRITICAL,
                # no dashboard, but the scheduler still serves /metrics over HTTP, by
                # default on port 8787: a second study (or any Dask) on the machine
                # made the first one's start fail; any free port will do
                scheduler_kwargs={"dashboard_address": ":0"}))
            client = Client(cluster)
        else:
            try:
                client = Client(scheduler.strip(), timeout=30)
            except (OSError, ValueError, TypeError) as exc:
                raise StudyError(f"cannot reach the Dask scheduler {scheduler}: "
                                 f"{' '.join(str(exc).split())}") from None
        stack.callback(client.close)  # releases the futures: the scheduler drops them
        # on exit, first silence everything (the scheduler's CRITICAL lines about the
        # closed client), then close the client and the cluster, then restore the level
        stack.callback(logging.getLogger("distributed").setLevel, logging.CRITICAL + 1)
        shared = client.scatter(study, broadcast=True)
        futures = {client.submit(fit_task, shared, task, pure=False): task for task in tasks}
        for future in as_completed(futures):
            try:
                result = future.result()
            except Exception as exc:  # a worker died too often, or the cluster failed
                text = " ".join(str(exc).split())[:200]
                message = f"Dask: {type(exc).__name__}: {text}".rstrip(": ")
                result = failed_record(study, futures[future], message), None
            yield result


__all__ = ["WORKER_ENV", "check_scheduler", "init_worker", "run_dask", "run_processes",
           "run_serial"]
