"""The study's progress bar and a remaining-time estimate that does not swing.

A study mixes fits of very different cost (EAM-PSO ~10 s, the filters ~0.1 s). A rate
averaged over the last few completions (tqdm's default) jumps each time a slow fit
finishes among fast ones: the estimate swung between 1:24 and 51:54 in one study.
:class:`RemainingTime` instead learns the mean time of a fit of each estimator and the
parallelism actually achieved, and predicts::

    remaining = sum over estimators (mean fit time x fits left) / parallelism

where parallelism = (sum of the finished fits' times) / (elapsed wall time). Fits of an
estimator not seen yet count at the mean of all fits seen so far.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Iterable, Mapping
from typing import Any


class RemainingTime:
    """Remaining wall time of a study from per-estimator fit times.

    Parameters
    ----------
    left : iterable of str
        The estimator label of every fit still to run (one entry per fit).
    start : float, optional
        The clock reading [s] when the fits started (default: now,
        ``time.perf_counter``).
    """

    def __init__(self, left: Iterable[str], start: float | None = None) -> None:
        self.left = Counter(left)
        self.start = time.perf_counter() if start is None else start
        self._time: Counter[str] = Counter()
        self._count: Counter[str] = Counter()

    def done(self, label: str, fit_time_s: float | None) -> None:
        """Count one finished fit of ``label`` that took ``fit_time_s`` [s] (None: unknown)."""
        self.left[label] -= 1
        if fit_time_s is not None and fit_time_s >= 0:
            self._time[label] += fit_time_s
            self._count[label] += 1

    def seconds(self, now: float | None = None) -> float | None:
        """Return the estimated remaining wall time [s], or None before any timed fit."""
        now = time.perf_counter() if now is None else now
        n_seen = sum(self._count.values())
        busy = sum(self._time.values())
        elapsed = now - self.start
        if n_seen == 0 or elapsed <= 0 or busy <= 0:
            return None
        overall = busy / n_seen
        work = sum(n * (self._time[k] / self._count[k] if self._count[k] else overall)
                   for k, n in self.left.items() if n > 0)
        return work / (busy / elapsed)


def format_seconds(seconds: float | None) -> str:
    """Return ``H:MM:SS`` or ``M:SS`` (``?`` for None)."""
    if seconds is None:
        return "?"
    s = int(round(seconds))
    h, rest = divmod(s, 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


class Progress:
    """A tqdm bar on stderr (fits done / total) with :class:`RemainingTime` as its estimate.

    Parameters
    ----------
    total, done : int
        Fits of the study, and fits already on disk.
    left : iterable of str
        The estimator label of each fit to run.
    name : str
        Shown before the bar.
    enabled : bool or None
        None: only when stderr is a terminal.
    """

    BAR_FORMAT = "{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}{postfix}]"

    def __init__(self, total: int, done: int, left: Iterable[str], name: str,
                 enabled: bool | None) -> None:
        from tqdm.auto import tqdm

        self.remaining = RemainingTime(left)
        self.failed = 0
        self.bar = tqdm(total=total, initial=done, unit="fit", desc=name,
                        disable=None if enabled is None else not enabled,
                        dynamic_ncols=True, bar_format=self.BAR_FORMAT)

    def update(self, record: Mapping[str, Any]) -> None:
        """Count one finished fit (its record)."""
        self.remaining.done(str(record["estimator"]), record.get("wall_time_s"))
        self.failed += not record["success"]
        self.bar.update(1)
        left = format_seconds(self.remaining.seconds())
        self.bar.set_postfix_str(f"~{left} left, {self.failed} failed", refresh=False)

    def close(self) -> None:
        """Close the bar."""
        self.bar.close()


__all__ = ["Progress", "RemainingTime", "format_seconds"]
