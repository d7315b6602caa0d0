"""A fitted coefficient table in Mach: CSV, JSBSim aerodynamics fragment and figure.

A fit with the airframe's ``[tables]`` (:class:`aeroid.model.MachTables`) returns the
tables' parameters (``result.names``: ``Cx@M1.4`` ...) with their standard errors;
:func:`fitted_tables` reads them back into one table per coefficient, and

- :func:`tables_csv`: ``coefficient, mach, value, stderr, low95, high95[, floor]`` rows;
- :func:`jsbsim_fragment`: one ``<function name="aero/coefficient/NAME_mach">`` per
  table, its ``<table>`` indexed by ``velocities/mach`` (JSBSim interpolates linearly
  between the rows and holds the end values beyond them: the model's tables);
- :func:`tables_figure`: each coefficient against Mach with its 95 % intervals.
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from xml.sax.saxutils import escape

import numpy as np
from matplotlib.figure import Figure

from aeroid.errors import EstimatorError
from aeroid.model import LABELS
from aeroid.model import tables as mach_tables

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


__all__ = ["DIGITS", "Z95", "FittedTable", "fitted_tables", "jsbsim_fragment", "tables_csv",
           "tables_figure"]
