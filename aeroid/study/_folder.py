"""A study's folder: checked, opened for a new study, resumed or moved aside.

Guarantees (each has a test; the files themselves: :mod:`aeroid.study._store`):

- A folder that holds a study's files is never written over: a new study there needs
  ``resume`` (same design and same code, checked against ``study.json``) or
  ``overwrite`` (the old files are moved into a new ``previous-<N>/``; an existing one
  is never replaced).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from aeroid.errors import StudyError
from aeroid.study._provenance import code_differences
from aeroid.study._store import (
    DESIGN_FILE,
    HISTORY_DIR,
    PREVIOUS_PREFIX,
    RESULTS_FILE,
    STUDY_FILES,
    TMP_SUFFIX,
    os_error,
    read_design,
    read_results,
    rewrite_results,
    write_atomic,
    write_design,
)


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


__all__ = ["check_out_dir", "move_aside", "open_store", "remove_temporary", "study_files"]
