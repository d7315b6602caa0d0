"""The barometer of a suite log: pressure altitude, or static pressure and temperature.

A ``baro`` group carries either ``altitude`` (a pressure altitude [m]) or ``pressure``
[Pa], optionally with ``temperature`` [K]. With ``pressure`` the filter's measurement is
the ISA pressure of the reconstructed pressure altitude, ``p = p_ISA(alt0 - pd)`` (so the
residual check is in the sensor's own unit), and the prior's altitude is the ISA pressure
altitude of the first sample. The density is ``rho = p / (R T)``: ``p`` the ISA pressure
of the reconstructed altitude at each IMU sample, ``T`` the logged temperature linear
between its samples (held beyond them); without a temperature channel, the ISA density
of the pressure altitude (a note says which).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from aeroid.errors import FlightError
from aeroid.flights import SuiteLog
from aeroid.model import R_AIR, isa_pressure, pressure_altitude

Model = Callable[[np.ndarray], np.ndarray]


def baro_channel(log: SuiteLog) -> str | None:
    """Return the barometer's measured channel, ``"altitude"`` or ``"pressure"`` (or None).

    Raises
    ------
    FlightError
        Both an altitude and a pressure (one would be ignored), a temperature without a
        pressure, or neither.
    """
    if "baro" not in log:
        return None
    group = log["baro"]
    has = set(group.channels)
    if {"altitude", "pressure"} <= has:
        raise FlightError(f"{group.source}: the baro group has both altitude and pressure; "
                          "give one (the other would be ignored)")
    if "temperature" in has and "pressure" not in has:
        raise FlightError(f"{group.source}: a baro temperature needs the static pressure "
                          "(rho = p / (R T)); give the pressure channel or drop temperature")
    if not has & {"altitude", "pressure"}:
        raise FlightError(f"{group.source}: the baro group needs altitude or pressure")
    return "pressure" if "pressure" in has else "altitude"


def baro_model(channel: str, altitude: Model) -> Model:
    """Return the measurement model of ``channel`` given the altitude's model ``h(x)``."""
    if channel == "pressure":
        return lambda x: isa_pressure(altitude(x))
    return altitude


def baro_altitude(channel: str, value: float, sd: float) -> tuple[float, float]:
    """Return the pressure altitude [m] of one sample and its sd [m]."""
    if channel == "altitude":
        return value, sd
    h = float(pressure_altitude(value))
    step = 1e-30
    slope = abs(float(isa_pressure(h + 1j * step).imag) / step)  # dp/dh [Pa/m]
    return h, sd / slope


def baro_density(log: SuiteLog, t: np.ndarray, altitude: np.ndarray,
                 notes: list[str]) -> np.ndarray | None:
    """Return ``p / (R T)`` at the IMU times ``t`` [kg/m^3], or None without a temperature."""
    group = log["baro"]
    if "temperature" not in group.channels:
        notes.append("density: ISA at the reconstructed pressure altitude (no baro "
                     "temperature)")
        return None
    temperature = np.interp(t, group.t, group.channels["temperature"])
    if not np.all(temperature > 0):
        raise FlightError(f"{group.source}: temperature must be above 0 K (min "
                          f"{float(np.min(group.channels['temperature'])):.6g} K)")
    notes.append("density: rho = p / (R T), p the ISA pressure of the reconstructed pressure "
                 "altitude, T the baro temperature linear between its samples")
    return isa_pressure(altitude) / (R_AIR * temperature)
