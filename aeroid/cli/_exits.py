"""How a command ends: one line for every way it can fail, SIGTERM, repeated warnings.

Used by :func:`aeroid.cli.main`: a stream that names itself in its write errors
(``standard output: No space left on device``), one line for an OS error, SIGTERM turned
into the Ctrl-C unwinding (exit status 143), and library warnings shown once per place.
"""

from __future__ import annotations

import contextlib
import errno
import io
import os
import signal
import sys
from pathlib import Path
from typing import Any

from aeroid.errors import AeroidWarning

#: Exit statuses of every command: done; finished and its output written, but not a
#: success (``estimate``: a method failed or its fit check refused the fit; ``reconstruct``:
#: an aiding source's residual check is NOT consistent with its stated sd); bad input or a
#: refusal (one line on stderr). Ctrl-C is 130 and SIGTERM 143.
EXIT_DONE, EXIT_NOT_SUCCESS, EXIT_BAD_INPUT = 0, 1, 2


class WarningLines:
    """``warnings.showwarning`` for the command line: one line per warning, once per place.

    An AeroidWarning is ``aeroid: warning: MESSAGE``, every time (each names its own
    input). Any other warning (numpy, scipy, filterpy) is one line the first time it
    comes from a place (category, file, line); later ones from that place are counted and
    :meth:`summary` says how many (the EKF on extreme accelerations printed 4006 lines of
    one scipy warning).
    """

    def __init__(self) -> None:
        self.repeats: dict[tuple[str, str, int], int] = {}

    def __call__(self, message: Warning | str, category: type[Warning], filename: str,
                 lineno: int, file: Any = None, line: str | None = None) -> None:
        """Print one warning (or count it)."""
        text = " ".join(str(message).split())
        if issubclass(category, AeroidWarning):
            print(f"aeroid: warning: {text}", file=sys.stderr)
            return
        key = (category.__name__, filename, lineno)
        if key in self.repeats:
            self.repeats[key] += 1
            return
        self.repeats[key] = 0
        print(f"aeroid: warning: {category.__name__} at {_short_path(filename)}:{lineno}: "
              f"{text}", file=sys.stderr)

    def summary(self) -> None:
        """One line per place whose warning came again."""
        for (name, filename, lineno), count in self.repeats.items():
            if count:
                print(f"aeroid: warning: {name} at {_short_path(filename)}:{lineno} came "
                      f"{count} more time(s), not shown", file=sys.stderr)


def _short_path(filename: str) -> str:
    """``filterpy/kalman/EKF.py`` for a file in site-packages (the last three parts)."""
    return "/".join(Path(filename).parts[-3:])


def os_message(exc: OSError) -> str:
    """One line for an OS error: the file, what failed, and a hint for the usual causes."""
    reason = exc.strerror or str(exc) or type(exc).__name__
    if exc.filename == "standard output":
        return f"standard output: cannot write: {reason}"
    where = exc.filename if exc.filename is not None else "a file"
    hints = {errno.ENAMETOOLONG: " (a file name is at most 255 bytes, a path 4096)",
             errno.ELOOP: " (a symbolic link that points to itself?)",
             errno.ENOSPC: " (the disk is full)"}
    return f"{where}: cannot read or write it: {reason}{hints.get(exc.errno or 0, '')}"


class NamedStream:
    """A text stream whose write errors name it (``standard output: No space left``)."""

    def __init__(self, stream: Any, name: str) -> None:
        self._stream = stream
        self._name = name

    def write(self, text: str) -> int:
        """Write ``text``; an OSError is raised again naming the stream."""
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror or str(exc), self._name) from None

    def flush(self) -> None:
        """Flush; an OSError is raised again naming the stream."""
        try:
            self._stream.flush()
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror or str(exc), self._name) from None

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def drop_stdout() -> None:
    """Point standard output at /dev/null, so the exit's flush cannot fail again."""
    with contextlib.suppress(OSError, ValueError, AttributeError,
                             io.UnsupportedOperation):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.__stdout__.fileno())  # type: ignore[union-attr]
        os.close(devnull)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread: the same unwinding as Ctrl-C (nothing lost)."""


def _on_sigterm(signum: int, frame: Any) -> None:
    raise Terminated


def catch_sigterm() -> Any:
    """Turn SIGTERM into :class:`Terminated`; return the previous handler (None: not set)."""
    try:
        return signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # not the main thread (main() called from a thread)
        return None


def restore_sigterm(previous: Any) -> None:
    if previous is not None:
        signal.signal(signal.SIGTERM, previous)
