"""What the before/after benchmarks share: a fit timed with a patch, the same result, a head.

Used by ``benchmarks/bench_ee_roll_pass.py`` and ``bench_oe_give_up.py`` (run from the
repository root as scripts: this folder is then on ``sys.path``): a change that must leave
a fit's result as it was is timed against the code before it, patched back in, in one
session, and the results are asserted equal bit for bit.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import os
import platform
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np


def timed_fit(estimator: Any, flight: Any, patch: Any = None,
              clock: Callable[[], float] = time.perf_counter) -> tuple[Any, float]:
    """Return ``estimator.fit(flight, rng=0)`` and its time by ``clock`` [s], inside
    ``patch`` (a context manager, e.g. ``unittest.mock.patch.object``) when given."""
    with patch if patch is not None else contextlib.nullcontext():
        start = clock()
        result = estimator.fit(flight, rng=0)
        return result, clock() - start


def assert_same_result(a: Any, b: Any) -> None:
    """Assert two results equal where a user reads them: estimate, standard errors,
    covariance, cost, success, message and warnings."""
    for name in ("theta", "stderr", "covariance"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert (a.cost, a.success, a.message, a.warnings) == (b.cost, b.success, b.message,
                                                          b.warnings)


def measured(title: str, measure: Callable[[], list[str]], results: Any, write: bool,
             about: str) -> str:
    """Run ``measure`` (its table's lines), print and (``write``) write it to ``results``
    under a head: the title, the command as run, the date, the machine and its load."""
    load, start = os.getloadavg(), time.time()
    lines = measure()
    command = " ".join([f"benchmarks/{os.path.basename(sys.argv[0])}", *sys.argv[1:]])
    text = "\n".join([
        f"# {title}", "",
        f"Command: `nice -n 10 python {command}` (repository root), "
        f"{dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC, {time.time() - start:.0f} s.",
        f"Machine: {platform.machine()}, {os.cpu_count()} CPU cores, Python "
        f"{platform.python_version()}, numpy {np.__version__}; load average at the start "
        f"{load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} (shared machine).", "",
        about, "", *lines, ""])
    print(text)
    if write:
        results.write_text(text)
    return text
