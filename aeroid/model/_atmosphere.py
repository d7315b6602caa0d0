"""International Standard Atmosphere (troposphere and lower stratosphere, 0-20 km).

:func:`pressure` and :func:`temperature` take real or complex altitudes (the branch is
chosen on the real part), so a complex-step derivative goes through them (the
reconstruction's barometer model). :func:`pressure_altitude` is the inverse of
:func:`pressure`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

G0 = 9.80665  # m/s^2, standard gravity
R_AIR = 287.05287  # J/(kg K), specific gas constant of dry air
GAMMA = 1.4
T0 = 288.15  # K, sea-level temperature
P0 = 101325.0  # Pa, sea-level pressure
LAPSE = 0.0065  # K/m, tropospheric lapse rate
H_TROPOPAUSE = 11000.0  # m
#: ISA temperature [K] and pressure [Pa] at the tropopause.
T_TROPOPAUSE = T0 - LAPSE * H_TROPOPAUSE
_EXPONENT = G0 / (R_AIR * LAPSE)
P_TROPOPAUSE = P0 * (T_TROPOPAUSE / T0) ** _EXPONENT
#: Air temperature range [K] of a given or logged air temperature (the ISA's 216.65 K
#: layer to a hot day at sea level, with margin); outside, a unit mistake (deg C).
AIR_TEMPERATURE_RANGE_K = (150.0, 350.0)


def _altitude(altitude_m: float | complex | np.ndarray) -> np.ndarray:
    h = np.asarray(altitude_m)
    return h if np.iscomplexobj(h) else h.astype(float)


def temperature(altitude_m: float | complex | np.ndarray) -> np.ndarray:
    """Return ISA temperature [K] at geopotential altitude [m], valid 0-20 km."""
    h = _altitude(altitude_m)
    return np.where(h.real < H_TROPOPAUSE, T0 - LAPSE * h, T_TROPOPAUSE + 0.0 * h)


def pressure(altitude_m: float | complex | np.ndarray) -> np.ndarray:
    """Return ISA pressure [Pa] at geopotential altitude [m], valid 0-20 km."""
    h = _altitude(altitude_m)
    below = h.real < H_TROPOPAUSE
    h_trop = np.where(below, h, H_TROPOPAUSE)
    h_strat = np.where(below, H_TROPOPAUSE, h)
    p_trop = P0 * ((T0 - LAPSE * h_trop) / T0) ** _EXPONENT
    above = np.exp(-G0 * (h_strat - H_TROPOPAUSE) / (R_AIR * T_TROPOPAUSE))
    return np.where(below, p_trop, P_TROPOPAUSE * above)


def pressure_altitude(pressure_pa: float | np.ndarray) -> np.ndarray:
    """Return the ISA pressure altitude [m] of a static pressure [Pa] (inverse of pressure)."""
    p = np.asarray(pressure_pa, dtype=float)
    trop = T0 / LAPSE * (1.0 - (p / P0) ** (1.0 / _EXPONENT))
    strat = H_TROPOPAUSE - R_AIR * T_TROPOPAUSE / G0 * np.log(p / P_TROPOPAUSE)
    return np.where(p > P_TROPOPAUSE, trop, strat)


def density(altitude_m: float | np.ndarray) -> np.ndarray:
    """Return ISA air density [kg/m^3] at altitude [m]."""
    return pressure(altitude_m) / (R_AIR * temperature(altitude_m))


def speed_of_sound_at(temperature_k: Any) -> Any:
    """Return the speed of sound ``sqrt(gamma R T)`` [m/s] of air at ``temperature_k`` [K].

    The one definition (the ISA's, a given and a per-sample temperature all use it);
    element-wise, so numpy evaluates it on arrays and CasADi on symbols.
    """
    return np.sqrt(GAMMA * R_AIR * temperature_k)


def speed_of_sound(altitude_m: float | np.ndarray) -> np.ndarray:
    """Return ISA speed of sound [m/s] at altitude [m]."""
    return np.asarray(speed_of_sound_at(temperature(altitude_m)))


def check_air_temperature(values: Any, where: str) -> np.ndarray:
    """Return air temperatures [K] as floats, checked: finite and in
    :data:`AIR_TEMPERATURE_RANGE_K` (outside it a unit mistake, e.g. deg C given as K).

    Raises
    ------
    ValueError
        One line naming ``where``, the first bad value and its sample index.
    """
    if isinstance(values, bool) or not isinstance(values, int | float | np.ndarray | list
                                                      | tuple | np.floating):
        raise ValueError(f"{where} must be a number of kelvin, got {values!r}")
    t = np.asarray(values, dtype=float)
    low, high = AIR_TEMPERATURE_RANGE_K
    bad = np.flatnonzero(~(np.isfinite(t) & (t >= low) & (t <= high)))
    if bad.size:
        i = int(bad[0])
        value = t.reshape(-1)[i]
        at = "" if t.ndim == 0 else f" at sample {i}"
        raise ValueError(f"{where} must be an air temperature in {low:g}..{high:g} K (kelvin, "
                         f"not deg C), got {value!r}{at} ({bad.size} bad value(s))")
    return t
