"""Which numba kernels a command compiles, for which signatures, and how long each takes.

Runs one ``aeroid`` command in this process with a listener on numba's ``numba:compile``
events and prints one line per compilation (nested ones indented: a kernel that calls
another compiles it inside its own time), then the command's wall time.

    NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/profile_compile.py study --out /tmp/q

An empty ``NUMBA_CACHE_DIR`` gives the first run on a fresh install; the same directory
again gives the warm run.
"""

from __future__ import annotations

import sys
import time

from numba.core import event


class _Compiles(event.Listener):
    """Record (depth, name, signature, seconds) of every numba compilation."""

    def __init__(self) -> None:
        self.rows: list[tuple[int, str, str, float]] = []
        self._open: list[tuple[int, float]] = []

    def on_start(self, ev: event.Event) -> None:
        self._open.append((len(self.rows), time.perf_counter()))
        self.rows.append((len(self._open) - 1, "", "", 0.0))

    def on_end(self, ev: event.Event) -> None:
        index, start = self._open.pop()
        data = ev.data or {}
        dispatcher = data.get("dispatcher")
        name = getattr(getattr(dispatcher, "py_func", None), "__qualname__", str(dispatcher))
        signature = ", ".join(str(a) for a in data.get("args", ()))
        self.rows[index] = (self.rows[index][0], name, signature,
                            time.perf_counter() - start)


def main(argv: list[str]) -> int:
    """Run ``aeroid ARGV`` and print its compilations."""
    from aeroid.cli import main as aeroid_main

    listener = _Compiles()
    start = time.perf_counter()
    with event.install_listener("numba:compile", listener):
        status = aeroid_main(argv)
    wall = time.perf_counter() - start
    total = sum(s for depth, _, _, s in listener.rows if depth == 0)
    print(f"\n{len(listener.rows)} compilations, {total:.1f} s at top level, "
          f"command {wall:.1f} s (status {status})", file=sys.stderr)
    for depth, name, signature, seconds in listener.rows:
        if seconds >= 0.05:
            print(f"{'  ' * depth}{seconds:7.2f} s  {name}({signature[:150]})", file=sys.stderr)
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
