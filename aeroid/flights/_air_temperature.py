"""The logged air temperature: the speed of sound of a flight's Mach tables, per sample.

A flight may carry the channel ``air_temperature`` [K] (a column of that name, or one
mapped to it, in ``K`` or ``degC`` through the column map's units): the temperature of the
AIR the airframe flies through, from an air-data probe or a met record. With the
airframe's ``[tables]`` it gives the speed of sound ``sqrt(gamma R T)`` of every sample
(:func:`flight_mach_tables`), and the fits' Mach is the airspeed over it at every sample
and RK4 stage (the model's exogenous input ``temperature``); without ``[tables]`` no part
of the model depends on it and the fits say so in one line (:func:`unused_note`).

A barometer's temperature in a flight-computer log is its BOARD's (issue 25), not the
air's: the suite log keeps it in its ``baro`` group (``temperature = "board"`` or
``"air"``, used for the density only) and never makes it this channel. A single-file log
names the channel explicitly (``air_temperature``); there is no shorter alias that a
``temperature`` column could fall into.
"""

from __future__ import annotations

import numpy as np

from aeroid.errors import FlightError
from aeroid.flights._flight import Flight
from aeroid.model import MachTables, check_air_temperature, speed_of_sound_at

#: The channel of the air temperature [K].
AIR_TEMPERATURE = "air_temperature"


def air_temperature(flight: Flight) -> np.ndarray | None:
    """Return the flight's logged air temperature [K], shape (n,), or None without one.

    Raises
    ------
    FlightError
        One line for a value that is not an air temperature (NaN, non-positive, outside
        :data:`aeroid.model.AIR_TEMPERATURE_RANGE_K`), naming the first bad sample.
    """
    if AIR_TEMPERATURE not in flight.channels:
        return None
    where = f"{flight.metadata.get('source', 'flight')}: channel {AIR_TEMPERATURE!r}"
    try:
        return check_air_temperature(np.asarray(flight[AIR_TEMPERATURE], dtype=float), where)
    except ValueError as exc:
        raise FlightError(str(exc)) from None


def flight_mach_tables(flight: Flight, states: np.ndarray | None = None
                       ) -> MachTables | None:
    """Return the flight's Mach tables (None without ``[tables]``): Mach from the logged
    air temperature of every sample when the flight has one, else the airframe's one
    speed of sound (``[tables] temperature_K`` or ISA at the altitude).

    ``states``: the flight's (default :meth:`Flight.states`), to choose counted knots.
    """
    if flight.airframe.tables is None:
        return None
    states = flight.states() if states is None else states
    return flight.airframe.mach_tables(states, air_temperature(flight))


def speed_of_sound_note(flight: Flight, tables: MachTables) -> str:
    """Return the one line saying which speed of sound a table fit's Mach used."""
    if tables.per_sample_temperature:
        t = air_temperature(flight)
        assert t is not None  # per-sample tables come from the channel
        a = speed_of_sound_at(t)
        return (f"Mach: speed of sound per sample from the logged {AIR_TEMPERATURE} "
                f"({t.min():.5g}-{t.max():.5g} K: {a.min():.5g}-{a.max():.5g} m/s)")
    spec = flight.airframe.tables
    source = (f"[tables] temperature_K = {spec.temperature_k:g} K"
              if spec is not None and spec.temperature_k is not None
              else f"ISA at [atmosphere] altitude_m = {flight.airframe.altitude_m:g} m")
    return (f"Mach: one speed of sound for the flight, {tables.speed_of_sound_mps:.5g} m/s "
            f"({source}; no {AIR_TEMPERATURE} channel)")


def unused_note(flight: Flight) -> str | None:
    """Return the one line saying a logged air temperature is not used (no ``[tables]``:
    no part of the model depends on Mach), or None."""
    if AIR_TEMPERATURE in flight.channels and flight.airframe.tables is None:
        return (f"{AIR_TEMPERATURE}: not used (the airframe has no [tables]: no coefficient "
                "depends on Mach)")
    return None


__all__ = ["AIR_TEMPERATURE", "air_temperature", "flight_mach_tables", "speed_of_sound_note",
           "unused_note"]
