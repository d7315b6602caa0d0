"""One writer per study folder: a lock file holding its owner's process id.

Two studies writing one folder (a ``--resume`` started while the first still ran) gave
122 records with 42 duplicates. :func:`study_lock` takes ``<folder>/study.lock`` for
the whole run and report: an advisory ``flock`` on it (released by the kernel when the
owner dies, whatever kills it) and one line inside saying who holds it. A second study
is refused with that line; a lock file left by a process that died (its ``flock`` gone,
its line still there) is taken over with a note naming the dead owner.

Where ``fcntl`` is missing (Windows) the owner's pid is tested instead: a live pid
refuses, a dead one is taken over.
"""

from __future__ import annotations

import contextlib
import datetime
import os
import socket
from collections.abc import Iterator
from pathlib import Path

from aeroid.errors import StudyError

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

#: The lock file inside a study folder (not one of the study's files: never moved aside).
LOCK_FILE = "study.lock"


def _owner_line() -> str:
    now = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M:%S UTC")
    return f"pid {os.getpid()} on {socket.gethostname()} since {now}"


def _read(fd: int) -> str:
    with contextlib.suppress(OSError):
        return os.pread(fd, 4096, 0).decode("utf-8", "replace").strip()
    return ""


def _pid_alive(line: str) -> bool:
    """Whether the ``pid N on HOST`` of ``line`` runs here (another host: assume it does)."""
    parts = line.split()
    if len(parts) < 4 or parts[0] != "pid" or not parts[1].isdigit():
        return False
    if parts[3] != socket.gethostname():
        return True
    try:
        os.kill(int(parts[1]), 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True  # exists, owned by someone else
    return True


def _acquire(path: Path) -> tuple[int, str]:
    """Open and lock ``path``; return ``(fd, the previous owner's line or "")``."""
    for _ in range(10):  # retried when the holder removed the file under us
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        previous = _read(fd)
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                raise StudyError(f"{path.parent}: another study is writing this folder "
                                 f"({previous or 'owner unknown'}); wait for it to finish, "
                                 "or use another --out") from None
            try:
                same = os.fstat(fd).st_ino == os.stat(path).st_ino
            except FileNotFoundError:
                same = False
            if not same:  # the owner finished and removed it between open and flock
                os.close(fd)
                continue
        elif previous and _pid_alive(previous):  # pragma: no cover - Windows
            os.close(fd)
            raise StudyError(f"{path.parent}: another study is writing this folder "
                             f"({previous}); wait for it to finish, or use another --out")
        return fd, previous
    raise StudyError(f"{path}: could not take the lock (it keeps being replaced)")


@contextlib.contextmanager
def study_lock(out_dir: str | Path) -> Iterator[list[str]]:
    """Hold the lock of a study folder (created if needed); yield notes for the user.

    Raises
    ------
    StudyError
        Another live process holds the folder, or the lock file cannot be written.
    """
    out_dir = Path(out_dir)
    path = out_dir / LOCK_FILE
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        fd, previous = _acquire(path)
    except OSError as exc:
        raise StudyError(f"{path}: cannot take the study's lock: {exc.strerror or exc}"
                         ) from None
    notes = []
    if previous:
        notes.append(f"took over the lock {path} left by {previous}, which is no longer "
                     "running")
    try:
        line = (_owner_line() + "\n").encode()
        os.ftruncate(fd, 0)
        os.pwrite(fd, line, 0)
    except OSError as exc:
        os.close(fd)
        raise StudyError(f"{path}: cannot write the study's lock: {exc.strerror or exc}"
                         ) from None
    try:
        yield notes
    finally:
        with contextlib.suppress(OSError):
            path.unlink()  # while still locked: the next owner finds no dead owner's line
        os.close(fd)


__all__ = ["LOCK_FILE", "study_lock"]
