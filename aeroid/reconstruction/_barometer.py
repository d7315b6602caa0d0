"""The barometer of a suite log: pressure altitude, or static pressure and temperature.

A ``baro`` group carries either ``altitude`` (a pressure altitude [m]) or ``pressure``
[Pa], optionally with ``temperature`` [K]. With ``pressure`` the filter's measurement is
the ISA pressure of the reconstructed pressure altitude, ``p = p_ISA(alt0 - pd)`` (so the
residual check is in the sensor's own unit), and the prior's altitude is the ISA pressure
altitude of the first sample. The density is ``rho = p / (R T)``: ``p`` the ISA pressure
of the reconstructed altitude at each IMU sample, ``T`` the logged temperature linear
between its samples (held beyond them); without a temperature channel, the ISA density
of the pressure altitude (a note says which). A temperature the log declares the board's
(``[groups.baro] temperature = "board"``: a flight computer's barometer) is not the air's:
the density is then the ISA density of the pressure altitude, and the note says why.
:func:`flight_atmosphere` passes the density on to a reconstruction's flight.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pandas as pd

from aeroid.errors import FlightError
from aeroid.flights import SuiteLog
from aeroid.model import R_AIR, Airframe, isa_pressure, pressure_altitude

Model = Callable[[np.ndarray], np.ndarray]
#: The densities :meth:`aeroid.reconstruction.Reconstruction.to_flight` can give a flight.
ATMOSPHERES = ("airframe", "per-sample", "altitude")


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
    if group.temperature_of == "board":
        notes.append('density: ISA at the reconstructed pressure altitude (the baro '
                     'temperature is the board\'s, temperature = "board": not the air\'s, '
                     'not used)')
        return None
    if "temperature" not in group.channels:
        notes.append("density: ISA at the reconstructed pressure altitude (no baro "
                     "temperature)")
        return None
    temperature = np.interp(t, group.t, group.channels["temperature"])
    if not np.all(temperature > 0):
        raise FlightError(f"{group.source}: temperature must be above 0 K (min "
                          f"{float(np.min(group.channels['temperature'])):.6g} K)")
    notes.append("density: rho = p / (R T), p the ISA pressure of the reconstructed pressure "
                 "altitude, T the baro temperature (the outside air's; a board's says "
                 'temperature = "board") linear between its samples')
    return isa_pressure(altitude) / (R_AIR * temperature)


def flight_atmosphere(atmosphere: str, table: pd.DataFrame, airframe: Airframe,
                      metadata: dict[str, Any], channels: dict[str, np.ndarray]
                      ) -> tuple[Airframe, str]:
    """Return a reconstruction's flight's airframe for ``atmosphere`` and its one-line note.

    Adds the flight's atmosphere channel to ``channels``: ``rho`` (the table's
    ``p / (R T)``, for ``"per-sample"`` when ``metadata['density']`` is ``"barometer"``)
    or ``altitude`` (ISA density per sample); none for ``"airframe"``.

    Raises
    ------
    FlightError
        A per-sample density without a barometer (no altitude in the table).
    """
    if atmosphere == "airframe":
        return airframe, "flight density: the airframe's atmosphere"
    if "altitude" not in table:
        raise FlightError(f"{metadata.get('source', 'suite log')}: atmosphere "
                          f"{atmosphere!r} needs a barometer group")
    from_baro = metadata.get("density") == "barometer"
    per_sample = airframe.replace(altitude_m=None, given_density_kgm3=None,
                                  atmosphere_channel="altitude")
    if atmosphere == "per-sample" and from_baro:
        channels["rho"] = table["rho"].to_numpy()
        return (per_sample.replace(atmosphere_channel="rho"),
                "flight density: rho = p / (R T) per sample from the barometer's pressure "
                "and temperature (channel rho)")
    channels["altitude"] = table["altitude"].to_numpy()
    note = "flight density: ISA at the reconstructed altitude, per sample"
    if from_baro:
        note += " (the barometer's rho = p / (R T) not used: atmosphere 'per-sample' uses it)"
    elif atmosphere == "per-sample":
        note += " (no baro temperature for p / (R T))"
    return per_sample, note
