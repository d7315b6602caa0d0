"""A pitot-static probe's pressures as the airspeed channel (issue 26).

A flight may log a probe's ``total_pressure`` (the pitot's) and ``static_pressure`` [Pa]
(columns of those names, or mapped to them, in Pa, hPa, mbar, kPa, psi or psf through the
column map's units). Their ratio ``r = p0 / p`` gives the Mach number:

* subsonic, isentropic: ``r = (1 + (g - 1) / 2 M^2)^(g / (g - 1))`` (NACA 1135 eq. 44),
  inverted in closed form;
* supersonic, Rayleigh's pitot formula (a normal shock stands ahead of the probe, whose
  total pressure is the one behind it, NACA 1135 eq. 100):
  ``r = ((g + 1)^2 M^2 / (4 g M^2 - 2 (g - 1)))^(g / (g - 1)) (1 - g + 2 g M^2) / (g + 1)``,
  solved for M by scipy's bracketed root finder on ``[1, MAX_MACH]``
  (:func:`mach_from_pitot`).

Both give ``((g + 1) / 2)^(g / (g - 1))`` = 1.893 at Mach 1 with the same slope. The
airspeed is ``M a``, the speed of sound ``a = sqrt(g R T)`` from, in turn: the log's
``air_temperature`` channel; the airframe's ``[tables] temperature_K``; the ISA at the
flight's ``altitude`` channel (``[atmosphere] per_sample = "altitude"``); the ISA at
``[atmosphere] altitude_m``. The same order as the Mach tables' speed of sound
(:func:`aeroid.flights.flight_mach_tables`), so a table fit's Mach is the probe's. A
flight with none (a given density) is refused: no temperature is assumed.

:func:`aeroid.flights.with_pitot_airspeed` (called by ``Estimator.fit``) turns the
pressures into the ``airspeed`` channel every method reads (the pressure columns are
dropped from the fitted copy) and says so in one line; the airspeed's sd per sample is
the pressures' sd propagated by the derivative (:func:`aeroid.flights.pitot_airspeed`).
Decisions: a log with both an ``airspeed`` channel and the pressures is refused (two
airspeeds: drop one with the column map's ``""``); a total pressure without a static one
is refused (Mach needs both; no ISA static pressure is assumed); a static pressure alone
is a barometer's, not air data: the fit leaves it out and says so in one line.

The simulator's probe (:meth:`aeroid.flights.GaussianNoise.corrupt_pitot`) logs the
static pressure of its atmosphere, ``p = rho R T`` (its density, and the air temperature
of :func:`true_air_temperature`: the ISA pressure at ``altitude_m`` without ``[air]``),
and the total pressure ``p r(M)`` of the true air-relative Mach.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.optimize.elementwise import find_root

from aeroid.errors import AirframeError
from aeroid.model import GAMMA, R_AIR, Airframe, isa_temperature, speed_of_sound_at

__all__ = ["MAX_MACH", "PITOT_CHANNELS", "PITOT_KEY", "SONIC_RATIO", "STATIC_PRESSURE",
           "STATIC_RANGE_PA", "TOTAL_PRESSURE", "bad_runs", "mach_from_pitot",
           "pitot_findings", "pitot_ratio", "pitot_ratio_slope", "probe_pressures",
           "true_air_temperature"]

TOTAL_PRESSURE = "total_pressure"
STATIC_PRESSURE = "static_pressure"
PITOT_CHANNELS: tuple[str, ...] = (TOTAL_PRESSURE, STATIC_PRESSURE)
#: Metadata key of the fitted copy: the line saying the airspeed came from the pressures.
PITOT_KEY = "airspeed_from_pressures"
#: Upper end of the supersonic root's bracket: the flight check's 3000 m/s at the ISA's
#: coldest 216.65 K is Mach 10; a ratio beyond Mach 20's is a unit mistake.
MAX_MACH = 20.0
#: Static pressure range [Pa]: 30 km (1.2 kPa) to a deep low at sea level below it; a
#: static pressure outside is in another unit (kPa or hPa read as Pa, or Pa as kPa).
STATIC_RANGE_PA = (1.0e3, 1.1e5)
#: Units a pressure may have been logged in, for the hint of the range check.
_OTHER_UNITS = (("kPa", 1e3), ("hPa or mbar", 1e2), ("psi", 6894.757293168))
_EXPONENT = GAMMA / (GAMMA - 1.0)
#: Pitot ratio at Mach 1, where the two formulas meet.
SONIC_RATIO = (0.5 * (GAMMA + 1.0)) ** _EXPONENT


def pitot_ratio(mach: Any, gamma: float = GAMMA) -> np.ndarray:
    """Return the probe's total over the free stream's static pressure at ``mach``.

    Isentropic below Mach 1, Rayleigh's pitot formula (normal shock) from Mach 1 on
    (module docstring); element-wise, any shape.
    """
    m2 = np.asarray(mach, dtype=float) ** 2
    e = gamma / (gamma - 1.0)
    sub = (1.0 + 0.5 * (gamma - 1.0) * m2) ** e
    with np.errstate(divide="ignore", invalid="ignore"):
        sup = ((gamma + 1.0) ** 2 * m2 / (4.0 * gamma * m2 - 2.0 * (gamma - 1.0))) ** e \
            * (1.0 - gamma + 2.0 * gamma * m2) / (gamma + 1.0)
    return np.where(m2 < 1.0, sub, sup)


def pitot_ratio_slope(mach: Any, gamma: float = GAMMA) -> np.ndarray:
    """Return ``d pitot_ratio / d M`` at ``mach`` (the two formulas' derivatives)."""
    m = np.asarray(mach, dtype=float)
    e = gamma / (gamma - 1.0)
    sub = gamma * m * (1.0 + 0.5 * (gamma - 1.0) * m * m) ** (1.0 / (gamma - 1.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        log_slope = (2.0 * e / m - e * 8.0 * gamma * m / (4.0 * gamma * m * m - 2.0 * (gamma - 1.0))
                     + 4.0 * gamma * m / (1.0 - gamma + 2.0 * gamma * m * m))
    return np.where(m < 1.0, sub, pitot_ratio(m, gamma) * log_slope)


def mach_from_pitot(ratio: Any, gamma: float = GAMMA) -> np.ndarray:
    """Return the Mach number of pitot ratios ``p0 / p`` (the inverse of :func:`pitot_ratio`).

    Subsonic in closed form; supersonic by scipy's vectorised bracketed root finder
    (:func:`scipy.optimize.elementwise.find_root`, Chandrupatla's method: brentq's
    guarantees, all samples at once) on ``log r(M) = log r`` in ``[1, MAX_MACH]``, to
    ``xatol`` 1e-13. Measured (``benchmarks/bench_pitot.py --timing-only``): 0.31 s for
    100,000 supersonic samples, where :func:`scipy.optimize.brentq` per sample takes 35 s
    (the tests use it as the reference solver).

    Raises
    ------
    ValueError
        A ratio that is not finite, below 1, or beyond Mach :data:`MAX_MACH`'s, naming
        the first such sample.
    """
    r = np.asarray(ratio, dtype=float)
    flat = r.reshape(-1)
    top = float(pitot_ratio(MAX_MACH, gamma))
    bad = np.flatnonzero(~((flat >= 1.0) & (flat <= top)))
    if bad.size:
        raise ValueError(f"pitot ratio p0/p must be in 1..{top:.4g} (Mach 0..{MAX_MACH:g}), "
                         f"got {flat[bad[0]]!r} at sample {int(bad[0])}")
    sonic = (0.5 * (gamma + 1.0)) ** (gamma / (gamma - 1.0))
    mach = np.sqrt(np.maximum(flat ** ((gamma - 1.0) / gamma) - 1.0, 0.0) * 2.0 / (gamma - 1.0))
    above = np.flatnonzero(flat >= sonic)
    if above.size:
        target = np.log(flat[above])
        found = find_root(lambda m, t: np.log(pitot_ratio(np.maximum(m, 1.0), gamma)) - t,
                          (np.ones(above.size), np.full(above.size, MAX_MACH)), args=(target,),
                          tolerances={"xatol": 1e-13, "xrtol": 1e-15})
        if not np.all(found.success):  # the bracket holds every root: never seen
            raise ValueError(f"pitot ratio: no Mach found at sample "
                             f"{int(above[np.flatnonzero(~found.success)[0]])}")
        mach[above] = found.x
    return mach.reshape(r.shape)


def bad_runs(bad: np.ndarray) -> str:
    """``"k value(s) in j run(s), first rows a-b"`` of the sorted bad row indices."""
    starts = np.flatnonzero(np.diff(bad, prepend=-2) != 1)
    first_end = bad[starts[1] - 1] if starts.size > 1 else bad[-1]
    rows = f"row {bad[0]}" if first_end == bad[0] else f"rows {bad[0]}-{first_end}"
    return f"{bad.size} value(s) in {starts.size} run(s), first at {rows}"


def pitot_findings(values: dict[str, np.ndarray], *, check_finite: bool = True) -> list[str]:
    """Return one error line per problem of the probe's pressures in ``values`` (channel
    arrays; none when the flight has no ``total_pressure``): a total without a static
    pressure, both pressures and an ``airspeed``, NaN (``check_finite``; else, with a NaN,
    nothing more: the flight check names it), values out of range, and a total not
    above the static pressure (each naming its rows)."""
    if TOTAL_PRESSURE not in values:
        return []
    if STATIC_PRESSURE not in values:
        return [f"channel {TOTAL_PRESSURE!r} without {STATIC_PRESSURE!r}: Mach needs both "
                "(no static pressure is assumed); map the probe's static pressure or drop "
                "the column"]
    if "airspeed" in values:
        return [f"both an 'airspeed' channel and a probe's {TOTAL_PRESSURE}, "
                f"{STATIC_PRESSURE}: two airspeeds; drop one with the column map (\"\")"]
    found = []
    total, static = (np.asarray(values[c], dtype=float) for c in PITOT_CHANNELS)
    for name, v in ((TOTAL_PRESSURE, total), (STATIC_PRESSURE, static)):
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size and not check_finite:
            return []
        if bad.size:
            found.append(f"channel {name!r} has NaN/inf: {bad_runs(bad)}")
    if found:
        return found
    low, high = STATIC_RANGE_PA
    bad = np.flatnonzero((static < low) | (static > high))
    if bad.size:
        first = float(static[bad[0]])
        hint = next((f" ({unit} read as Pa?)" for unit, pa in _OTHER_UNITS
                     if low <= first * pa <= high), "")
        found.append(f"channel {STATIC_PRESSURE!r} must be an air pressure in {low:g}.."
                     f"{high:g} Pa, got {first:.4g}{hint}: {bad_runs(bad)}")
    bad = np.flatnonzero(~(total > static))
    if bad.size:
        found.append(f"channel {TOTAL_PRESSURE!r} must be above {STATIC_PRESSURE!r} (a "
                     f"pitot's total pressure): not above it in {bad_runs(bad)}")
    return found


def true_air_temperature(airframe: Airframe, air: Any, speed_of_sound_mps: float | None,
                         t: np.ndarray) -> np.ndarray:
    """Return the simulator's true air temperature [K] at ``t``: the scenario's ``[air]``
    (``air``), else that of the flown tables' speed of sound (``speed_of_sound_mps``),
    else the ISA at ``altitude_m``.

    Raises
    ------
    AirframeError
        None of them (a given density): the probe's pressures need a temperature.
    """
    t = np.asarray(t, dtype=float)
    if air is not None:
        return np.asarray(air.temperature(t, airframe.altitude_m), dtype=float)
    if speed_of_sound_mps is not None:
        return np.full(t.shape, speed_of_sound_mps ** 2 / (GAMMA * R_AIR))
    if airframe.altitude_m is not None:
        return np.full(t.shape, float(isa_temperature(airframe.altitude_m)))
    raise AirframeError("simulate: the probe's pressures (total_pressure_sd_pa, "
                        "static_pressure_sd_pa) need the air temperature: [atmosphere] "
                        "altitude_m (ISA) or the scenario's [air]")


def probe_pressures(air_velocity: tuple[np.ndarray, ...], density_kgm3: Any,
                    temperature_k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the true ``(total, static)`` pressures [Pa] a probe reads in air of
    ``density_kgm3`` and ``temperature_k`` at the air-relative body velocity
    ``air_velocity`` ``(u, v, w)`` [m/s]: ``p = rho R T`` and ``p r(V / a)``."""
    u, v, w = (np.asarray(c, dtype=float) for c in air_velocity)
    static = np.broadcast_to(np.asarray(density_kgm3, dtype=float) * R_AIR * temperature_k,
                             u.shape).astype(float)
    mach = np.sqrt(u * u + v * v + w * w) / np.asarray(speed_of_sound_at(temperature_k))
    return static * pitot_ratio(mach), static
