"""The study store: a study's folder on disk, written so that no finished fit is lost.

Layout of an output folder::

    study.json        the design (Study.describe()) and the code that ran it
    floors.json       the Cramér-Rao floors of every noise condition (computed once, before
                      the first fit; aeroid.study._floors)
    results.jsonl     one JSON record per finished fit, appended as each finishes
    histories/        run-0 convergence histories, one file per (noise, estimator)
                      index pair: n<k>-e<j>.npz (indices of the design, never labels)
    previous-<N>/     older results moved aside by --overwrite (N = 1, 2, ...)

and the report's files (``report.md``, ``results.csv``, ``summary.csv``, ``figures/``).
Opening a folder for a study (resume, overwrite) is :mod:`aeroid.study._folder`.

Guarantees (each has a test, several with real SIGKILLs):

- A record reaches ``results.jsonl`` only after its history file is complete on disk
  (written to a temporary name, flushed, renamed), and names that file; a kill
  between the two leaves a history without a record, which the resumed study
  refits. A record whose history file is missing is dropped on resume and refitted.
- A record is appended with one ``write`` of the whole line and flushed to disk; a
  partly written last line (a kill mid-write) is removed on resume.
- A failed write (a full disk, a permission change) raises a one-line
  :class:`aeroid.errors.StudyError`, removes its temporary file and truncates a
  partly appended line, so the folder stays resumable.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from aeroid.errors import StudyError

RESULTS_FILE = "results.jsonl"
DESIGN_FILE = "study.json"
FLOORS_FILE = "floors.json"
HISTORY_DIR = "histories"
REPORT_FILES = ("report.md", "results.csv", "summary.csv", "figures")
#: Everything a study writes into its folder (moved aside together by ``overwrite``).
STUDY_FILES = (DESIGN_FILE, FLOORS_FILE, RESULTS_FILE, HISTORY_DIR, *REPORT_FILES)
PREVIOUS_PREFIX = "previous-"
TMP_SUFFIX = ".tmp"
#: Required keys of a record and their JSON types (checked when results are read back).
HISTORY_NAME = re.compile(HISTORY_DIR + r"/n[0-9]+-e[0-9]+\.npz")
RECORD_TYPES: dict[str, type | tuple[type, ...]] = {
    "run": int, "noise": str, "estimator": str, "success": bool, "theta": list}


# --------------------------------------------------------------------------------------
# Low-level writes (tests replace these to simulate a full disk)
# --------------------------------------------------------------------------------------
def _write_all(fd: int, data: bytes) -> None:
    """Write every byte of ``data`` to the file descriptor ``fd``."""
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


def os_error(path: Path, what: str, exc: OSError) -> StudyError:
    reason = exc.strerror or str(exc)
    if exc.errno == errno.ENOSPC:
        reason += " (free some space, then rerun with --resume)"
    return StudyError(f"{path}: cannot {what}: {reason}")


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file and a rename.

    Raises
    ------
    StudyError
        On any OS error; the temporary file is removed and ``path`` is unchanged.
    """
    tmp = path.with_name(path.name + TMP_SUFFIX)
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        try:
            _write_all(fd, data)
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise os_error(path, "write", exc) from None


# --------------------------------------------------------------------------------------
# Design file
# --------------------------------------------------------------------------------------
def write_design(out_dir: Path, design: Mapping[str, Any]) -> None:
    """Write ``study.json`` (atomically)."""
    write_atomic(out_dir / DESIGN_FILE, (json.dumps(design, indent=2) + "\n").encode())


def read_design(out_dir: str | Path) -> dict[str, Any]:
    """Return the parsed ``study.json`` of a study folder.

    Raises
    ------
    StudyError
        When it is missing, unreadable, not JSON or not a design (no fingerprint).
    """
    path = Path(out_dir) / DESIGN_FILE
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise StudyError(f"{path}: missing (the folder holds no study design)") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise StudyError(f"{path}: cannot read ({exc})") from None
    except json.JSONDecodeError as exc:
        raise StudyError(f"{path}: not valid JSON ({exc.msg}, line {exc.lineno})") from None
    if not isinstance(data, dict) or not isinstance(data.get("fingerprint"), str):
        raise StudyError(f"{path}: not a study design (no fingerprint)")
    return data


# --------------------------------------------------------------------------------------
# Records
# --------------------------------------------------------------------------------------
def check_record(record: Any) -> str | None:
    """Return what is wrong with a record read back from ``results.jsonl``, or None."""
    if not isinstance(record, dict):
        return "not a JSON object"
    for key, kind in RECORD_TYPES.items():
        value = record.get(key)
        if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
            return f"{key!r} missing or not {getattr(kind, '__name__', kind)}"
    if record["run"] < 0:
        return "'run' is negative"
    history = record.get("history")
    if history is not None and not (isinstance(history, str)
                                    and HISTORY_NAME.fullmatch(history)):
        return "'history' is not a file name like histories/n0-e1.npz"
    return None


def read_results(path: str | Path, *, repair: bool = False) -> list[dict[str, Any]]:
    """Return the records of a results file (one JSON object per line).

    A partly written last line (a study killed while writing) is ignored, and removed
    from the file when ``repair`` is true, so that appending goes on cleanly.

    Raises
    ------
    StudyError
        When a line other than the last is not valid JSON or not a record (the file is
        damaged), or the file cannot be read.
    """
    path = Path(path)
    if not path.exists():
        return []
    if not path.is_file():
        raise StudyError(f"{path}: not a regular file")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise os_error(path, "read", exc) from None
    lines = raw.split(b"\n")  # the last element is what follows the last newline
    records, good_bytes = [], 0
    for k, line in enumerate(lines[:-1]):
        if line.strip():
            try:
                record = json.loads(line)
            except (json.JSONDecodeError, UnicodeDecodeError):
                raise StudyError(f"{path}: line {k + 1} is not valid JSON (damaged file)"
                                 ) from None
            problem = check_record(record)
            if problem:
                raise StudyError(f"{path}: line {k + 1} is not a study record ({problem})")
            records.append(record)
        good_bytes += len(line) + 1
    if repair and good_bytes < len(raw):
        try:
            with path.open("r+b") as fh:  # drop the partly written last line
                fh.truncate(good_bytes)
        except OSError as exc:
            raise os_error(path, "repair", exc) from None
    return records


def rewrite_results(path: Path, records: Iterable[Mapping[str, Any]]) -> None:
    """Replace a results file by ``records`` (atomically)."""
    text = "".join(json.dumps(r, allow_nan=False) + "\n" for r in records)
    write_atomic(path, text.encode())


class RecordWriter:
    """Appends records to ``results.jsonl``: one write per line, flushed to disk.

    A failed write truncates the file back to its last complete line and raises a
    one-line :class:`StudyError`. Use as a context manager.
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        try:
            self._fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        except OSError as exc:
            raise os_error(path, "open", exc) from None

    def append(self, record: Mapping[str, Any]) -> None:
        """Append one record as a line of JSON (NaN is not allowed: use None)."""
        data = (json.dumps(record, allow_nan=False) + "\n").encode()
        size = os.fstat(self._fd).st_size
        try:
            _write_all(self._fd, data)
            os.fsync(self._fd)
        except OSError as exc:
            with contextlib.suppress(OSError):
                os.ftruncate(self._fd, size)
            raise os_error(self.path, "append a record", exc) from None

    def close(self) -> None:
        """Close the file."""
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1

    def __enter__(self) -> RecordWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


__all__ = ["DESIGN_FILE", "FLOORS_FILE", "HISTORY_DIR", "RESULTS_FILE", "STUDY_FILES",
           "RecordWriter", "check_record", "os_error", "read_design", "read_results",
           "rewrite_results", "write_atomic", "write_design"]
