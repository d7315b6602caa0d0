"""The per-sample input channels against plausible ranges, the airframe and the kinematics.

A per-sample ``mass``, ``thrust``, ``ix``, ``iy``, ``iz``, ``rho``, ``altitude`` or ``qbar``
replaces the airframe's constant in every estimator, so a wrong unit there gives
confident garbage: a mass in grams made every force coefficient 1000x off, a thrust of 0
where the airframe says 740 N put Cx 113 % off, an altitude in feet on a 5 km flight put
Cmd 374 % off, each with ``success`` true. Three comparisons, each one line:

* plausible ranges (:data:`RANGES`), naming the unit that would put the value inside;
* the airframe's own value (mass, thrust, inertias): beyond :data:`AIRFRAME_WARN_FACTOR`
  a warning naming both, beyond :data:`AIRFRAME_ERROR_FACTOR` an error (a unit, not a
  propellant burn);
* the kinematics: the altitude's change against the integral of the vertical speed
  ``u sin theta - (v sin phi + w cos phi) cos theta`` (the body velocity turned to the
  vertical by the attitude), through the same least-squares scale as the rate and angle
  checks of :mod:`aeroid.flights._checks` (3.28 for an altitude in feet).
"""

from __future__ import annotations

import math

import numpy as np

from aeroid.flights._channels import UNITS
from aeroid.model import AIRFRAME_LIMITS, Airframe

#: Plausible per-sample values [SI]; outside: an error. Mass: a 1 g dart to a 10,000 t
#: launch vehicle (Saturn V: 2,900 t); thrust: up to 100 MN (Saturn V: 35 MN, Starship:
#: 74 MN); inertias: 1e-9 kg m^2 (a dart) to 1e10 (Saturn V: about 1e9); density and
#: altitude: the airframe file's own limits (the altitude's range, the ISA model's, is
#: checked with the other structural checks and named with :func:`range_hint`).
RANGES: dict[str, tuple[float, float]] = {
    "mass": (1e-3, 1e7),
    "thrust": (0.0, 1e8),
    "ix": (1e-9, 1e10), "iy": (1e-9, 1e10), "iz": (1e-9, 1e10),
    "rho": AIRFRAME_LIMITS["density_kgm3"],
}
#: Other units of each channel: (name, SI value of one of them). A value outside its
#: range, off the airframe or off the kinematics by about one of these factors names it.
OTHER_UNITS: dict[str, tuple[tuple[str, float], ...]] = {
    "mass": (("grams", 1e-3), ("pounds", 0.45359237), ("tonnes", 1e3)),
    "thrust": (("kN", 1e3), ("lbf", 4.4482216), ("mN", 1e-3)),
    **{c: (("g m^2", 1e-3), ("kg cm^2", 1e-4), ("slug ft^2", 1.3558179))
       for c in ("ix", "iy", "iz")},
    "rho": (("g/m^3", 1e-3),),
    "altitude": (("feet", 0.3048), ("km", 1e3)),
    "qbar": (("kPa", 1e3), ("psf", 47.880259), ("psi", 6894.7573)),
}
#: A unit is named when the observed factor is within this factor of the unit's.
UNIT_MATCH = 1.15
#: The channel's median this far off the airframe's value (either way) is a warning: a
#: burn changes the mass a few percent over a window of seconds, the thrust ripples.
AIRFRAME_WARN_FACTOR = 1.10
#: This far off is an error: no propellant burn or thrust curve explains a factor 30
#: within a window; grams or kN give 1000.
AIRFRAME_ERROR_FACTOR = 30.0
#: The airframe's attribute and file key of each channel it states.
AIRFRAME_VALUES: dict[str, tuple[str, str, str]] = {
    "mass": ("mass_kg", "mass_kg", "kg"),
    "thrust": ("thrust_n", "thrust_N", "N"),
    "ix": ("ix_kgm2", "Ix_kgm2", "kg m^2"),
    "iy": ("iy_kgm2", "Iy_kgm2", "kg m^2"),
    "iz": ("iz_kgm2", "Iz_kgm2", "kg m^2"),
}
#: What the altitude check compares, as the kinematic checks name their pairs.
ALTITUDE_RATE = "the altitude's change"


def unit_hint(channel: str, factor: float) -> str:
    """Return ``" (altitude in feet?)"`` when ``factor`` (SI / logged) matches a unit, or ``""``."""
    if not (math.isfinite(factor) and factor > 0):
        return ""
    for name, si in OTHER_UNITS.get(channel, ()):
        if abs(math.log(factor / si)) < math.log(UNIT_MATCH):
            return f" ({channel} in {name}?)"
    return ""


def check_inputs(finite: dict[str, np.ndarray], airframe: Airframe, errors: list[str],
                 warns: list[str]) -> None:
    """Append the findings on the per-sample inputs of ``finite`` (channel -> values)."""
    for channel, (low, high) in RANGES.items():
        v = finite.get(channel)
        if v is None or v.size == 0:
            continue
        lo, hi = float(np.min(v)), float(np.max(v))
        if lo >= low and hi <= high:
            curve = channel == "thrust" and getattr(airframe, "thrust_curve", None) is not None
            if channel in AIRFRAME_VALUES and not curve:  # a curve: the thrust it states
                _against_airframe(channel, v, airframe, errors, warns)
            continue
        if (channel in ("mass", "ix", "iy", "iz", "rho") and lo <= 0) or (
                channel == "thrust" and lo < 0):
            continue  # the sign checks of aeroid.flights._checks say it
        worst = hi if hi > high else lo
        hint = range_hint(channel, v, low, high)
        errors.append(f"channel {channel!r} reaches {worst:.4g}, outside the plausible "
                      f"{low:g} to {high:g} {UNITS[channel]}{hint}")
    if "qbar" in finite and all(c in finite for c in ("u", "v", "w")):
        _dynamic_pressure(finite, errors)


def range_hint(channel: str, v: np.ndarray, low: float, high: float) -> str:
    """The units that would put every value of ``v`` inside ``[low, high]``, as a hint."""
    lo, hi = float(np.min(v)), float(np.max(v))
    names = [name for name, si in OTHER_UNITS.get(channel, ())
             if low <= lo * si and hi * si <= high and (lo * si > 0 or low == 0)]
    return f" ({channel} in {' or '.join(names)}?)" if names else ""


def _against_airframe(channel: str, v: np.ndarray, airframe: Airframe, errors: list[str],
                      warns: list[str]) -> None:
    attribute, key, unit = AIRFRAME_VALUES[channel]
    stated = float(getattr(airframe, attribute))
    median = float(np.median(v))
    both = (f"channel {channel!r} (median {median:.4g} {unit}) against the airframe's "
            f"{key} = {stated:.4g} {unit}")
    if median == stated:
        return
    if stated == 0.0 or median == 0.0:  # a thrust of 0 on one side: a coast, or a mistake
        where = "the channel" if median == 0.0 else "the airframe"
        warns.append(f"{both}: {where} says there is no thrust; the channel is used")
        return
    ratio = median / stated
    off = abs(math.log(ratio))
    hint = unit_hint(channel, 1.0 / ratio)
    if off > math.log(AIRFRAME_ERROR_FACTOR):
        errors.append(f"{both}: {ratio:.3g}x{hint or ' (check the unit)'}")
    elif off > math.log(AIRFRAME_WARN_FACTOR):
        warns.append(f"{both}: {ratio:.3g}x, more than {AIRFRAME_WARN_FACTOR - 1:.0%} off"
                     f"{hint}; the channel is used")


def _dynamic_pressure(finite: dict[str, np.ndarray], errors: list[str]) -> None:
    """``qbar`` against the airspeed: the density it implies must be a density."""
    qbar = finite["qbar"]
    speed2 = finite["u"] ** 2 + finite["v"] ** 2 + finite["w"] ** 2
    if np.any(qbar <= 0) or not np.all(speed2 > 0):
        return  # the sign and airspeed checks say it
    low, high = AIRFRAME_LIMITS["density_kgm3"]
    implied = 2.0 * qbar / speed2
    lo, hi = float(np.min(implied)), float(np.max(implied))
    if low <= lo and hi <= high:
        return
    hint = range_hint("qbar", implied, low, high)
    worst = hi if hi > high else lo
    errors.append(f"channel 'qbar' with the airspeed implies a density of {worst:.3g} kg/m^3 "
                  f"(2 qbar / V^2), outside the plausible {low:g} to {high:g} kg/m^3{hint}")


def altitude_pair(finite: dict[str, np.ndarray]) -> tuple[str, str, np.ndarray,
                                                           np.ndarray] | None:
    """``(left, right, y, x)`` with ``y = k x``: the altitude and the integrated climb.

    Both centred on their means (the altitude's origin is unknown). Integrating the
    vertical speed, rather than differentiating a noisy altimeter (a 0.5 m noise at
    500 Hz is 180 m/s of noise in its derivative), keeps the comparison sharp.
    """
    if not {"t", "altitude", "u", "v", "w", "phi", "theta"} <= set(finite):
        return None
    u, v, w = finite["u"], finite["v"], finite["w"]
    phi, theta, t = finite["phi"], finite["theta"], finite["t"]
    climb = u * np.sin(theta) - (v * np.sin(phi) + w * np.cos(phi)) * np.cos(theta)
    risen = np.concatenate([[0.0], np.cumsum(0.5 * (climb[1:] + climb[:-1]) * np.diff(t))])
    altitude = finite["altitude"]
    return (ALTITUDE_RATE, "the integrated vertical speed u sin theta - (v sin phi + w cos "
            "phi) cos theta", altitude - np.mean(altitude), risen - np.mean(risen))


def altitude_hint(k: float) -> str:
    """The likely cause of an altitude rate ``k`` times the vertical speed."""
    if k < 0:
        return "opposite signs: the altitude channel must be height up (not depth or z down)"
    hint = unit_hint("altitude", 1.0 / k)
    if hint:
        return f"altitude in {hint[len(' (altitude in '):-2]}? (the channel is in metres)"
    return "check the altitude's unit (metres), the time column and the attitude"
