"""Reading a suite log's air group: the probe's position and its pressures' checks.

The leaf of :mod:`._suite_air` that :mod:`._suite_log` calls on reading (module docstring
there): ``probe_position_m = [x, y, z]`` (body axes from the c.g. [m]) and the
pressures checked as a single-file log's (:func:`aeroid.flights._pitot.pitot_findings`),
a static pressure without a total one refused.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from aeroid.errors import FlightError
from aeroid.flights._pitot import STATIC_PRESSURE, TOTAL_PRESSURE, pitot_findings

__all__ = ["AIR_KEYS", "check_air_group", "probe_position", "read_probe_position"]

#: Keys only the ``air`` group takes.
AIR_KEYS = ("probe_position_m",)


def probe_position(value: Any, where: str, error: type[Exception]) -> tuple[float, float, float]:
    """``value`` as a probe position ``(x, y, z)`` [m], or ``error`` in one line naming
    ``where``."""
    try:
        r = np.asarray(value, dtype=float).reshape(-1)
        if r.size != 3 or not np.all(np.isfinite(r)) or isinstance(value, str | bytes):
            raise ValueError
    except (TypeError, ValueError):
        raise error(f"{where} must be [x, y, z]: three finite numbers, body axes from the "
                    f"c.g. [m], got {value!r}") from None
    return (float(r[0]), float(r[1]), float(r[2]))


def read_probe_position(table: Mapping[str, Any], where: str
                        ) -> tuple[float, float, float] | None:
    """The ``probe_position_m`` of an air group's table, or None (not stated)."""
    if "probe_position_m" not in table:
        return None
    return probe_position(table["probe_position_m"], f"{where}: probe_position_m", FlightError)


def check_air_group(channels: Mapping[str, np.ndarray], where: str) -> None:
    """Refuse, in one line, an air group's pressures a single-file log would refuse, and a
    static pressure without a total one (module docstring)."""
    if STATIC_PRESSURE in channels and TOTAL_PRESSURE not in channels:
        raise FlightError(f"{where}: {STATIC_PRESSURE!r} without {TOTAL_PRESSURE!r}: a probe's "
                          "static pressure alone is not air data (a barometer's goes in the "
                          "baro group as 'pressure')")
    problems = pitot_findings(dict(channels))
    if problems:
        raise FlightError(f"{where}: " + "; ".join(problems))
