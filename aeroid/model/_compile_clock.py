"""What compiles while a block runs, and how long it takes.

numba announces every compilation it really does (not a load from its disk cache, not
a specialisation already in memory) as a ``numba:compile`` event; other one-time
builds announce themselves with :func:`compiling` (an ``aeroid:compile`` event through
numba's event bus). :func:`compile_clock` listens to both for the duration of a block:
the command line names each compilation as it starts and says its measured time when it
ends (one line each, only when something compiles); a study leaves the compile time out
of the fits' runtimes.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator
from typing import Any

from aeroid.model._compiled import HAVE_NUMBA

if HAVE_NUMBA:
    from numba.core import event

    _Listener: Any = event.Listener
else:  # pragma: no cover - exercised only where numba is missing
    _Listener = object


#: The event kinds a :class:`CompileClock` counts.
KINDS = ("numba:compile", "aeroid:compile")


def _name(ev: Any) -> str:
    if ev.kind == "aeroid:compile":
        return str((ev.data or {}).get("name", "?"))
    dispatcher = (ev.data or {}).get("dispatcher")
    function = getattr(dispatcher, "py_func", None)
    return str(getattr(function, "__name__", dispatcher))


class CompileClock(_Listener):  # type: ignore[misc]
    """The top-level numba compilations seen while installed (:func:`compile_clock`).

    A kernel that calls others compiles them inside its own compilation: only the
    outermost counts, with the time of everything inside it.

    Attributes
    ----------
    compiled : list of (str, float)
        Each compilation's function name and wall time [s], in order.
    """

    def __init__(self, say: Callable[[str], None] | None = None) -> None:
        self.compiled: list[tuple[str, float]] = []
        self._say = say
        self._depth = 0
        self._start = 0.0

    @property
    def seconds(self) -> float:
        """Wall time of all compilations so far [s]."""
        return float(sum(seconds for _, seconds in self.compiled))

    def on_start(self, ev: Any) -> None:
        """A compilation starts (numba calls this)."""
        self._depth += 1
        if self._depth == 1:
            self._start = time.perf_counter()
            if self._say is not None:
                what = "the numba kernel " if ev.kind == "numba:compile" else ""
                self._say(f"compiling {what}{_name(ev)} (once: cached on disk for later "
                          "runs)")

    def on_end(self, ev: Any) -> None:
        """A compilation ends (numba calls this, also when it fails)."""
        self._depth -= 1
        if self._depth == 0:
            seconds = time.perf_counter() - self._start
            self.compiled.append((_name(ev), seconds))
            if self._say is not None:
                self._say(f"compiled {_name(ev)} in {seconds:.1f} s")


@contextlib.contextmanager
def compile_clock(say: Callable[[str], None] | None = None) -> Iterator[CompileClock]:
    """Record the numba compilations done inside the block (:class:`CompileClock`).

    ``say``: called with one line when a compilation starts (what compiles) and one when
    it ends (its measured time). Without numba nothing compiles: the clock stays empty.
    """
    clock = CompileClock(say)
    if not HAVE_NUMBA:  # pragma: no cover - exercised only where numba is missing
        yield clock
        return
    with contextlib.ExitStack() as stack:
        for kind in KINDS:
            stack.enter_context(event.install_listener(kind, clock))
        yield clock


@contextlib.contextmanager
def compiling(name: str) -> Iterator[None]:
    """Announce a one-time build other than numba's (a C library, say) as ``name``.

    Inside the block the build runs; :func:`compile_clock` counts its time as compile
    time (a study leaves it out of the fit's runtime) and the command line names it.
    """
    if not HAVE_NUMBA:  # pragma: no cover - exercised only where numba is missing
        yield
        return
    with event.trigger_event("aeroid:compile", data={"name": name}):
        yield


__all__ = ["KINDS", "CompileClock", "compile_clock", "compiling"]
