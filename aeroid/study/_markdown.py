"""Markdown tables of a study's reports: numbers formatted for reading, counts as integers."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np


def _fmt(x: Any, digits: int = 3) -> str:
    if isinstance(x, float) and math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a"
    if isinstance(x, float | np.floating):
        if x == 0:
            return "0"
        if float(x).is_integer() and 100 <= abs(x) < 1e7:
            return str(int(x))
        if abs(x) >= 1000 or abs(x) < 0.01:
            return f"{x:.{digits}g}"
        return f"{x:.{digits}g}" if abs(x) < 1 else f"{x:.{max(digits - 1, 1)}f}"
    return str(x)


def _count(x: Any) -> str:
    """A count (or a median of counts): an integer, or one decimal for a half."""
    if x is None or not math.isfinite(float(x)):
        return "n/a"
    return str(int(x)) if float(x).is_integer() else f"{float(x):.1f}"


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]],
           counts: Sequence[int] = ()) -> list[str]:
    """Markdown table; the columns whose indices are in ``counts`` print as integers."""
    lines = ["| " + " | ".join(header) + " |",
             "|" + "|".join("---:" if k else ":---" for k in range(len(header))) + "|"]
    lines += ["| " + " | ".join(_count(v) if k in counts else _fmt(v)
                                for k, v in enumerate(row)) + " |" for row in rows]
    return lines


__all__ = ["_count", "_fmt", "_table"]
