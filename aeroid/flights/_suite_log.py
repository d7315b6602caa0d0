"""Multi-rate sensor-suite logs: one CSV per sensor group, described by a log TOML.

A flight-test logger writes each sensor group at its own rate with its own clock. A
suite log keeps them apart (nothing is resampled here): the log file names, per group,
its CSV file, its time column and unit, a time offset, and a column map with units::

    [log]
    airframe = "airframe.toml"          # relative to this file (optional)

    [groups.imu]
    file = "flight-imu.csv"             # relative to this file
    time = ["time_ms", "ms"]            # column and unit of the group's clock
    offset_s = 0.0                      # true time = logged time + offset_s
    [groups.imu.columns]                # aeroid channel = [column, unit]
    ax1 = ["ax1", "m/s^2"]
    p = ["gyro_x", "deg/s"]
    [groups.imu.noise_sd]               # white-noise sd per sample, SI (optional)
    ax1 = 0.05

The groups and their channels are :data:`GROUPS` (``imu``: two accelerometer triads and
three gyros, body axes; ``gnss``: NED velocity and position from the origin, flat
Earth; ``baro``: pressure altitude, or static pressure (Pa, hPa, mbar, psi) and a
temperature (K, degC; the air's, or ``temperature = "board"``: :mod:`._flight_computer`);
``ins``: Euler attitude, possibly wrapped; ``fin``: fin deflection; ``air``: a probe's
alpha, beta and airspeed, or its total and static pressures, with ``probe_position_m``:
:mod:`._suite_air`). The ``imu`` group may
state its mounting (a ``[groups.imu.mounting]`` table: the rotation from the sensor's
axes to the body's and the triads' positions) and its range (``accel_range`` [m/s^2],
``gyro_range`` [rad/s]): :mod:`._mounting`; the mounting is applied on reading, so the
groups hold body axes, and the one-line notices (``SuiteLog.metadata["notes"]``) say what
was applied and how many samples saturated. Units are converted to SI (radians) on
reading (:data:`UNITS`). An optional ``[truth]`` table of numbers and lists (a
simulator's sensor errors) is kept as metadata. Every bad input is a one-line
:class:`~aeroid.errors.FlightError` naming the file and column.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from aeroid.errors import AeroidError, FlightError
from aeroid.flights._columns import UNIT_FACTORS
from aeroid.flights._flight_computer import BARO_KEYS, read_temperature_source
from aeroid.flights._mounting import (
    RANGE_KEYS,
    Mounting,
    mount,
    read_mounting,
    read_ranges,
)
from aeroid.flights._suite_air_read import AIR_KEYS, check_air_group, read_probe_position
from aeroid.model import Airframe, load_airframe, read_toml

#: The sensor groups and their channels (SI units inside aeroid; NED from the origin).
GROUPS: dict[str, tuple[str, ...]] = {
    "imu": ("ax1", "ay1", "az1", "ax2", "ay2", "az2", "p", "q", "r"),
    "gnss": ("vn", "ve", "vd", "pn", "pe", "pd"),
    "baro": ("altitude", "pressure", "temperature"),
    "ins": ("phi", "theta", "psi"),
    "fin": ("delta",),
    # air: a probe's air data, or a pitot-static probe's pressures (:mod:`._suite_air`)
    "air": ("alpha", "beta", "airspeed", "total_pressure", "static_pressure"),
}
#: The SI unit of each channel.
SI_UNITS: dict[str, str] = {
    **{c: "m/s^2" for c in GROUPS["imu"][:6]}, "p": "rad/s", "q": "rad/s", "r": "rad/s",
    "vn": "m/s", "ve": "m/s", "vd": "m/s", "pn": "m", "pe": "m", "pd": "m", "altitude": "m",
    "pressure": "Pa", "temperature": "K", "alpha": "rad", "beta": "rad", "airspeed": "m/s",
    "phi": "rad", "theta": "rad", "psi": "rad", "delta": "rad",
    "total_pressure": "Pa", "static_pressure": "Pa",
}
#: The SI unit of each kind of quantity a suite log carries.
_SI_OF_KIND = {"acceleration": "m/s^2", "rate": "rad/s", "speed": "m/s", "length": "m",
               "angle": "rad", "time": "s", "pressure": "Pa", "temperature": "K"}
#: Units of a barometer beyond the column maps' (1 psi = 1 lbf / in^2).
_BARO_UNITS = {"hPa": (100.0, "pressure"), "mbar": (100.0, "pressure"),
               "psi": (4.4482216152605 / 0.0254**2, "pressure"),
               "K": (1.0, "temperature"), "degC": (1.0, "temperature")}
#: Units a file may use: {unit: (SI unit, factor to SI)}: the column maps' units of those
#: kinds (one table, :data:`aeroid.flights._columns.UNIT_FACTORS`), microseconds and the
#: barometer's units.
UNITS: dict[str, tuple[str, float]] = {
    unit: (_SI_OF_KIND[kind], factor)
    for unit, (factor, kind) in {**UNIT_FACTORS, "us": (1e-6, "time"), **_BARO_UNITS}.items()
    if kind in _SI_OF_KIND}
#: Units with an offset: SI = value * factor + offset.
UNIT_OFFSETS: dict[str, float] = {"degC": 273.15}
_GROUP_KEYS = ("file", "time", "offset_s", "columns", "noise_sd")
#: Keys only the ``imu`` group takes (:mod:`._mounting`).
_IMU_KEYS = ("mounting", *RANGE_KEYS)


@dataclass(frozen=True)
class SensorGroup:
    """One sensor group of a suite log, in SI units on the true time axis.

    Attributes
    ----------
    name : str
        A key of :data:`GROUPS`.
    t : ndarray, shape (n,)
        Sample times [s], strictly increasing, offset applied.
    channels : dict of str to ndarray, shape (n,)
        The group's channels present in the log (SI, :data:`SI_UNITS`).
    noise_sd : dict of str to float
        White-noise sd per sample of the channels that state one (SI).
    offset_s : float
        The offset added to the logged times [s].
    source : str
        Where the group came from (file name), for messages.
    mounting : Mounting, optional
        The rotation from the sensor's axes to the body's (already applied to
        ``channels``) and the triads' positions; None: sensor axes are body axes.
    ranges : dict of str to float
        ``accel_range`` [m/s^2] and ``gyro_range`` [rad/s] where stated.
    saturated : dict of str to ndarray of bool, shape (n,)
        Per body channel under a stated range: True where a sensor axis it draws on read
        at or beyond the range.
    sensor_channels : dict of str to ndarray, shape (n,)
        The readings as logged, in the sensor's axes (SI), when mounted; written back by
        :func:`write_suite_log`.
    notes : tuple of str
        One line each: the mounting applied, the samples saturated per range.
    temperature_of : {"air", "board"}
        What a baro group's ``temperature`` measures (:mod:`._flight_computer`).
    probe_position_m : (x, y, z), optional
        An air group's probe position, body axes from the c.g. [m] (None: not stated).
    """

    name: str
    t: np.ndarray
    channels: dict[str, np.ndarray]
    noise_sd: dict[str, float] = field(default_factory=dict)
    offset_s: float = 0.0
    source: str = "suite log"
    mounting: Mounting | None = None
    ranges: dict[str, float] = field(default_factory=dict)
    saturated: dict[str, np.ndarray] = field(default_factory=dict)
    sensor_channels: dict[str, np.ndarray] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    temperature_of: str = "air"
    probe_position_m: tuple[float, float, float] | None = None

    @property
    def n_saturated(self) -> int:
        """Number of (sample, body channel) entries saturated."""
        return int(sum(int(m.sum()) for m in self.saturated.values()))

    @property
    def rate_hz(self) -> float:
        """Mean sample rate [Hz]."""
        return (len(self.t) - 1) / float(self.t[-1] - self.t[0]) if len(self.t) > 1 else 0.0


@dataclass(frozen=True)
class SuiteLog:
    """A multi-rate sensor-suite log: groups by name, the airframe, metadata."""

    groups: dict[str, SensorGroup]
    airframe: Airframe | None = None
    metadata: dict[str, Any] = field(default_factory=dict)
    source: str = "suite log"

    def __contains__(self, name: str) -> bool:
        return name in self.groups

    def __getitem__(self, name: str) -> SensorGroup:
        if name not in self.groups:
            raise FlightError(f"{self.source}: no {name!r} group (has "
                              f"{', '.join(self.groups) or 'none'})")
        return self.groups[name]


# Reading ------------------------------------------------------------------------------
def read_suite_log(path: str | Path) -> SuiteLog:
    """Read a suite log TOML and its CSV files (module docstring).

    Raises
    ------
    FlightError
        One line naming the file (and column): a missing file, an unknown group, channel
        or unit, a unit of the wrong kind, a missing time or data column, a time column
        that is not strictly increasing, a value that is not a finite number.
    """
    path = Path(path)
    try:
        data = read_toml(path)
    except AeroidError as exc:
        raise FlightError(str(exc)) from None
    unknown = sorted(set(data) - {"log", "groups", "truth"})
    if unknown:
        raise FlightError(f"{path}: unknown table(s) {', '.join(unknown)} "
                          "(allowed: log, groups, truth)")
    groups_table = data.get("groups")
    if not isinstance(groups_table, Mapping) or not groups_table:
        raise FlightError(f"{path}: no [groups.NAME] table (groups: {', '.join(GROUPS)})")
    groups = {name: _read_group(path, name, table) for name, table in groups_table.items()}
    log = data.get("log", {})
    airframe = None
    if not isinstance(log, Mapping) or sorted(set(log) - {"airframe"}):
        raise FlightError(f"{path}: [log] takes only airframe = \"FILE\"")
    if "airframe" in log:
        airframe_path = path.parent / str(log["airframe"])
        if not airframe_path.is_file():
            raise FlightError(f"{path}: airframe file {airframe_path} does not exist")
        try:
            airframe = load_airframe(airframe_path)
        except AeroidError as exc:
            raise FlightError(str(exc)) from None
    truth = data.get("truth", {})
    notes = [note for g in groups.values() for note in g.notes]
    return SuiteLog(groups, airframe, {"truth": dict(truth), "source": str(path),
                                       "notes": notes}, str(path))


def _read_group(path: Path, name: str, table: Any) -> SensorGroup:
    where = f"{path}: [groups.{name}]"
    if name not in GROUPS:
        raise FlightError(f"{where}: unknown group {name!r} (known: {', '.join(GROUPS)})")
    if not isinstance(table, Mapping):
        raise FlightError(f"{where} must be a table")
    extra = sorted(set(table) - set(_GROUP_KEYS) - set(_IMU_KEYS if name == "imu" else ())
                   - set(BARO_KEYS if name == "baro" else ()) - set(AIR_KEYS * (name == "air")))
    if name != "imu" and set(table) & set(_IMU_KEYS):
        raise FlightError(f"{where}: {', '.join(sorted(set(table) & set(_IMU_KEYS)))} "
                          "only in [groups.imu] (the other groups' values are not in a "
                          "sensor's axes: NED, pressure, angles)")
    missing = [k for k in ("file", "time", "columns") if k not in table]
    if extra or missing:
        raise FlightError(f"{where}: " + (f"unknown key(s) {', '.join(extra)}" if extra else
                                          f"missing {', '.join(missing)}"))
    file = path.parent / str(table["file"])
    if not file.is_file():
        raise FlightError(f"{where}: file {file} does not exist")
    time_col, time_unit = _column_spec(table["time"], f"{where} time")
    _factor(time_unit, "s", f"{file}: column {time_col!r}")
    columns = table["columns"]
    if not isinstance(columns, Mapping) or not columns:
        raise FlightError(f"{where}.columns must map channels to [column, unit]")
    specs = {}
    for channel, spec in columns.items():
        if channel not in GROUPS[name]:
            raise FlightError(f"{where}.columns: unknown channel {channel!r} for group "
                              f"{name!r} (known: {', '.join(GROUPS[name])})")
        specs[channel] = _column_spec(spec, f"{where}.columns.{channel}")
    offset = table.get("offset_s", 0.0)
    if not isinstance(offset, int | float) or isinstance(offset, bool) or not math.isfinite(offset):
        raise FlightError(f"{where}: offset_s must be a finite number of seconds")
    try:
        frame = pd.read_csv(file)
    except (ValueError, OSError) as exc:  # pandas' parser errors are ValueErrors
        raise FlightError(f"{file}: cannot read CSV ({' '.join(str(exc).split())})") from None
    t = _numbers(frame, file, time_col) * _factor(time_unit, "s", f"{file}: column {time_col!r}")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        raise FlightError(f"{file}: column {time_col!r}: time not strictly increasing at line "
                          f"{bad[0] + 3} of the file ({t[bad[0]]:.9g} then {t[bad[0] + 1]:.9g} s)")
    channels = {}
    for channel, (column, unit) in specs.items():
        factor = _factor(unit, SI_UNITS[channel], f"{file}: column {column!r}")
        channels[channel] = _numbers(frame, file, column) * factor + UNIT_OFFSETS.get(unit, 0.0)
    noise = table.get("noise_sd", {})
    if not isinstance(noise, Mapping):
        raise FlightError(f"{where}.noise_sd must be a table of channel = sd")
    noise_sd = {}
    for channel, sd in noise.items():
        if channel not in channels:
            raise FlightError(f"{where}.noise_sd: {channel!r} is not a channel of this group")
        if not isinstance(sd, int | float) or isinstance(sd, bool) or not sd > 0:
            raise FlightError(f"{where}.noise_sd.{channel} must be a positive number (SI)")
        noise_sd[channel] = float(sd)
    mounting = read_mounting(table["mounting"], where) if "mounting" in table else None
    group = mounted_group(name, t + float(offset), channels, noise_sd, float(offset),
                          str(file), mounting, read_ranges(table, where))
    if name == "air":
        check_air_group(channels, f"{file}")
    return dataclasses.replace(group, temperature_of=read_temperature_source(
        table if name == "baro" else {}, channels, where), probe_position_m=(
            read_probe_position(table, where) if name == "air" else None))


def mounted_group(name: str, t: np.ndarray, sensor: dict[str, np.ndarray],
                  noise_sd: dict[str, float], offset_s: float, source: str,
                  mounting: Mounting | None = None, ranges: dict[str, float] | None = None
                  ) -> SensorGroup:
    """Return a group from readings in the sensor's axes: mounted, ranges applied.

    The channels become the body's (:func:`aeroid.flights._mounting.mount`); the readings
    as logged stay in ``sensor_channels`` when mounted.
    """
    ranges = dict(ranges or {})
    if mounting is None and not ranges:
        return SensorGroup(name, t, dict(sensor), dict(noise_sd), offset_s, source)
    body = mount(sensor, noise_sd, mounting, ranges, source)
    return SensorGroup(name, t, body.channels, body.noise_sd, offset_s, source, mounting,
                       ranges, body.saturated, dict(sensor) if mounting is not None else {},
                       body.notes)


def _column_spec(spec: Any, where: str) -> tuple[str, str]:
    if (not isinstance(spec, list) or len(spec) != 2
            or not all(isinstance(s, str) for s in spec)):
        raise FlightError(f"{where} must be [\"column\", \"unit\"], got {spec!r}")
    return spec[0], spec[1]


def _factor(unit: str, si: str, where: str) -> float:
    if unit not in UNITS:
        raise FlightError(f"{where}: unknown unit {unit!r} (known: {', '.join(UNITS)})")
    kind, factor = UNITS[unit]
    if kind != si:
        raise FlightError(f"{where}: unit {unit!r} is not a unit of {si}")
    return factor


def _numbers(frame: pd.DataFrame, file: Path, column: str) -> np.ndarray:
    if column not in frame.columns:
        raise FlightError(f"{file}: no column {column!r} (columns: "
                          f"{', '.join(map(str, frame.columns))})")
    values = pd.to_numeric(frame[column], errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise FlightError(f"{file}: column {column!r}: not a finite number at line {bad[0] + 2} "
                          f"({frame[column].iloc[bad[0]]!r})")
    return values
