"""Atomic writes: a file appears whole or not at all (temp file beside it + ``os.replace``)."""

from __future__ import annotations

import contextlib
import io
import os
from pathlib import Path
from typing import Any

from aeroid.errors import UsageError

#: Suffix of the temporary file written beside the target.
TMP_SUFFIX = ".tmp"


def write_bytes_atomic(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file and ``os.replace``.

    Raises
    ------
    UsageError
        One line naming the path when it cannot be written (no permission, no space, a
        directory in the way).
    """
    path = Path(path)
    tmp = path.with_name(path.name + TMP_SUFFIX)
    try:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise UsageError(f"{path}: cannot write ({exc.strerror or exc})") from None
    return path


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`write_bytes_atomic`)."""
    return write_bytes_atomic(path, text.encode("utf-8"))


def write_figure_atomic(fig: Any, path: str | Path, dpi: int) -> Path:
    """Render ``fig`` as PNG in memory and write it atomically."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    return write_bytes_atomic(path, buffer.getvalue())


def make_directory(path: str | Path) -> Path:
    """Create ``path`` (and parents); one line naming it when that fails."""
    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{path}: cannot create the report folder "
                         f"({exc.strerror or exc})") from None
    if not path.is_dir():
        raise UsageError(f"{path}: not a folder")
    return path
