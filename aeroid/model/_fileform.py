"""Reading and checking aeroid's small text files (TOML tables, JSON sidecars).

Every check raises :class:`~aeroid.errors.AirframeError` with one line naming where
(``"FILE: [table] key"``) and what was found. A boolean is not a number (TOML's
``true`` and JSON's ``true`` are refused where a number belongs), text is not a number,
and every table accepts only the keys it documents.
"""

from __future__ import annotations

import math
import os
import stat
import tomllib
from collections.abc import Collection, Mapping
from numbers import Real
from pathlib import Path
from typing import Any

from aeroid.errors import AeroidError, AirframeError

#: Largest TOML file (airframe, scenario, column map, study) read [bytes]. aeroid's own
#: files are 1-3 kB; a file this large is not one of them (``/dev/zero`` given as a
#: scenario used to grow memory until the machine ran out).
MAX_TOML_BYTES = 1 << 20


def regular_file_size(path: Path, error: type[AeroidError] = AirframeError) -> int:
    """Return the size of ``path`` [bytes] after checking that it is a regular file.

    A FIFO would block the reader forever and a device (``/dev/zero``) never ends, so
    both are refused before anything is opened.

    Raises
    ------
    AeroidError
        ``error`` with one line: no such file, a folder, or not a regular file.
    """
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise error(f"{path}: no such file") from None
    except OSError as exc:
        raise error(f"{path}: cannot read ({exc.strerror})") from None
    if stat.S_ISDIR(info.st_mode):
        raise error(f"{path}: is a folder, not a file")
    if not stat.S_ISREG(info.st_mode):
        raise error(f"{path}: not a regular file (a FIFO, socket or device): "
                    f"save the data to a file first")
    return info.st_size


def read_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file, turning every failure into a one-line ``AirframeError``.

    Refuses non-regular files and files over :data:`MAX_TOML_BYTES` before reading.
    """
    path = Path(path)
    size = regular_file_size(path)
    if size > MAX_TOML_BYTES:
        raise AirframeError(f"{path}: {size} bytes is too large for an aeroid TOML file "
                            f"(limit {MAX_TOML_BYTES}); is it the right file?")
    try:
        with path.open("rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise AirframeError(f"{path}: malformed TOML ({exc}){_bom_hint(path)}") from None
    except RecursionError:  # tomllib recurses once per nested array or inline table
        raise AirframeError(f"{path}: malformed TOML (arrays or tables nested thousands "
                            "deep)") from None
    except UnicodeDecodeError:
        raise AirframeError(f"{path}: malformed TOML (not UTF-8 text)") from None
    except OSError as exc:
        raise AirframeError(f"{path}: cannot read ({exc.strerror})") from None


def _bom_hint(path: Path) -> str:
    """A hint when the file starts with a UTF-8 byte-order mark (TOML forbids it)."""
    try:
        with path.open("rb") as fh:
            bom = fh.read(3) == b"\xef\xbb\xbf"
    except OSError:
        return ""
    return ("; the file starts with a UTF-8 byte-order mark (BOM), which TOML does not "
            "allow: save it as UTF-8 without BOM" if bom else "")


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(float(value)) if isinstance(value, float) else str(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def dumps_toml(data: Mapping[str, Mapping[str, Any]]) -> str:
    """Write a two-level mapping (tables of scalars and lists) as TOML text."""
    lines: list[str] = []
    for table, entries in data.items():
        lines.append(f"[{table}]")
        lines.extend(f"{key} = {_toml_value(value)}" for key, value in entries.items())
        lines.append("")
    return "\n".join(lines)


# Checks ------------------------------------------------------------------------------
def check_table(value: Any, where: str) -> Mapping[str, Any]:
    """Return ``value`` when it is a table (mapping), else raise naming ``where``."""
    if not isinstance(value, Mapping):
        raise AirframeError(f"{where} must be a table, got {_shown(value)}")
    return value


def check_keys(table: Mapping[str, Any], allowed: Collection[str], where: str,
               required: Collection[str] = ()) -> None:
    """Refuse unknown keys and missing required keys of ``table`` (one line, ``where``)."""
    unknown = sorted(str(k) for k in table if k not in allowed)
    if unknown:
        raise AirframeError(f"{where} has unknown key(s) {', '.join(unknown)} "
                            f"(allowed: {', '.join(allowed)})")
    missing = [k for k in required if k not in table]
    if missing:
        raise AirframeError(f"{where} is missing {', '.join(missing)}")


def is_number(value: Any) -> bool:
    """Return True for a real number that is not a boolean (finite or not) and is a float.

    An integer beyond the float range (TOML and JSON read a 400-digit integer exactly)
    is not one: ``float()`` of it raises OverflowError.
    """
    if not isinstance(value, Real) or isinstance(value, bool):
        return False
    try:
        float(value)
    except OverflowError:
        return False
    return True


def number(value: Any, where: str) -> float:
    """Return ``value`` as a finite float; a boolean or text is not a number."""
    if not is_number(value) or not math.isfinite(float(value)):
        raise AirframeError(f"{where} must be a finite number, got {_shown(value)}"
                            f"{_too_large(value)}")
    return float(value)


def integer(value: Any, where: str) -> int:
    """Return ``value`` as an int; refuses booleans, text and non-integral floats."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise AirframeError(f"{where} must be an integer, got {_shown(value)}")
    return int(value)


def numbers(value: Any, length: int, where: str) -> tuple[float, ...]:
    """Return ``value`` as a tuple of ``length`` finite floats."""
    if isinstance(value, str | bytes | Mapping) or not hasattr(value, "__len__"):
        raise AirframeError(f"{where} must be {length} numbers, got {_shown(value)}")
    items = list(value)
    if len(items) != length or not all(
            is_number(x) and math.isfinite(float(x)) for x in items):
        raise AirframeError(f"{where} must be {length} finite numbers, got {_shown(value)}")
    return tuple(float(x) for x in items)


def text(value: Any, where: str) -> str:
    """Return ``value`` when it is a non-empty string."""
    if not isinstance(value, str) or not value.strip():
        raise AirframeError(f"{where} must be a non-empty string, got {_shown(value)}")
    return value


def _too_large(value: Any) -> str:
    """`` (an integer of N digits, beyond the float range)`` for such a value, else ``""``."""
    if isinstance(value, int) and not isinstance(value, bool) and not is_number(value):
        return f" (an integer of {len(str(abs(value)))} digits, beyond the float range)"
    return ""


def _shown(value: Any) -> str:
    """A short, one-line representation of a bad value for a message."""
    shown = repr(value)
    shown = " ".join(shown.split())
    return shown if len(shown) <= 60 else shown[:57] + "..."
