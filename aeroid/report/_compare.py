"""Several methods on one log, side by side (``aeroid estimate LOG --method all``).

One column per method; one row per coefficient (``estimate +- stderr``), then the fit
check's worst ratio, success, wall time and the options each method was given. With a
simulated flight's truth, a ``truth`` column. Below the table, one line per option (the
methods it was given to, and those that do not have it) and per failure or warning.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from aeroid.estimation import EstimationResult

__all__ = ["compare_results", "comparison_markdown", "comparison_text", "options_note",
           "result_notes"]


def _cell(value: float, se: float | None) -> str:
    if not math.isfinite(value):
        return "n/a"
    text = f"{value:.5g}"
    if se is not None and math.isfinite(se):
        text += f" ± {se:.2g}"
    return text


def _fit_check_cell(result: EstimationResult) -> str:
    check = result.info.get("fit_check")
    if not isinstance(check, Mapping) or not check.get("ratio"):
        return "none"
    worst = check["worst"]
    return f"{check['ratio'][worst]:.3g} ({worst})"


def compare_results(results: Mapping[str, EstimationResult],
                    applied: Mapping[str, Mapping[str, Any]] | None = None,
                    truth: np.ndarray | None = None) -> pd.DataFrame:
    """Return the side-by-side table: rows are coefficients then ``fit check`` (the worst
    ratio and its channel), ``success``, ``time [s]``, ``options``; columns the methods
    (and ``truth`` when given). Cells are text (``estimate ± stderr``). The messages and
    warnings are :func:`result_notes`.

    ``applied``: the options each method was given (method -> {name: value}).
    """
    applied = applied or {}
    first = next(iter(results.values()), None)
    names = list(first.names) if first is not None else []
    columns: dict[str, list[str]] = {}
    for method, result in results.items():
        se = [None] * len(names) if result.stderr is None else list(result.stderr)
        cells = [_cell(float(v), s) for v, s in zip(result.theta, se, strict=True)]
        options = applied.get(method, {})
        cells += [_fit_check_cell(result), "yes" if result.success else "FAILED",
                  f"{result.wall_time_s:.3g}",
                  ", ".join(f"{k}={v}" for k, v in options.items()) or "-"]
        columns[method] = cells
    index = [*names, "fit check", "success", "time [s]", "options"]
    frame = pd.DataFrame(columns, index=pd.Index(index, name="coefficient"))
    if truth is not None:
        frame.insert(0, "truth", [f"{v:.5g}" for v in truth] + [""] * (len(index) - len(names)))
    return frame


def result_notes(results: Mapping[str, EstimationResult]) -> list[str]:
    """One line per failed method (its message) and per warning of a method."""
    lines = []
    for method, result in results.items():
        if not result.success:
            lines.append(f"{method} FAILED: {' '.join(result.message.split())}")
        lines += [f"{method} warning: {w}" for w in result.warnings]
    return lines


def options_note(given: Sequence[str], applied: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """One line per option given: the methods that took it and those that do not have it."""
    lines = []
    for key in given:
        took = [m for m, opts in applied.items() if key in opts]
        left = [m for m in applied if m not in took]
        line = f"option {key}: applied to {', '.join(took) or 'none'}"
        if left:
            line += f"; not an option of {', '.join(left)}"
        lines.append(line)
    return lines


def comparison_text(frame: pd.DataFrame, notes: Sequence[str] = ()) -> str:
    """The table as fixed-width text (a terminal), then the notes."""
    table = frame.copy()
    table.index.name = None
    with pd.option_context("display.max_columns", None, "display.width", 10_000,
                           "display.max_colwidth", 60):
        text = table.to_string()
    return text + ("\n" + "\n".join(notes) if notes else "")


def comparison_markdown(frame: pd.DataFrame, notes: Sequence[str] = (),
                        links: Mapping[str, str] | None = None) -> str:
    """The table as markdown, the notes, and links to each method's report."""
    header = ["", *frame.columns]
    lines = ["# Methods side by side", "",
             "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for name, row in frame.iterrows():
        cells = [str(v).replace("|", "\\|") for v in row]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines.append("")
    lines += [f"- {note}" for note in notes]
    for method, target in (links or {}).items():
        lines.append(f"- [{method}: report]({target})")
    return "\n".join(lines).rstrip() + "\n"
