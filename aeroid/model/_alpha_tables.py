"""Coefficient tables in the total angle of attack: the variable, its knots and names.

A coefficient may be a piecewise-linear table in the **total angle of attack**
``alpha_t = atan2(sqrt(v^2 + w^2), u)`` [rad], the angle between the body axis and the
velocity, instead of in Mach (:class:`aeroid.model.MachTables` holds both kinds; the hat
basis is :mod:`aeroid.model._table_basis`'s). Why the total angle and not the body alpha:
the airframe is axisymmetric and rolls, so its body ``alpha = atan(w/u)`` and ``beta``
swap and change sign every half turn while the flow round it does not; the model's
``M_Y = Q S D Cma alpha`` and ``M_Z = -Q S D Cma beta`` share one ``Cma``, which for a
body of revolution can depend on the angle's size only, ``alpha_t`` (a table in the body
alpha would give the pitch and yaw planes different slopes at the same incidence, and
tie the coefficient to the roll angle).

Knots are given in degrees at the edges (the airframe file's ``{alpha_deg = [...]}``, the
parameter names ``Cma@A4deg``) and are radians inside. ``sqrt(v^2 + w^2)`` has no
derivative at ``v = w = 0`` (a flight's first sample is often there), so the square root
takes :data:`CROSSFLOW_FLOOR_MPS` squared added: ``alpha_t`` at zero incidence is then
``1e-6 / V`` rad (1e-9 rad at 700 m/s), far below any knot spacing, and the output-error
graph's derivatives stay finite.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from aeroid.errors import AirframeError
from aeroid.model import _equations as eq

Scalar = Any  # a float, an ndarray or a CasADi symbol: element-wise

#: Separator and unit of an angle table point's name: ``Cma@A4deg`` is Cma at 4 deg.
ANGLE_SEPARATOR = "@A"
ANGLE_UNIT = "deg"
#: Key of an angle table in the airframe file's ``[tables]`` and the scenario's
#: ``[coefficients]``: ``Cma = {alpha_deg = [0, 2, 4]}``.
ANGLE_KEY = "alpha_deg"
#: Range of the knots [deg]: the total angle is 0..180 deg; beyond 90 the airframe flies
#: backwards (a knot there is a unit mistake, radians given as degrees are inside).
ANGLE_KNOT_RANGE_DEG = (0.0, 90.0)
#: Closest knots [deg] (their names, printed with 6 digits, must differ; a hat narrower
#: than this is steeper than a record informs).
MIN_ANGLE_SPACING_DEG = 0.01
#: Knots chosen from the data are rounded outward to this step [deg].
ANGLE_ROUNDING_DEG = 0.1
#: Cross-flow speed added in quadrature [m/s] so that ``alpha_t`` is differentiable at
#: zero incidence (module docstring); 1e-6 m/s moves ``alpha_t`` by < 1e-8 rad.
CROSSFLOW_FLOOR_MPS = 1e-6


def total_angle(u: Scalar, v: Scalar, w: Scalar) -> Scalar:
    """Return the total angle of attack ``atan2(sqrt(v^2 + w^2), u)`` [rad] (element-wise).

    Body velocities [m/s]; see the module docstring for the floor on the cross-flow.
    """
    crossflow = np.sqrt(v * v + w * w + CROSSFLOW_FLOOR_MPS * CROSSFLOW_FLOOR_MPS)
    return eq.atan2(crossflow, u)


def angle_point_name(name: str, knot_rad: float) -> str:
    """Return the parameter name of an angle table point: ``Cma@A4deg``."""
    return f"{name}{ANGLE_SEPARATOR}{math.degrees(knot_rad):g}{ANGLE_UNIT}"


def split_point(name: str) -> tuple[str, str, float]:
    """Return ``(coefficient, variable, knot)`` of a parameter name.

    ``Cx@M1.4`` -> ``("Cx", "mach", 1.4)``; ``Cma@A4deg`` -> ``("Cma", "alpha", 0.0698...)``
    (radians); a constant ``Cza`` -> ``("Cza", "", nan)``.
    """
    if ANGLE_SEPARATOR in name and name.endswith(ANGLE_UNIT):
        base, _, knot = name[: -len(ANGLE_UNIT)].partition(ANGLE_SEPARATOR)
        return base, "alpha", math.radians(float(knot))
    base, sep, knot = name.partition("@M")
    return (base, "mach", float(knot)) if sep else (base, "", math.nan)


def check_angle_knots(knots_deg: Any, where: str) -> tuple[float, ...]:
    """Return knots given in degrees as increasing radians, or raise one line."""
    if isinstance(knots_deg, str | bytes) or not isinstance(knots_deg, list | tuple
                                                                       | np.ndarray):
        raise AirframeError(f"{where}: {ANGLE_KEY} must be a list of angles [deg], "
                            f"got {knots_deg!r}")
    if any(isinstance(k, bool) for k in knots_deg):
        raise AirframeError(f"{where}: {ANGLE_KEY} must be numbers, got {list(knots_deg)!r}")
    try:
        values = tuple(float(k) for k in knots_deg)
    except (TypeError, ValueError):
        raise AirframeError(f"{where}: {ANGLE_KEY} must be numbers, "
                            f"got {list(knots_deg)!r}") from None
    if not values:
        raise AirframeError(f"{where}: no knots (give at least one angle [deg])")
    low, high = ANGLE_KNOT_RANGE_DEG
    if not all(math.isfinite(k) and low <= k <= high for k in values):
        raise AirframeError(f"{where}: {ANGLE_KEY} knots must be total angles of attack in "
                            f"[{low:g}, {high:g}] deg, got {list(values)}")
    if np.any(np.diff(values) < MIN_ANGLE_SPACING_DEG):
        raise AirframeError(f"{where}: {ANGLE_KEY} knots must increase by at least "
                            f"{MIN_ANGLE_SPACING_DEG:g} deg, got {list(values)}")
    names = [f"{k:g}" for k in values]
    if len(set(names)) != len(names):
        raise AirframeError(f"{where}: {ANGLE_KEY} knots {names} have the same name")
    return tuple(math.radians(k) for k in values)


def choose_angle_knots(angle_rad: np.ndarray, count: int) -> tuple[float, ...]:
    """Return ``count`` knots [rad] evenly spaced over the range of ``angle_rad``.

    The end knots are the data's smallest and largest total angle rounded outward to
    :data:`ANGLE_ROUNDING_DEG`, so no sample lies beyond the table.
    """
    if int(count) != count or count < 1:
        raise AirframeError(f"tables: knot count must be a positive integer, got {count!r}")
    deg = np.degrees(np.asarray(angle_rad, dtype=float))
    deg = deg[np.isfinite(deg)]
    if deg.size == 0:
        raise AirframeError("tables: no finite angle of attack in the data to choose knots")
    step = ANGLE_ROUNDING_DEG
    low = max(0.0, math.floor(float(deg.min()) / step + 1e-6) * step)
    high = math.ceil(float(deg.max()) / step - 1e-6) * step
    if count == 1:
        return (math.radians(round(0.5 * (low + high), 2)),)
    if high - low < MIN_ANGLE_SPACING_DEG * (count - 1):
        raise AirframeError(f"tables: the data span the total angle of attack "
                            f"{deg.min():.3g}-{deg.max():.3g} deg, too narrow for {count} knots")
    return tuple(math.radians(round(float(k), 2)) for k in np.linspace(low, high, int(count)))


__all__ = ["ANGLE_KEY", "ANGLE_KNOT_RANGE_DEG", "ANGLE_SEPARATOR", "CROSSFLOW_FLOOR_MPS",
           "angle_point_name", "check_angle_knots", "choose_angle_knots", "split_point",
           "total_angle"]


def check_angle_knots_rad(knots_rad: Any, where: str) -> tuple[float, ...]:
    """Return knots given in radians as floats after :func:`check_angle_knots`'s checks."""
    if isinstance(knots_rad, str | bytes) or not isinstance(knots_rad, list | tuple
                                                                       | np.ndarray):
        raise AirframeError(f"{where}: angle knots must be a list of radians, "
                            f"got {knots_rad!r}")
    check_angle_knots([math.degrees(float(k)) for k in knots_rad], where)
    return tuple(float(k) for k in knots_rad)


__all__ += ["check_angle_knots_rad"]
