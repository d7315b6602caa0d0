"""Held and prior coefficients beside coefficient tables (:func:`table_holds`).

With ``[tables]`` a fit estimates the tables' parameters
(:meth:`aeroid.model.MachTables.parameter_names`: the constants, and each tabled
coefficient's points ``Cx@M1.4``), not the nine coefficients. A
:class:`~aeroid.estimation.CoefficientSpec` names them so:

* a **constant** (a coefficient that is not tabled) by its name: ``--hold Czd=0``,
  ``--prior Cma=-33:3``;
* a **table point** by its parameter name: ``--hold Cx@M1.4=-0.98``,
  ``--prior Cx@M1.4=-0.98:0.05`` (the knot matched by its value: ``Cx@M1.40`` is
  ``Cx@M1.4``); a point of a table in the total angle of attack the same way,
  ``--hold Cma@A1.2deg=-33.8`` (the knot matched in degrees: ``Cma@A1.20deg``);
* a **whole table** by the coefficient's name: the same hold or the same independent
  prior on each of its points (``--prior Cx=-1.0:0.1`` is ``N(-1.0, 0.1^2)`` on every
  ``Cx@M...``; a hold makes the table flat at that value). A passive fin's ``Czd``,
  ``Cmd`` held at zero reach their tables' points that way.

A point named both by its own name and by its table's (``Cx`` and ``Cx@M1.4``), a point
of no table of the flight (or of a Mach table named as an angle point, or the reverse),
and every parameter held are one-line errors. Several windows share one table
(:func:`windows_table_spec`: knots given as a count are chosen over all the windows), so
their holds name the shared points (:func:`fit_tables`).
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

import numpy as np

from aeroid.errors import EstimatorError
from aeroid.estimation._holds import (
    CoefficientSpec,
    HeldIndexes,
    describe_holds,
    holds_json,
)
from aeroid.flights import Flight, Windows, flight_mach_tables
from aeroid.model import MachTables, TableSpec, tables

__all__ = ["TableHolds", "fit_tables", "table_holds", "windows_table_spec"]

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
            bases.setdefault(tables.split_point(n)[0], []).append(n)
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


def _is_point(name: str) -> bool:
    """Whether ``name`` is a table point (``Cx@M1.4``, ``Cma@A4deg``), not a coefficient."""
    return tables.POINT_SEPARATOR in name or tables.ANGLE_SEPARATOR in name


def _point(name: str, mach_tables: MachTables) -> str:
    """Return the parameter name of table point ``name`` (``Cx@M1.4`` or ``Cma@A4deg``)
    in ``mach_tables``."""
    base, kind, knot = tables.split_point(name)
    tabled = (*mach_tables.names, *mach_tables.angle_names)
    if base not in tabled:
        raise EstimatorError(f"{name}: {base} is not a table of this flight (tables: "
                             f"{', '.join(tabled) or 'none'}); name it {base}")
    by_angle = base in mach_tables.angle_names
    if by_angle != (kind == "alpha"):
        table, form = (("the total angle of attack", f"{base}@A<angle>deg") if by_angle
                       else ("Mach", f"{base}@M<Mach>"))
        raise EstimatorError(f"{name}: {base} is a table in {table} on this flight; name its "
                             f"points {form} (its points: "
                             f"{', '.join(mach_tables.point_names(base))})")
    knots = mach_tables.knots_of(base)
    unit = math.degrees if by_angle else float  # angle knots are matched in degrees
    for k, point in zip(knots, mach_tables.point_names(base), strict=True):
        if math.isclose(unit(k), unit(knot), rel_tol=0.0, abs_tol=KNOT_MATCH):
            return point
    raise EstimatorError(f"{name}: no such knot in {base}'s table (its points: "
                         f"{', '.join(mach_tables.point_names(base))})")


def table_holds(spec: CoefficientSpec, mach_tables: MachTables) -> TableHolds:
    """Return ``spec`` over the parameters of ``mach_tables`` (module docstring).

    Mach tables and tables in the total angle of attack alike: an angle point is named
    ``Cma@A4deg`` (its knot matched in degrees), a whole angle table ``Cma``.

    Raises
    ------
    EstimatorError
        One line for a point of no table of the flight or no knot of its table, a point
        named both by itself and by its table, or every parameter held.
    """
    names = mach_tables.parameter_names()
    held: dict[str, float] = {}
    priors: dict[str, tuple[float, float]] = {}
    sources: dict[str, str] = {}
    origin: dict[str, str] = {}
    for kind, table in (("hold", spec.held), ("prior", spec.priors)):
        for given, value in table.items():
            if _is_point(given):
                targets = [_point(given, mach_tables)]
            elif given in (*mach_tables.names, *mach_tables.angle_names):
                targets = list(mach_tables.point_names(given))
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


def windows_table_spec(windows: Windows) -> tuple[TableSpec, np.ndarray, np.ndarray]:
    """Return the windows' ``[tables]`` with every knot resolved over all of them, and
    every window's Mach numbers and total angles of attack [rad] (concatenated).

    Knots given as a count are chosen over the windows' Mach (each window at its own
    speed of sound) or total angle together; angle knots stay in degrees, as the file
    gives them. The windows' ``[tables]`` are the first window's (checked equal by the
    fits: :func:`baselines._tables_windows.shared_tables`).
    """
    spec = windows.airframe.tables
    if spec is None:
        raise EstimatorError("windows: the airframe has no [tables]")
    machs = [tables.mach_number(*f.states()[:, :3].T, spec.speed_of_sound(f.airframe.altitude_m))
             for f in windows]
    every = np.concatenate(machs)
    knots = tuple((name, tables.choose_knots(every, k) if isinstance(k, int) else k)
                  for name, k in spec.knots)
    alpha = np.concatenate([tables.total_angle(*f.states()[:, :3].T) for f in windows])
    angles = tuple((name, tuple(float(np.degrees(x)) for x in tables.choose_angle_knots(alpha, k))
                    if isinstance(k, int) else k) for name, k in spec.angle_knots)
    return TableSpec(knots, spec.temperature_k, angles), every, alpha


def fit_tables(flight: Flight | Windows) -> MachTables:
    """Return the tables a fit of ``flight`` estimates: a flight's own (counted knots from
    its Mach range), or the tables several windows share (:func:`windows_table_spec`)."""
    if isinstance(flight, Windows):
        spec, _, _ = windows_table_spec(flight)
        return spec.resolve(flight.airframe.altitude_m)
    return flight_mach_tables(flight)  # Mach per sample from a logged air temperature
