"""Held and prior coefficients beside coefficient tables in Mach (:func:`table_holds`).

With ``[tables]`` a fit estimates the tables' parameters
(:meth:`aeroid.model.MachTables.parameter_names`: the constants, and each tabled
coefficient's points ``Cx@M1.4``), not the nine coefficients. A
:class:`~aeroid.estimation.CoefficientSpec` names them so:

* a **constant** (a coefficient that is not tabled) by its name: ``--hold Czd=0``,
  ``--prior Cma=-33:3``;
* a **table point** by its parameter name: ``--hold Cx@M1.4=-0.98``,
  ``--prior Cx@M1.4=-0.98:0.05`` (the knot matched by its value: ``Cx@M1.40`` is
  ``Cx@M1.4``);
* a **whole table** by the coefficient's name: the same hold or the same independent
  prior on each of its points (``--prior Cx=-1.0:0.1`` is ``N(-1.0, 0.1^2)`` on every
  ``Cx@M...``; a hold makes the table flat at that value). A passive fin's ``Czd``,
  ``Cmd`` held at zero reach their tables' points that way.

A point named both by its own name and by its table's (``Cx`` and ``Cx@M1.4``), a point
of no table of the flight, and every parameter held are one-line errors.
:class:`TableHolds` is the result: the same interface as ``CoefficientSpec`` (``held``,
``priors``, ``free_index``, ``held_index``, ``held_values``, ``prior_mean_sd``,
``prior_information``...) over the tables' parameter vector, so the output-error and
equation-error fits take it as they take a spec over the nine coefficients.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from aeroid.errors import EstimatorError
from aeroid.estimation._holds import (
    CoefficientSpec,
    HeldIndexes,
    describe_holds,
    holds_json,
)
from aeroid.model import MachTables, tables

__all__ = ["TableHolds", "table_holds"]

#: A point named ``Cx@M1.4`` matches the knot 1.4 when they differ by at most this much
#: (knots are written with ``%g``: six significant digits).
KNOT_MATCH = 1e-6


@dataclass(frozen=True)
class TableHolds(HeldIndexes):
    """Held and prior parameters of a table fit (module docstring).

    Attributes
    ----------
    names : tuple of str
        The tables' parameter names, in parameter-vector order.
    held : mapping of str -> float
        Parameter name -> the value it is held at.
    priors : mapping of str -> (float, float)
        Parameter name -> ``(mean, sd)`` of its Gaussian prior.
    sources : mapping of str -> str
        Parameter name -> where it was declared (the coefficient's or the point's
        declaration).
    """

    names: tuple[str, ...]
    held: Mapping[str, float] = field(default_factory=dict)
    priors: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    sources: Mapping[str, str] = field(default_factory=dict)

    def parameter_order(self) -> tuple[str, ...]:
        """The tables' parameters, :attr:`names`."""
        return tuple(self.names)

    @property
    def empty(self) -> bool:
        """True when every parameter is free without a prior."""
        return not self.held and not self.priors

    def covers(self) -> dict[str, str]:
        """Coefficient (or parameter) name -> "held"/"prior" for what the spec determines:
        each parameter, and a tabled coefficient when every one of its points is."""
        out = {n: "held" for n in self.held}
        out.update({n: "prior" for n in self.priors})
        bases: dict[str, list[str]] = {}
        for n in self.names:
            bases.setdefault(n.partition(tables.POINT_SEPARATOR)[0], []).append(n)
        for base, points in bases.items():
            if all(p in out for p in points):
                out.setdefault(base, out[points[0]])
        return out

    def describe(self) -> str:
        """Return one line: what is held and what has a prior (empty when all are free)."""
        return describe_holds(self)

    def to_json(self) -> dict[str, Any]:
        """Return ``{"held": {name: value}, "priors": {name: {"mean", "sd"}}}``."""
        return holds_json(self)


def _point(name: str, mach_tables: MachTables) -> str:
    """Return the parameter name of table point ``name`` (``Cx@M1.4``) in ``mach_tables``."""
    base, _, knot = name.partition(tables.POINT_SEPARATOR)
    if base not in mach_tables.names:
        raise EstimatorError(f"{name}: {base} is not a table of this flight (tables: "
                             f"{', '.join(mach_tables.names) or 'none'}); name it {base}")
    knots = mach_tables.knots_of(base)
    for k in knots:
        if math.isclose(k, float(knot), rel_tol=0.0, abs_tol=KNOT_MATCH):
            return tables.point_name(base, k)
    raise EstimatorError(f"{name}: no such knot in {base}'s table (its points: "
                         f"{', '.join(tables.point_name(base, k) for k in knots)})")


def table_holds(spec: CoefficientSpec, mach_tables: MachTables) -> TableHolds:
    """Return ``spec`` over the parameters of ``mach_tables`` (module docstring).

    Raises
    ------
    EstimatorError
        One line for a point of no table of the flight or no knot of its table, a point
        named both by itself and by its table, or every parameter held.
    """
    if mach_tables.angle_knots:  # issue 23: angle tables without holds and priors yet
        raise EstimatorError(f"{', '.join(mach_tables.angle_names)}: tables in the angle of "
                             f"attack cannot be fitted with held coefficients or priors yet "
                             f"({spec.describe()}); fit them free")
    names = mach_tables.parameter_names()
    held: dict[str, float] = {}
    priors: dict[str, tuple[float, float]] = {}
    sources: dict[str, str] = {}
    origin: dict[str, str] = {}
    for kind, table in (("hold", spec.held), ("prior", spec.priors)):
        for given, value in table.items():
            if tables.POINT_SEPARATOR in given:
                targets = [_point(given, mach_tables)]
            elif given in mach_tables.names:
                targets = [tables.point_name(given, k) for k in mach_tables.knots_of(given)]
            else:
                targets = [given]
            for target in targets:
                if target in origin:
                    raise EstimatorError(f"{target}: declared twice, as {origin[target]} and "
                                         f"as {given} ({kind}); name it once")
                origin[target] = given
                if kind == "hold":
                    held[target] = float(value)  # type: ignore[arg-type]
                else:
                    priors[target] = value  # type: ignore[assignment]
                where = spec.sources.get(given, "given")
                sources[target] = where if target == given else f"{where}, {given}"
    if len(held) == len(names):
        raise EstimatorError("every table parameter is held: nothing left to estimate")
    order = {n: i for i, n in enumerate(names)}
    return TableHolds(names, dict(sorted(held.items(), key=lambda kv: order[kv[0]])),
                      dict(sorted(priors.items(), key=lambda kv: order[kv[0]])), sources)
