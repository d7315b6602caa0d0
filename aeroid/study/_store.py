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

Guarantees (each has a test, several with real SIGKILLs):

- A folder that holds a study's files is never written over: a new study there needs
  ``resume`` (same design and same code, checked against ``study.json``) or
  ``overwrite`` (the old files are moved into a new ``previous-<N>/``; an existing one
  is never replaced).
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
from aeroid.study._provenance import code_differences

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
# The folder
# --------------------------------------------------------------------------------------
def check_out_dir(out_dir: str | Path) -> Path:
    """Return ``out_dir`` as a Path after checking it may hold a study.

    Raises
    ------
    StudyError
        When it is an existing file, or the working directory or one of its parents
        (a study writes and moves files: it gets a folder of its own).
    """
    path = Path(out_dir)
    try:
        if path.exists() and not path.is_dir():
            raise StudyError(f"--out {path}: is a file, not a folder")
        resolved, cwd = path.resolve(strict=False), Path.cwd().resolve()
    except (OSError, RuntimeError) as exc:  # RuntimeError: pathlib's symlink loop
        reason = getattr(exc, "strerror", None) or "a symbolic link loop"
        raise StudyError(f"--out {_short(path)}: cannot use it as a folder: {reason}") from None
    if resolved == cwd or resolved in cwd.parents:
        raise StudyError(f"--out {path}: is the working directory or one of its parents; "
                         "a study needs a folder of its own (e.g. --out results/NAME)")
    return path


def _short(path: Path, limit: int = 200) -> str:
    """``path`` for a message: a 5000-character name is cut to its start and end."""
    text = str(path)
    return text if len(text) <= limit else f"{text[:90]}...{text[-90:]} ({len(text)} characters)"


def study_files(out_dir: Path) -> list[str]:
    """Return the names of a study's files present in ``out_dir`` (empty results ignored)."""
    found = []
    for name in STUDY_FILES:
        p = out_dir / name
        if name == RESULTS_FILE and p.is_file() and p.stat().st_size == 0:
            continue
        if p.exists() or p.is_symlink():
            found.append(name)
    return found


def move_aside(out_dir: Path) -> Path | None:
    """Move the study's files of ``out_dir`` into a new ``previous-<N>/``; return it.

    ``N`` is the smallest number whose folder does not exist yet (created exclusively,
    so an earlier ``previous-<N>`` is never replaced). Returns None when there was
    nothing to move.
    """
    names = study_files(out_dir)
    if not names:
        return None
    n = 1
    while True:
        target = out_dir / f"{PREVIOUS_PREFIX}{n}"
        try:
            target.mkdir()
            break
        except FileExistsError:
            n += 1
        except OSError as exc:
            raise os_error(target, "create the folder", exc) from None
    for name in names:
        try:
            os.replace(out_dir / name, target / name)
        except OSError as exc:
            raise os_error(out_dir / name, f"move it to {target}", exc) from None
    return target


def remove_temporary(out_dir: Path) -> None:
    """Remove temporary files left by a killed writer (``*.tmp`` in the store, figures)."""
    for folder in (out_dir, out_dir / HISTORY_DIR, out_dir / "figures"):
        if folder.is_dir():
            for p in folder.glob(f"*{TMP_SUFFIX}"):
                with contextlib.suppress(OSError):
                    p.unlink()


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


# --------------------------------------------------------------------------------------
# Opening a folder for a study
# --------------------------------------------------------------------------------------
def _check_resumable(out_dir: Path, design: Mapping[str, Any]) -> str | None:
    """Refuse another design or other code; return a note when only the CPU differs."""
    old = read_design(out_dir)
    if old["fingerprint"] != design["fingerprint"]:
        raise StudyError(f"{out_dir}: the results there come from another study design "
                         "(different seed, scenario, noise or estimators); use another --out")
    old_code, new_code = old.get("code"), design["code"]
    if not isinstance(old_code, dict) or not isinstance(old_code.get("id"), str):
        raise StudyError(f"{out_dir / DESIGN_FILE}: does not say which code computed its "
                         "results (written by an older aeroid); resuming could mix code "
                         "versions: use --overwrite to start again, or another --out")
    if old_code["id"] != new_code["id"]:
        changes = "; ".join(code_differences(old_code, new_code)) or "code identity"
        raise StudyError(f"{out_dir}: its results were computed by other code ({changes}); "
                         "resuming would mix two code versions in one table: use "
                         "--overwrite to start again, or another --out")
    if old_code.get("cpu") != new_code.get("cpu"):
        return (f"the results in {out_dir} were computed on a {old_code.get('cpu')} CPU, "
                f"this one is {new_code.get('cpu')}: fits run here may differ in the last "
                "digits (fast-math kernels), EAM-PSO's estimates more")
    return None


def open_store(out_dir: str | Path, design: Mapping[str, Any], *, resume: bool = False,
               overwrite: bool = False) -> tuple[list[dict[str, Any]], list[str]]:
    """Prepare a folder for a study; return the records to keep and notes for the user.

    Parameters
    ----------
    out_dir : path-like
        The study's folder (created if needed; see :func:`check_out_dir`).
    design : dict
        What ``study.json`` will hold: ``Study.describe()`` plus ``code``
        (:func:`aeroid.study.code_identity`).
    resume : bool
        Keep the records of the same design computed by the same code (``study.json``
        is required and compared; a mismatch refuses). Records whose history file is
        missing are dropped (they are refitted).
    overwrite : bool
        Move a previous study's files into a new ``previous-<N>/`` first.

    Raises
    ------
    StudyError
        The folder holds a study's files and neither flag is given; ``resume`` with a
        missing or different design or other code; both flags; an OS error.
    """
    if resume and overwrite:
        raise StudyError("give --resume or --overwrite, not both")
    out_dir = check_out_dir(out_dir)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise os_error(out_dir, "create the folder", exc) from None
    remove_temporary(out_dir)
    present = study_files(out_dir)
    records: list[dict[str, Any]] = []
    notes: list[str] = []
    results = out_dir / RESULTS_FILE
    if present and resume:
        note = _check_resumable(out_dir, design)
        if note:
            notes.append(note)
        records = read_results(results, repair=True)
        code = design["code"]["id"]
        for k, r in enumerate(records):
            if r.get("code") != code:
                raise StudyError(f"{results}: record {k + 1} was computed by other code "
                                 f"({r.get('code')} vs {code}); use --overwrite or another "
                                 "--out")
        lost = [r for r in records if r.get("history")
                and not (out_dir / r["history"]).is_file()]
        if lost:
            records = [r for r in records if r not in lost]
            rewrite_results(results, records)
            notes.append(f"{len(lost)} record(s) in {results} lost their history file: "
                         "they are refitted")
    elif present and overwrite:
        notes.append(f"moved the previous results in {out_dir} to {move_aside(out_dir)}")
    elif present:
        raise StudyError(f"{out_dir}: holds a study's results ({', '.join(present)}); use "
                         "--resume to complete them, --overwrite to move them aside into "
                         f"{out_dir / PREVIOUS_PREFIX}N/, or another --out")
    elif resume:
        notes.append(f"nothing to resume in {out_dir}: the study starts from the beginning")
    write_design(out_dir, design)
    if not results.exists():
        write_atomic(results, b"")
    return records, notes


__all__ = ["DESIGN_FILE", "FLOORS_FILE", "HISTORY_DIR", "RESULTS_FILE", "STUDY_FILES",
           "RecordWriter", "check_out_dir", "check_record", "move_aside", "open_store",
           "os_error", "read_design", "read_results", "remove_temporary", "rewrite_results",
           "study_files", "write_atomic", "write_design"]
