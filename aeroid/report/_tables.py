"""A fitted coefficient table in Mach (or in the total angle of attack): CSV, JSBSim
aerodynamics fragment and figure.

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

A table in the total angle of attack (points ``Cma@A4deg``) has its knots in degrees
(``FittedTable.variable == "alpha"``): the CSV gives them in an ``alpha_deg`` column (the
``mach`` cell empty), the JSBSim fragment computes the total angle
``atan2(sqrt((sin alpha cos beta)^2 + sin^2 beta), cos alpha cos beta)`` from
``aero/alpha-rad`` and ``aero/beta-rad`` (``aero/function/alpha_total_rad``: JSBSim's
alpha is ``atan2(w, u)`` and beta ``asin(v / V)``, so this is
``atan2(sqrt(v^2 + w^2), u)``, the model's) and indexes ``aero/coefficient/NAME_alpha``
by it, knots in radians; the figure's axis is the angle in degrees.
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
ANGLE_SEPARATOR = mach_tables.ANGLE_SEPARATOR
#: JSBSim property of the total angle of attack [rad] the angle tables are indexed by.
ALPHA_TOTAL_PROPERTY = "aero/function/alpha_total_rad"

#: Half-width of the plotted and written intervals in standard errors (95 %, Gaussian).
Z95 = 1.96
#: Significant digits of the written numbers (more than any fit resolves).
DIGITS = 10


@dataclass(frozen=True)
class FittedTable:
    """One coefficient's fitted table: knots [Mach], values, standard errors (and floor).

    ``variable`` is ``"alpha"`` for a table in the total angle of attack: its knots
    (the field ``mach``) are then in degrees.
    """

    name: str
    mach: np.ndarray
    value: np.ndarray
    stderr: np.ndarray
    floor: np.ndarray | None = None
    variable: str = "mach"


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
    variable: dict[str, str] = {}
    for i, name in enumerate(names):
        base, kind, _ = mach_tables.split_point(name)
        if kind:
            groups.setdefault(base, []).append(i)
            variable[base] = kind
    if not groups:
        raise EstimatorError("tables: the result has no table points (names like Cx@M1.4); "
                             "fit a flight whose airframe has [tables]")
    out = []
    for coefficient, idx in groups.items():
        knots = np.array([mach_tables.split_point(names[i])[2] for i in idx])
        if variable[coefficient] == "alpha":
            knots = np.degrees(knots)
        out.append(FittedTable(coefficient, knots, theta[idx], stderr[idx],
                               None if floor is None else np.asarray(floor, float)[idx],
                               variable[coefficient]))
    return out


def tables_csv(tables: Sequence[FittedTable]) -> str:
    """Return the tables as CSV text, one row per table point (module docstring)."""
    floor = any(t.floor is not None for t in tables)
    angles = any(t.variable == "alpha" for t in tables)
    buf = io.StringIO()
    buf.write("coefficient,mach" + (",alpha_deg" if angles else "")
              + ",value,stderr,low95,high95" + (",floor" if floor else "") + "\n")
    for t in tables:
        for j in range(t.mach.size):
            knot = [f"{t.mach[j]:g}"]
            if angles:
                knot = ["", knot[0]] if t.variable == "alpha" else [knot[0], ""]
            row = [t.name, *knot] + [
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
    what = ("in Mach and the total angle of attack" if any(t.variable == "alpha" for t in tables)
            else "in Mach")
    lines = [f"<!-- coefficient tables {what} fitted by {escape(source)}: linear between "
             "the rows, end values held beyond them -->"]
    if any(t.variable == "alpha" for t in tables):
        lines += _alpha_total_function()
    for t in tables:
        if t.variable == "alpha":
            lines += _alpha_table(t, source)
            continue
        lines += [f'<function name="aero/coefficient/{t.name}_mach">',
                  f"  <description>{escape(t.name)} against Mach ({escape(source)})"
                  "</description>",
                  "  <table>",
                  '    <independentVar lookup="row">velocities/mach</independentVar>',
                  "    <tableData>"]
        lines += [f"      {m:g}  {v:.{DIGITS}g}" for m, v in zip(t.mach, t.value, strict=True)]
        lines += ["    </tableData>", "  </table>", "</function>"]
    return "\n".join(lines) + "\n"


def _alpha_total_function() -> list[str]:
    """JSBSim's total angle of attack [rad] from its alpha and beta (module docstring)."""
    sa, ca = "<sin><p>aero/alpha-rad</p></sin>", "<cos><p>aero/alpha-rad</p></cos>"
    sb, cb = "<sin><p>aero/beta-rad</p></sin>", "<cos><p>aero/beta-rad</p></cos>"
    cross = (f"<sqrt><sum><pow><product>{sa}{cb}</product><v>2</v></pow>"
             f"<pow>{sb}<v>2</v></pow></sum></sqrt>")
    return [f'<function name="{ALPHA_TOTAL_PROPERTY}">',
            "  <description>total angle of attack atan2(sqrt(v^2 + w^2), u) [rad]"
            "</description>",
            f"  <atan2>{cross}<product>{ca}{cb}</product></atan2>",
            "</function>"]


def _alpha_table(t: FittedTable, source: str) -> list[str]:
    """One ``<function>`` of a table in the total angle of attack (knots in radians)."""
    rows = [f"      {np.radians(a):.{DIGITS + 6}g}  {v:.{DIGITS}g}"
            for a, v in zip(t.mach, t.value, strict=True)]
    return [f'<function name="aero/coefficient/{t.name}_alpha">',
            f"  <description>{escape(t.name)} against the total angle of attack "
            f"[rad] ({escape(source)})</description>",
            "  <table>",
            f'    <independentVar lookup="row">{ALPHA_TOTAL_PROPERTY}</independentVar>',
            "    <tableData>", *rows, "    </tableData>", "  </table>", "</function>"]


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
        what = "total angle of attack [deg]" if t.variable == "alpha" else "Mach"
        ax.set_xlabel(what)
        ax.set_ylabel(LABELS.get(t.name, t.name))
        ax.set_title(f"{t.name} against {what.split(' [')[0]}")
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


#: Files of :func:`write_tables_report` beside the report page.
TABLE_FILES = {"csv": "tables.csv", "jsbsim": "tables_jsbsim.xml", "figure": "tables.png"}
#: Dots per inch of the figure (the reports' own).
DPI = 110


def has_tables(names: Sequence[str]) -> bool:
    """Whether a result's names hold table points (``Cx@M1.4``)."""
    return any(mach_tables.split_point(name)[1] for name in names)


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
    knot_header = ("Mach or angle" if any(t.variable == "alpha" for t in tables)
                   else "Mach")
    status = "ok" if result.success else "FAILED"
    lines = [f"# {result.estimator} on {source}: coefficient tables in Mach", "",
             f"**{status}**" + (f": {result.message}" if result.message else ""), "",
             f"{flight.n_samples} samples, t = {flight.t[0]:g} .. {flight.t[-1]:g} s.", "",
             "## Warnings and notes", ""]
    found = [f"- warning: {w}" for w in result.warnings] + [f"- {n}" for n in notes]
    found.append("- the figures of the model against the data are not drawn for tables "
                 "(the prediction integrates constant coefficients)")
    lines += found + ["", "## Tables", "", f"![tables]({TABLE_FILES['figure']})", "",
                      f"| coefficient | {knot_header} | estimate | std err | 95 % interval |",
                      "|---|---|---|---|---|"]
    for t in tables:
        unit = " deg" if t.variable == "alpha" else ""
        lines += [f"| {t.name} | {m:g}{unit} | {v:.6g} | {s:.3g} | {v - Z95 * s:.6g} .. "
                  f"{v + Z95 * s:.6g} |"
                  for m, v, s in zip(t.mach, t.value, t.stderr, strict=True)]
    stderr = (np.full(len(result.names), np.nan) if result.stderr is None
              else np.asarray(result.stderr, dtype=float))
    lines += ["", "## Constant coefficients", "", "| coefficient | estimate | std err |",
              "|---|---|---|"]
    lines += [f"| {n} | {v:.6g} | {s:.3g} |"
              for n, v, s in zip(result.names, result.theta, stderr, strict=True)
              if not mach_tables.split_point(n)[1]]
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
