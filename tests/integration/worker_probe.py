"""What a spawned study worker sees: run in the worker by ``test_study_executors``."""

from __future__ import annotations

import os


def compile_in_worker() -> tuple[str | None, int, str]:
    """Compile a new numba function (nothing cached) in this process.

    Returns the ``NUMBA_NUM_THREADS`` variable, numba's configured thread count and
    ``"compiled"`` or the error the compilation raised.
    """
    import numba

    try:
        @numba.njit
        def add_one(x: int) -> int:
            return x + 1

        outcome = "compiled" if add_one(1) == 2 else "wrong result"
    except Exception as exc:  # noqa: BLE001 - the error is the measurement
        outcome = f"{type(exc).__name__}: {exc}"
    return os.environ.get("NUMBA_NUM_THREADS"), numba.config.NUMBA_NUM_THREADS, outcome
