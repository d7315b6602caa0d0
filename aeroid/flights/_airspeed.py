"""The airspeed channel checked: positive, plausible, and in the unit of ``u, v, w``.

An air-data probe's ``airspeed`` [m/s] is the air-relative speed; the inertial speed
``|u, v, w|`` differs from it by the wind along the path (5 m/s of 500 m/s: 1 %; a
gliding model's 10 m/s of 30 m/s: a third). A unit mistake is a factor: knots 0.514,
ft/s 0.305, km/h 0.278. So the median ratio of airspeed to inertial speed beyond
:data:`UNIT_FACTOR` either way is an error naming the unit that explains it; within it,
the channel is taken as it is (the wind is what estimators take from the difference).
"""

from __future__ import annotations

import math

import numpy as np

#: Median airspeed / |u, v, w| beyond this factor either way is a unit error, not a
#: wind: a wind of half the flight speed is not a flight aeroid's models describe, and
#: the nearest unit mistake (knots read as m/s: 1.94) is beyond it.
UNIT_FACTOR = 1.5
#: Units an airspeed may have been logged in: (name, m/s per one of them).
OTHER_SPEED_UNITS: tuple[tuple[str, float], ...] = (
    ("knots", 1852.0 / 3600.0), ("ft/s", 0.3048), ("km/h", 1.0 / 3.6), ("mph", 0.44704))
#: Fastest airspeed [m/s] (the flight check's bound on |u, v, w|: Mach 10 at 10 km).
MAX_AIRSPEED_MPS = 3000.0


def airspeed_findings(finite: dict[str, np.ndarray]) -> list[str]:
    """Return one error line per problem of the ``airspeed`` channel in ``finite`` (none
    when the channel is absent or fine)."""
    v = finite.get("airspeed")
    if v is None or v.size == 0:
        return []
    bad = np.flatnonzero(~(v > 0))
    if bad.size:
        return [f"channel 'airspeed' must be positive [m/s], first non-positive at row "
                f"{int(bad[0])}"]
    high = np.flatnonzero(v > MAX_AIRSPEED_MPS)
    if high.size:
        return [f"channel 'airspeed' reaches {float(v[high[0]]):.4g} m/s at row "
                f"{int(high[0])}, above {MAX_AIRSPEED_MPS:g} m/s"]
    if not all(c in finite for c in ("u", "v", "w")):
        return []
    speed = np.sqrt(finite["u"] ** 2 + finite["v"] ** 2 + finite["w"] ** 2)
    if not np.all(speed > 0):
        return []  # the flight check says it
    ratio = float(np.median(v / speed))
    if abs(math.log(ratio)) <= math.log(UNIT_FACTOR):
        return []
    hint = next((f" (airspeed in {name}?)" for name, si in OTHER_SPEED_UNITS
                 if abs(math.log(ratio * si)) < math.log(1.15)), "")
    return [f"channel 'airspeed' is {ratio:.3g}x the inertial speed |u, v, w| (median), "
            f"beyond a wind's {UNIT_FACTOR:g}x{hint or ' (check the unit)'}"]


__all__ = ["MAX_AIRSPEED_MPS", "OTHER_SPEED_UNITS", "UNIT_FACTOR", "airspeed_findings"]
