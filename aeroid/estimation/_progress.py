"""Progress of one long fit: how an estimator reports it and how a caller listens.

A caller passes a callback to :meth:`aeroid.estimation.Estimator.fit`
(``fit(flight, progress=callback)``); for the duration of that fit the callback is the
current listener of this context (a :class:`contextvars.ContextVar`, so concurrent
threads and processes each have their own, and a fit without a callback is silent even
inside another fit's). An estimator's ``run(flight, rng)`` keeps its signature: it
reports by calling :func:`report_progress` wherever it has something to say, and the
call costs nothing when nobody listens. Third-party estimators that never call it work
unchanged (the caller just sees no progress).

The hook for an iterative method (the paper's PSO methods use it through
:func:`pso_callback`; output-error's Gauss-Newton loop can do the same)::

    from aeroid.estimation import report_progress

    for iteration in range(1, max_iterations + 1):
        ...  # one Gauss-Newton step
        report_progress(iteration, max_iterations, stage="Gauss-Newton", cost=cost)

``done`` may stop short of ``total`` (a method that converged early); a new ``stage``
(or a new ``total``) starts a new count. Listeners must not raise: an exception from
the callback ends the fit like any other failure inside the method.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator
from contextvars import ContextVar
from dataclasses import dataclass

import numpy as np

__all__ = ["ProgressEvent", "progress_listener", "pso_callback", "report_progress"]


@dataclass(frozen=True)
class ProgressEvent:
    """One progress report of a running fit.

    Attributes
    ----------
    done : int
        Steps finished in this stage (iterations, samples...).
    total : int
        Steps the stage will take at most.
    stage : str
        What is counted ("PSO", "FAZ 2/4", "Gauss-Newton"); "" for a one-stage method.
    cost : float
        Best cost so far, NaN when the method has none.
    """

    done: int
    total: int
    stage: str = ""
    cost: float = math.nan


ProgressCallback = Callable[[ProgressEvent], None]

_LISTENER: ContextVar[ProgressCallback | None] = ContextVar("aeroid_progress", default=None)


@contextlib.contextmanager
def progress_listener(callback: ProgressCallback | None) -> Iterator[None]:
    """Make ``callback`` (or nobody, for None) the listener inside the ``with`` block."""
    token = _LISTENER.set(callback)
    try:
        yield
    finally:
        _LISTENER.reset(token)


def listening() -> bool:
    """Return True when a listener is set (to skip preparing reports nobody reads)."""
    return _LISTENER.get() is not None


def report_progress(done: int, total: int, stage: str = "", cost: float = math.nan) -> None:
    """Tell the current listener, if any, that ``done`` of ``total`` steps are finished."""
    callback = _LISTENER.get()
    if callback is not None:
        callback(ProgressEvent(int(done), int(total), stage, float(cost)))


def pso_callback(total: int, stage: str = "PSO"
                 ) -> Callable[[int, np.ndarray, float], bool] | None:
    """Return a :func:`aeroid.estimation.minimize` callback reporting each iteration.

    Returns None when nobody listens, so the optimiser runs exactly as without one. The
    callback never asks the optimiser to stop, and it reports ``0 / total`` at once so
    the listener shows the stage before the first (possibly compiling) evaluation.
    """
    if not listening():
        return None
    report_progress(0, total, stage)

    def callback(iteration: int, best_x: np.ndarray, best_cost: float) -> bool:
        report_progress(iteration, total, stage, best_cost)
        return False

    return callback
