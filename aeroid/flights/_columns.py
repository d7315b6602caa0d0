"""A logger's columns as aeroid channels: the column map, units, wrapped angles.

Column map (TOML, :func:`read_column_map`)
    ``name in the file = "channel"``; ``name = ""`` drops the column (a logged ``qbar``
    beside ``[atmosphere] per_sample = "rho"``, which would otherwise be refused as an
    input the model does not use); ``name = {channel = "p", unit = "deg/s"}`` converts
    the column to aeroid's unit on reading (:data:`UNIT_FACTORS`; the conversion is
    recorded in the flight's ``metadata["units"]``). A column with a unit is converted by
    it alone (``--degrees`` applies to the angle channels without one).
Wrapped angles (:func:`unwrap_angles`)
    A roll or yaw angle logged within +-180 deg jumps by a turn when it wraps. When its
    Euler rate from the logged p, q, r moves it less than half a turn per sample
    (``|phidot| dt < pi``), each jump is resolved: the turn is the one that brings the step
    closest to the rate's, and the angle is made continuous, with a one-line note. A jump
    that is not a whole turn off the rate's step (:data:`WRAP_TOLERANCE_RAD`) is left
    for the flight's check to refuse.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from aeroid.errors import FlightError
from aeroid.flights._channels import ACCELEROMETER_CHANNELS, CHANNELS
from aeroid.model import G0

__all__ = ["ChannelMap", "UNIT_FACTORS", "UNIT_KINDS", "UNIT_OFFSETS", "WRAP_TOLERANCE_RAD",
           "channel_map", "check_targets", "unwrap_angles"]

#: Factor to aeroid's (SI, radian) unit, and the kind of quantity, of each unit a column
#: map may name.
UNIT_FACTORS: dict[str, tuple[float, str]] = {
    "rad": (1.0, "angle"), "deg": (math.pi / 180.0, "angle"),
    "rad/s": (1.0, "rate"), "deg/s": (math.pi / 180.0, "rate"),
    "m/s^2": (1.0, "acceleration"), "g": (G0, "acceleration"),
    "m/s": (1.0, "speed"), "ft/s": (0.3048, "speed"), "kn": (1852.0 / 3600.0, "speed"),
    "m": (1.0, "length"), "ft": (0.3048, "length"),
    "s": (1.0, "time"), "ms": (1e-3, "time"),
    "kg": (1.0, "mass"), "lb": (0.45359237, "mass"),
    "N": (1.0, "force"), "lbf": (4.4482216152605, "force"),
    "Pa": (1.0, "pressure"), "kPa": (1e3, "pressure"), "psf": (47.88025898, "pressure"),
    "hPa": (1e2, "pressure"), "mbar": (1e2, "pressure"), "psi": (6894.757293168, "pressure"),
    "kg/m^3": (1.0, "density"), "slug/ft^3": (515.3788184, "density"),
    "kg m^2": (1.0, "inertia"), "slug ft^2": (1.3558179483, "inertia"),
    "K": (1.0, "temperature"), "degC": (1.0, "temperature"),
}
#: Units with an offset: aeroid's unit = value * factor + offset.
UNIT_OFFSETS: dict[str, float] = {"degC": 273.15}
#: A jump is taken for a wrap only when, less a whole turn, it agrees with the step of
#: the Euler rate within this [rad]: a glitch of another size stays a jump (and the
#: flight's check refuses it). The reference flight's rate-predicted steps agree with the
#: logged ones within 0.01 rad under the paper's noise (5 % of p, 2 ms samples).
WRAP_TOLERANCE_RAD = math.pi / 4
#: The kind of quantity of each channel (a unit of another kind is refused).
UNIT_KINDS: dict[str, str] = {
    "t": "time", **{c: "acceleration" for c in ACCELEROMETER_CHANNELS},
    "p": "rate", "q": "rate", "r": "rate",
    **{c: "angle" for c in ("delta", "alpha", "beta", "phi", "theta", "psi")},
    "u": "speed", "v": "speed", "w": "speed", "mass": "mass", "thrust": "force",
    "ix": "inertia", "iy": "inertia", "iz": "inertia", "rho": "density",
    "altitude": "length", "qbar": "pressure", "airspeed": "speed",
    "air_temperature": "temperature",
    "total_pressure": "pressure", "static_pressure": "pressure",  # a pitot-static probe's
}


class ChannelMap(dict):
    """``{name in the file: channel}`` (``""``: dropped) with :attr:`units` per column."""

    units: dict[str, str]

    def __init__(self, channels: Mapping[str, str], units: Mapping[str, str] | None = None):
        super().__init__(channels)
        self.units = dict(units or {})


def channel_map(table: Mapping[str, Any], where: str) -> ChannelMap:
    """Return the column map of a TOML table (module docstring), checked.

    Raises
    ------
    FlightError
        One line naming ``where``: a value that is neither a channel name nor a
        ``{channel, unit}`` table, an unknown channel or unit, a unit of the wrong kind,
        two columns sent to one channel.
    """
    channels: dict[str, str] = {}
    units: dict[str, str] = {}
    bad = []
    for name, value in table.items():
        if isinstance(value, str):
            channels[name] = value
        elif isinstance(value, Mapping) and set(value) <= {"channel", "unit"} \
                and isinstance(value.get("channel"), str) \
                and isinstance(value.get("unit", ""), str):
            channels[name] = value["channel"]
            if value.get("unit"):
                units[name] = value["unit"]
        else:
            bad.append(name)
    if bad:
        raise FlightError(f"{where}: column map values must be channel names (strings, \"\" "
                          f"to drop a column) or {{channel = \"p\", unit = \"deg/s\"}}; "
                          f"check {', '.join(map(repr, sorted(bad)))}")
    check_targets(channels, where)
    for name, unit in units.items():
        channel = channels[name]
        if unit not in UNIT_FACTORS:
            raise FlightError(f"{where}: column {name!r}: unknown unit {unit!r} "
                              f"(units: {', '.join(UNIT_FACTORS)})")
        if not channel:
            raise FlightError(f"{where}: column {name!r} is dropped (\"\") but has a unit")
        kind = UNIT_KINDS[channel]
        if UNIT_FACTORS[unit][1] != kind:
            fits = [u for u, (_, k) in UNIT_FACTORS.items() if k == kind]
            raise FlightError(f"{where}: column {name!r}: unit {unit!r} measures "
                              f"{UNIT_FACTORS[unit][1]}, channel {channel!r} is {kind} "
                              f"({', '.join(fits)})")
    return ChannelMap(channels, units)


def check_targets(columns: Mapping[str, str], where: str) -> None:
    """Refuse unknown channels and two columns sent to one channel (``""`` drops)."""
    unknown = sorted(set(columns.values()) - set(CHANNELS) - {""})
    if unknown:
        raise FlightError(f"{where}: column map names unknown channel(s) {unknown} "
                          f"(channels: {', '.join(CHANNELS)}; \"\" drops a column)")
    seen: dict[str, str] = {}
    for name, channel in columns.items():
        if not channel:
            continue
        if channel in seen:
            raise FlightError(f"{where}: column map sends both {seen[channel]!r} and {name!r} "
                              f"to channel {channel!r}")
        seen[channel] = name


def _euler_rates(values: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """phidot and psidot [rad/s] from p, q, r, phi, theta (eq. 8), where all are given."""
    need = ("p", "q", "r", "phi", "theta")
    if not all(n in values for n in need):
        return {}
    p, q, r, phi, theta = (values[n] for n in need)
    with np.errstate(all="ignore"):
        lateral = q * np.sin(phi) + r * np.cos(phi)
        return {"phi": p + lateral * np.tan(theta), "psi": lateral / np.cos(theta)}


def unwrap_angles(values: dict[str, np.ndarray], t: np.ndarray) -> list[str]:
    """Make a wrapped ``phi`` or ``psi`` continuous in place where the rates resolve it.

    Returns one note per angle unwrapped (empty when none was wrapped or the rates do not
    resolve it: the flight's check then refuses the jump, naming its row).
    """
    notes: list[str] = []
    if t.size < 2:
        return notes
    for name in ("phi", "psi"):
        if name not in values:
            continue
        angle = values[name]
        step = np.diff(angle)
        if not np.any(np.abs(step) > math.pi):
            continue
        rates = _euler_rates({**values, name: angle})  # with the wrapped angle: sin/cos agree
        if name not in rates:
            continue
        rate = rates[name]
        dt = np.diff(t)
        predicted = 0.5 * (rate[:-1] + rate[1:]) * dt
        if not (np.all(np.isfinite(predicted)) and np.all(np.isfinite(step))) \
                or np.max(np.abs(predicted)) >= math.pi:
            continue
        turns = np.round((predicted - step) / (2.0 * math.pi))
        wrapped = turns != 0
        if not np.any(wrapped):
            continue
        miss = np.abs(step + 2.0 * math.pi * turns - predicted)[wrapped]
        if np.max(miss) > WRAP_TOLERANCE_RAD:
            continue  # a jump that is not a turn (a glitch): the check refuses it
        values[name] = angle + 2.0 * math.pi * np.concatenate([[0.0], np.cumsum(turns)])
        largest = float(np.max(np.abs(predicted)))
        notes.append(f"{name} was wrapped: unwrapped {int(np.sum(turns != 0))} jump(s) of a "
                     f"turn (its rate from p, q, r moves it at most {largest:.3g} rad per "
                     f"sample, < pi)")
    return notes
