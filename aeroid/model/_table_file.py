"""The airframe file's ``[tables]`` entries, read and checked (one-line errors; private).

:mod:`aeroid.model._tables` reads ``[tables]`` with these: an angle table's
``{alpha_deg = ...}`` and a given air temperature [K] (checked as every air temperature
is, :func:`aeroid.model.check_air_temperature`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from aeroid.errors import AirframeError
from aeroid.model import _alpha_tables as angle
from aeroid.model import _atmosphere as atmosphere


def given_temperature(value: Any, where: str) -> float:
    """Return a given air temperature [K] checked (one-line :class:`AirframeError`)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise AirframeError(f"{where} must be a number of kelvin, got {value!r}")
    try:
        return float(atmosphere.check_air_temperature(value, where))
    except ValueError as exc:
        raise AirframeError(str(exc)) from None


def angle_entry(value: Mapping[str, Any], where: str) -> tuple[float, ...] | int:
    """Read ``{alpha_deg = [...]}`` (knots [deg], checked) or ``{alpha_deg = count}``."""
    if set(value) != {angle.ANGLE_KEY}:
        raise AirframeError(f"{where}: a table in the angle of attack is "
                            f"{{{angle.ANGLE_KEY} = [deg, ...]}} or {{{angle.ANGLE_KEY} = "
                            f"count}}, got keys {sorted(value)}")
    knots = value[angle.ANGLE_KEY]
    if isinstance(knots, int) and not isinstance(knots, bool):
        if knots < 1:
            raise AirframeError(f"{where}: a knot count must be >= 1, got {knots}")
        return knots
    angle.check_angle_knots(knots, where)
    return tuple(float(k) for k in knots)
