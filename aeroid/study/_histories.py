"""Run-0 convergence histories of a study, one ``.npz`` file per (noise, estimator) pair.

Files are named by the pair's indices in the design (``histories/n<k>-e<j>.npz``), never
by labels, so two labels that differ only in characters a file name cannot hold
(``M/1`` and ``M_1``) keep their own files. The record of a fit names its history
file; :func:`load_history` finds it from the labels through ``study.json``.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from aeroid.errors import StudyError
from aeroid.study._store import HISTORY_DIR, TMP_SUFFIX, os_error, read_design


def _savez(path: Path, arrays: Mapping[str, np.ndarray]) -> None:
    """Write ``arrays`` as a compressed ``.npz`` to ``path`` and flush it to disk."""
    with path.open("wb") as fh:
        np.savez_compressed(fh, **arrays)
        fh.flush()
        os.fsync(fh.fileno())


def history_name(noise_index: int, estimator_index: int) -> str:
    """Return the history file of a (noise, estimator) pair, relative to the folder."""
    return f"{HISTORY_DIR}/n{noise_index}-e{estimator_index}.npz"


def save_history(out_dir: Path, name: str, history: Mapping[str, Any]) -> None:
    """Write a history (``history_*``/``info_*`` arrays) as ``out_dir/name``, atomically.

    Raises
    ------
    StudyError
        On any OS error; no temporary file is left behind.
    """
    path = out_dir / name
    arrays = {k: (np.asarray(str(v)) if k == "history_axis" else np.asarray(v))
              for k, v in history.items()}
    tmp = path.with_name(path.name + TMP_SUFFIX)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        _savez(tmp, arrays)
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise os_error(path, "write the history", exc) from None


def read_history(out_dir: str | Path, name: str) -> dict[str, Any] | None:
    """Return the arrays of a history file named by a record, or None if it is missing."""
    path = Path(out_dir) / name
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            out = {k: data[k] for k in data.files}
    except (OSError, ValueError) as exc:
        raise StudyError(f"{path}: cannot read the history ({exc})") from None
    if "history_axis" in out:
        out["history_axis"] = str(out["history_axis"])
    return out


def history_index(design: Mapping[str, Any], noise: str, estimator: str
                  ) -> tuple[int, int] | None:
    """Return the (noise, estimator) indices of two labels in a ``study.json`` design."""
    noises = [n.get("label") for n in design.get("noise", [])]
    estimators = [e.get("label") for e in design.get("estimators", [])]
    if noise not in noises or estimator not in estimators:
        return None
    return noises.index(noise), estimators.index(estimator)


def load_history(out_dir: str | Path, noise: str, estimator: str) -> dict[str, Any] | None:
    """Return the run-0 history of (noise label, estimator label), or None.

    The labels are looked up in the folder's ``study.json``; the arrays are the
    ``history_*`` and ``info_*`` keys of the fit's ``EstimationResult``.
    """
    index = history_index(read_design(out_dir), noise, estimator)
    return None if index is None else read_history(out_dir, history_name(*index))




__all__ = ["history_index", "history_name", "load_history", "read_history", "save_history"]
