"""A probe's pressures turned into the airspeed channel of a flight (issue 26).

The formulas, the checks and the decisions are :mod:`aeroid.flights._pitot`'s; this
module reads them off a :class:`~aeroid.flights.Flight` (the speed of sound from its
temperature, in the order of that docstring) and gives ``Estimator.fit`` the copy with an
``airspeed`` channel (:func:`with_pitot_airspeed`).
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np
import pandas as pd

from aeroid.errors import FlightError
from aeroid.flights._air_temperature import AIR_TEMPERATURE, air_temperature
from aeroid.flights._channels import CHANNELS
from aeroid.flights._flight import Flight
from aeroid.flights._pitot import (
    PITOT_CHANNELS,
    PITOT_KEY,
    STATIC_PRESSURE,
    TOTAL_PRESSURE,
    mach_from_pitot,
    pitot_findings,
    pitot_ratio_slope,
)
from aeroid.flights._windows import Windows
from aeroid.model import isa_temperature, speed_of_sound_at

__all__ = ["PitotAirspeed", "pitot_airspeed", "with_pitot_airspeed"]


@dataclasses.dataclass(frozen=True)
class PitotAirspeed:
    """The airspeed a probe's pressures give: ``airspeed`` [m/s], ``mach``,
    ``speed_of_sound`` [m/s], each (n,); ``sd`` [m/s] (n,) from the pressures' sd (None
    when not given); ``dv_dtotal``, ``dv_dstatic`` [m/s per Pa] (n,): the derivatives
    the sd propagates; ``note``: the one line saying what was done."""

    airspeed: np.ndarray
    mach: np.ndarray
    speed_of_sound: np.ndarray
    sd: np.ndarray | None
    dv_dtotal: np.ndarray
    dv_dstatic: np.ndarray
    note: str


def _where(flight: Flight) -> str:
    return str(flight.metadata.get("source", "flight"))


def _temperature(flight: Flight) -> tuple[np.ndarray, str]:
    """The air temperature [K] per sample for the speed of sound, and where it came from."""
    n = flight.n_samples
    logged = air_temperature(flight)
    if logged is not None:
        return logged, f"the logged {AIR_TEMPERATURE}"
    airframe = flight.airframe
    spec = airframe.tables
    if spec is not None and spec.temperature_k is not None:
        return (np.full(n, float(spec.temperature_k)),
                f"[tables] temperature_K = {spec.temperature_k:g} K; no {AIR_TEMPERATURE}")
    if airframe.atmosphere_channel == "altitude":
        return (np.asarray(isa_temperature(flight["altitude"]), dtype=float),
                f"ISA at the altitude channel; no {AIR_TEMPERATURE}")
    if airframe.altitude_m is not None:
        return (np.full(n, float(isa_temperature(airframe.altitude_m))),
                f"ISA at [atmosphere] altitude_m = {airframe.altitude_m:g} m; no "
                f"{AIR_TEMPERATURE}")
    raise FlightError(f"{_where(flight)}: the probe's pressures give Mach; its airspeed needs "
                      f"the air temperature: an {AIR_TEMPERATURE} channel, [tables] "
                      "temperature_K or [atmosphere] altitude_m (ISA); none is assumed")


def _given_sd(flight: Flight, total_sd_pa: float | None, static_sd_pa: float | None
              ) -> tuple[float, float] | None:
    noise = flight.metadata.get("noise") or {}
    total = total_sd_pa if total_sd_pa is not None else noise.get("total_pressure_sd_pa")
    static = static_sd_pa if static_sd_pa is not None else noise.get("static_pressure_sd_pa")
    if total is None and static is None:
        return None
    return float(total or 0.0), float(static or 0.0)


def pitot_airspeed(flight: Flight, *, total_sd_pa: float | None = None,
                   static_sd_pa: float | None = None) -> PitotAirspeed:
    """Return the airspeed of ``flight``'s probe pressures and its sd (module docstring).

    ``total_sd_pa``, ``static_sd_pa``: the pressures' noise sd [Pa] (default: the
    simulator's, ``metadata["noise"]``; neither: ``sd`` is None). The airspeed's sd is
    ``sqrt((dV/dp0 sd0)^2 + (dV/dp sd)^2)`` with ``V = a M(p0 / p)``.

    Raises
    ------
    FlightError
        One line naming the flight: :func:`pitot_findings`, or no temperature.
    """
    present = {c: flight[c] for c in (*PITOT_CHANNELS, "airspeed") if c in flight.channels}
    if TOTAL_PRESSURE not in present:
        raise FlightError(f"{_where(flight)}: no {TOTAL_PRESSURE!r} channel (a probe's "
                          "pressures)")
    problems = pitot_findings(present)
    if problems:
        raise FlightError(f"{_where(flight)}: " + "; ".join(problems))
    total, static = present[TOTAL_PRESSURE], present[STATIC_PRESSURE]
    temperature, source = _temperature(flight)
    a = np.asarray(speed_of_sound_at(temperature), dtype=float)
    ratio = total / static
    try:
        mach = mach_from_pitot(ratio)
    except ValueError as exc:
        raise FlightError(f"{_where(flight)}: {TOTAL_PRESSURE} / {STATIC_PRESSURE}: {exc}"
                          ) from None
    dv_dr = a / pitot_ratio_slope(mach)
    dv_dtotal, dv_dstatic = dv_dr / static, -dv_dr * ratio / static
    given = _given_sd(flight, total_sd_pa, static_sd_pa)
    sd = None if given is None else np.hypot(dv_dtotal * given[0], dv_dstatic * given[1])
    speed = mach * a
    above = int(np.count_nonzero(mach >= 1.0))
    formula = ("Rayleigh's pitot formula" if above == mach.size else "isentropic" if not above
               else f"Rayleigh's pitot formula at {above} of {mach.size} samples, isentropic "
               "at the rest")
    shown = (f"its sd {np.min(sd):.3g}-{np.max(sd):.3g} m/s from the pressures' sd "
             f"{given[0]:g}, {given[1]:g} Pa" if sd is not None and given is not None else
             f"1 Pa moves it {np.median(dv_dtotal):.3g} m/s (total), "
             f"{np.median(-dv_dstatic):.3g} m/s (static; no sd given)")
    sound = (f"{a[0]:.5g}" if np.ptp(a) == 0 else f"{np.min(a):.5g}-{np.max(a):.5g}")
    note = (f"airspeed from the probe's {TOTAL_PRESSURE} and {STATIC_PRESSURE}: Mach "
            f"{np.min(mach):.4g}-{np.max(mach):.4g} ({formula}) times the speed of sound "
            f"{sound} m/s ({source}): {np.min(speed):.5g}-{np.max(speed):.5g} m/s, {shown}")
    return PitotAirspeed(speed, mach, a, sd, dv_dtotal, dv_dstatic, note)


def _with_airspeed(flight: Flight) -> Flight:
    if TOTAL_PRESSURE not in flight.channels:
        if STATIC_PRESSURE not in flight.channels:
            return flight
        note = (f"{STATIC_PRESSURE} not used (a static pressure without a pitot's "
                f"{TOTAL_PRESSURE} is a barometer's, not air data)")
        logging.getLogger("aeroid").info(f"{_where(flight)}: {note}")
        return Flight(flight.data.drop(columns=STATIC_PRESSURE), flight.airframe,
                      dict(flight.metadata), notes=(*flight.notes, note))
    derived = pitot_airspeed(flight)
    frame = flight.data.drop(columns=list(PITOT_CHANNELS)).assign(airspeed=derived.airspeed)
    ordered = [c for c in CHANNELS if c in frame] + [c for c in frame if c not in CHANNELS]
    logging.getLogger("aeroid").info(f"{_where(flight)}: {derived.note}")
    return Flight(pd.DataFrame(frame[ordered]), flight.airframe,
                  {**flight.metadata, PITOT_KEY: derived.note},
                  notes=(*flight.notes, derived.note))


def with_pitot_airspeed(flight: Flight | Windows) -> Flight | Windows:
    """Return ``flight`` (or every window) with a probe's pressures turned into the
    ``airspeed`` channel (the pressure columns dropped; ``metadata[PITOT_KEY]`` and the
    ``aeroid`` logger say what was done); a static pressure alone dropped (said); else
    ``flight`` itself.

    Raises
    ------
    FlightError
        As :func:`pitot_airspeed`.
    """
    if isinstance(flight, Windows):
        converted = tuple(_with_airspeed(f) for f in flight.flights)
        if all(a is b for a, b in zip(converted, flight.flights, strict=True)):
            return flight
        return dataclasses.replace(flight, flights=converted)
    return _with_airspeed(flight)


