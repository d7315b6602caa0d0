"""A fitted coefficient table in Mach: CSV, JSBSim aerodynamics fragment and figure.

A fit with the airframe's ``[tables]`` (:class:`aeroid.model.MachTables`) returns the
tables' parameters (``result.names``: ``Cx@M1.4`` ...) with their standard errors;
:func:`fitted_tables` reads them back into one table per coefficient, and

- :func:`tables_csv`: ``coefficient, mach, value, stderr, low95, high95[, floor]`` rows;
- :func:`jsbsim_fragment`: one ``<function name="aero/coefficient/NAME_mach">`` per
  table, its ``<table>`` indexed by ``velocities/mach`` (JSBSim interpolates linearly
  between the rows and holds the end values beyond them: the model's tables);
- :func:`tables_figure`: each coefficient against Mach with its 95 % intervals;
- :func:`write_tables_report`: the report of such a fit (``aeroid estimate --report``):
  the three files above and a page with the points, the constants and the fit check.
  The figures of the model against the data are not drawn for tables:
  :meth:`aeroid.estimation.EstimationResult.predict` integrates constant coefficients.
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape

import numpy as np
from matplotlib.figure import Figure

from aeroid.errors import EstimatorError
from aeroid.model import LABELS
from aeroid.model import tables as mach_tables
from aeroid.report._files import write_figure_atomic, write_text_atomic
from aeroid.report._html import html_page

POINT_SEPARATOR = mach_tables.POINT_SEPARATOR

#: Half-width of the plotted and written intervals in standard errors (95 %, Gaussian).
Z95 = 1.96
#: Significant digits of the written numbers (more than any fit resolves).
DIGITS = 10


@dataclass(frozen=True)
class FittedTable:
    """One coefficient's fitted table: knots [Mach], values, standard errors (and floor)."""

    name: str
    mach: np.ndarray
    value: np.ndarray
    stderr: np.ndarray
    floor: np.ndarray | None = None


def fitted_tables(names: Sequence[str], theta: np.ndarray, stderr: np.ndarray | None,
                  floor: np.ndarray | None = None) -> list[FittedTable]:
    """Return the tables among a result's parameters (``Cx@M1.4`` names), in their order.

    Parameters
    ----------
    names, theta, stderr
        A result's ``names``, ``theta`` and ``stderr`` (NaN standard errors without one).
    floor : ndarray, optional
        The Cramér-Rao floor of each parameter (same order).

    Raises
    ------
    EstimatorError
        When no name is a table point (a fit without ``[tables]``).
    """
    theta = np.asarray(theta, dtype=float)
    stderr = np.full(theta.shape, np.nan) if stderr is None else np.asarray(stderr, float)
    groups: dict[str, list[int]] = {}
    for i, name in enumerate(names):
        if POINT_SEPARATOR in name:
            groups.setdefault(name.split(POINT_SEPARATOR)[0], []).append(i)
    if not groups:
        raise EstimatorError("tables: the result has no table points (names like Cx@M1.4); "
                             "fit a flight whose airframe has [tables]")
    out = []
    for coefficient, idx in groups.items():
        mach = np.array([float(names[i].split(POINT_SEPARATOR)[1]) for i in idx])
        out.append(FittedTable(coefficient, mach, theta[idx], stderr[idx],
                               None if floor is None else np.asarray(floor, float)[idx]))
    return out


def tables_csv(tables: Sequence[FittedTable]) -> str:
    """Return the tables as CSV text, one row per table point (module docstring)."""
    floor = any(t.floor is not None for t in tables)
    buf = io.StringIO()
    buf.write("coefficient,mach,value,stderr,low95,high95" + (",floor" if floor else "") + "\n")
    for t in tables:
        for j in range(t.mach.size):
            row = [t.name, f"{t.mach[j]:g}"] + [
                f"{v:.{DIGITS}g}" for v in (t.value[j], t.stderr[j],
                                            t.value[j] - Z95 * t.stderr[j],
                                            t.value[j] + Z95 * t.stderr[j])]
            if floor:
                row.append("" if t.floor is None else f"{t.floor[j]:.{DIGITS}g}")
            buf.write(",".join(row) + "\n")
    return buf.getvalue()


def jsbsim_fragment(tables: Sequence[FittedTable], source: str = "aeroid") -> str:
    """Return a JSBSim ``<aerodynamics>`` fragment: one ``<function>`` per table.

    ``<function name="aero/coefficient/Cx_mach">`` holds a one-dimensional ``<table>``
    whose ``independentVar`` is ``velocities/mach``; the function's value is the
    coefficient (dimensionless), to be multiplied into a force or moment by the
    aircraft's own ``<axis>`` functions. ``source`` goes into each ``<description>``.
    """
    lines = [f"<!-- coefficient tables in Mach fitted by {escape(source)}: linear between "
             "the rows, end values held beyond them -->"]
    for t in tables:
        lines += [f'<function name="aero/coefficient/{t.name}_mach">',
                  f"  <description>{escape(t.name)} against Mach ({escape(source)})"
                  "</description>",
                  "  <table>",
                  '    <independentVar lookup="row">velocities/mach</independentVar>',
                  "    <tableData>"]
        lines += [f"      {m:g}  {v:.{DIGITS}g}" for m, v in zip(t.mach, t.value, strict=True)]
        lines += ["    </tableData>", "  </table>", "</function>"]
    return "\n".join(lines) + "\n"


def tables_figure(tables: Sequence[FittedTable],
                  truth: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None) -> Figure:
    """Each coefficient against Mach: the fitted points with their 95 % intervals.

    ``truth``: optional ``{name: (mach, value)}`` drawn as a line (a simulated flight's
    true tables). One panel per coefficient; axes labelled with the coefficient and Mach.
    """
    fig = Figure(figsize=(5.0 * len(tables), 4.0))
    axes = fig.subplots(1, len(tables), squeeze=False)[0]
    for ax, t in zip(axes, tables, strict=True):
        order = np.argsort(t.mach)
        ax.errorbar(t.mach[order], t.value[order], yerr=Z95 * t.stderr[order], fmt="o-",
                    capsize=3, label="fit, 95 % interval")
        if truth and t.name in truth:
            mach, value = truth[t.name]
            ax.plot(mach, value, "k--", label="truth")
        ax.set_xlabel("Mach")
        ax.set_ylabel(LABELS.get(t.name, t.name))
        ax.set_title(f"{t.name} against Mach")
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


#: Files of :func:`write_tables_report` beside the report page.
TABLE_FILES = {"csv": "tables.csv", "jsbsim": "tables_jsbsim.xml", "figure": "tables.png"}
#: Dots per inch of the figure (the reports' own).
DPI = 110


def has_tables(names: Sequence[str]) -> bool:
    """Whether a result's names hold table points (``Cx@M1.4``)."""
    return any(POINT_SEPARATOR in name for name in names)


def write_tables_report(result: Any, flight: Any, folder: Path, name: str, *,
                        notes: Sequence[str] = (), fmt: str = "md",
                        sections: Sequence[str] = ()) -> Path:
    """Write the report of a fit with coefficient tables into ``folder``; return its page.

    ``result``: an :class:`aeroid.estimation.EstimationResult` whose names hold table
    points; ``name``: the page's file name (``report.md`` or ``report.html``). Writes
    :data:`TABLE_FILES` (CSV, JSBSim fragment, figure) and the page; ``sections``:
    markdown lines added after the fit check (the drag against a reference curve).
    """
    given = result.info.get("table_floor") or {}  # name -> floor (the fits' info)
    floor = (np.array([given.get(n, np.nan) for n in result.names]) if given else None)
    tables = fitted_tables(result.names, result.theta, result.stderr, floor)
    write_text_atomic(folder / TABLE_FILES["csv"], tables_csv(tables))
    write_text_atomic(folder / TABLE_FILES["jsbsim"],
                      jsbsim_fragment(tables, f"aeroid {result.estimator}"))
    write_figure_atomic(tables_figure(tables), folder / TABLE_FILES["figure"], DPI)
    source = flight.metadata.get("source", "flight")
    status = "ok" if result.success else "FAILED"
    lines = [f"# {result.estimator} on {source}: coefficient tables in Mach", "",
             f"**{status}**" + (f": {result.message}" if result.message else ""), "",
             f"{flight.n_samples} samples, t = {flight.t[0]:g} .. {flight.t[-1]:g} s.", "",
             "## Warnings and notes", ""]
    found = [f"- warning: {w}" for w in result.warnings] + [f"- {n}" for n in notes]
    found.append("- the figures of the model against the data are not drawn for tables "
                 "(the prediction integrates constant coefficients)")
    lines += found + ["", "## Tables", "", f"![tables]({TABLE_FILES['figure']})", "",
                      "| coefficient | Mach | estimate | std err | 95 % interval |",
                      "|---|---|---|---|---|"]
    for t in tables:
        lines += [f"| {t.name} | {m:g} | {v:.6g} | {s:.3g} | {v - Z95 * s:.6g} .. "
                  f"{v + Z95 * s:.6g} |"
                  for m, v, s in zip(t.mach, t.value, t.stderr, strict=True)]
    stderr = (np.full(len(result.names), np.nan) if result.stderr is None
              else np.asarray(result.stderr, dtype=float))
    lines += ["", "## Constant coefficients", "", "| coefficient | estimate | std err |",
              "|---|---|---|"]
    lines += [f"| {n} | {v:.6g} | {s:.3g} |"
              for n, v, s in zip(result.names, result.theta, stderr, strict=True)
              if POINT_SEPARATOR not in n]
    check = result.info.get("fit_check")
    lines += ["", "## Fit check", ""]
    if isinstance(check, Mapping) and check:
        lines += ["| channel | residual RMS / noise |", "|---|---|"]
        lines += [f"| {c} | {r:.3g} |" for c, r in check["ratio"].items()]
    else:
        lines += ["The method reports no residuals: no fit check."]
    lines += ["", *sections]
    lines += ["", f"Files: `{TABLE_FILES['csv']}` (every point, its standard error and 95 % "
              f"interval), `{TABLE_FILES['jsbsim']}` (a JSBSim aerodynamics fragment: "
              "one `<function>` per table, indexed by `velocities/mach`).", ""]
    text = "\n".join(lines)
    if fmt == "html":
        text = html_page(text, f"{result.estimator} on {source}")
    return write_text_atomic(folder / name, text)


__all__ = ["DIGITS", "TABLE_FILES", "Z95", "FittedTable", "fitted_tables", "has_tables",
           "jsbsim_fragment", "tables_csv", "tables_figure", "write_tables_report"]
