"""International Standard Atmosphere (troposphere and lower stratosphere, 0-20 km)."""

from __future__ import annotations

import numpy as np

G0 = 9.80665  # m/s^2, standard gravity
R_AIR = 287.05287  # J/(kg K), specific gas constant of dry air
GAMMA = 1.4
T0 = 288.15  # K, sea-level temperature
P0 = 101325.0  # Pa, sea-level pressure
LAPSE = 0.0065  # K/m, tropospheric lapse rate
H_TROPOPAUSE = 11000.0  # m


def temperature(altitude_m: float | np.ndarray) -> np.ndarray:
    """Return ISA temperature [K] at geopotential altitude [m], valid 0-20 km."""
    h = np.asarray(altitude_m, dtype=float)
    return np.where(h < H_TROPOPAUSE, T0 - LAPSE * h, T0 - LAPSE * H_TROPOPAUSE)


def pressure(altitude_m: float | np.ndarray) -> np.ndarray:
    """Return ISA pressure [Pa] at geopotential altitude [m], valid 0-20 km."""
    h = np.asarray(altitude_m, dtype=float)
    exponent = G0 / (R_AIR * LAPSE)
    p_trop = P0 * (temperature(np.minimum(h, H_TROPOPAUSE)) / T0) ** exponent
    t11 = T0 - LAPSE * H_TROPOPAUSE
    above = np.exp(-G0 * np.maximum(h - H_TROPOPAUSE, 0.0) / (R_AIR * t11))
    return p_trop * above


def density(altitude_m: float | np.ndarray) -> np.ndarray:
    """Return ISA air density [kg/m^3] at altitude [m]."""
    return pressure(altitude_m) / (R_AIR * temperature(altitude_m))


def speed_of_sound(altitude_m: float | np.ndarray) -> np.ndarray:
    """Return ISA speed of sound [m/s] at altitude [m]."""
    return np.sqrt(GAMMA * R_AIR * temperature(altitude_m))
