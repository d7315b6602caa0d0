"""Sensors as mounted: the rotation from a sensor's axes to the body's, its position, its range.

A flight computer's IMU logs in the board's axes (the long axis often along -Y or +Z),
not the airframe's. The ``imu`` group of a suite log may say how it is mounted::

    [groups.imu.mounting]
    axes = "x=-y, y=x, z=z"      # body x reads the sensor's -y, body y its x, body z its z
    # or: axes = { x = "-y", y = "x", z = "z" }
    # or: angles_deg = [roll, pitch, yaw]  (3-2-1: see below)
    # or: matrix = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]   (body = matrix @ sensor)
    accel1_position_m = [0.60, 0.0, 0.0]   # optional, body axes from the c.g. [m]
    accel2_position_m = [-0.59, 0.0, 0.0]

    [groups.imu]
    accel_range = 160.0          # m/s^2: |reading| at or beyond it is saturated
    gyro_range = 34.9            # rad/s

With a mounting, the column map's channels are the *sensor's* axes (``ax1`` its x axis,
``p`` its rate about x); on reading they become the body's: ``v_body = C v_sensor`` for
each triad and for the gyros alike, ``C`` the rotation from sensor to body axes.

Angles: ``angles_deg = [roll, pitch, yaw]`` are the 3-2-1 (z-y-x) Euler angles of the
sensor axes relative to the body axes, the convention of aeroid's attitude (the body
relative to NED): from the body axes, yaw about z, then pitch about the new y, then roll
about the new x gives the sensor axes, and ``C = body_to_ned(roll, pitch, yaw)``.

A rotation that is not proper (an axis used twice or missing, not orthonormal, a
determinant of -1: a mirrored axis, which no mounting can produce) is refused with one
line naming the file and group. A body axis is computed when every sensor axis it draws
on is logged (an axial accelerometer alone: body ``ax1`` from the one sensor axis the
mounting maps onto it); a logged sensor channel that enters no computed body axis is
refused. The noise sd of a body channel is that of its sensor axes, combined as
independent noises (``sqrt(sum C_ij^2 sd_j^2)``).

Range: a sample whose reading on a sensor axis is at or beyond the stated range (the
full scale, where a real IMU clips) is *saturated*; every body channel that draws on that
axis is saturated at that sample (:attr:`SensorGroup.saturated`). Saturated samples leave
the likelihood of the estimators that honour them (output-error, EKF/UKF); in a
:class:`~aeroid.flights.Flight` they are ``metadata["saturated"]``: channel -> sample
indices (:func:`used_samples`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from aeroid.errors import FlightError
from aeroid.flights._frames import body_to_ned

#: The IMU's triads: (sensor-axis channel of x, y, z) each, rotated alike.
TRIADS: tuple[tuple[str, str, str], ...] = (("ax1", "ay1", "az1"), ("ax2", "ay2", "az2"),
                                            ("p", "q", "r"))
#: The range keys of a group and the channels each bounds.
RANGE_KEYS: dict[str, tuple[str, ...]] = {"accel_range": TRIADS[0] + TRIADS[1],
                                          "gyro_range": TRIADS[2]}
#: The keys of a mounting table.
MOUNTING_KEYS = ("axes", "angles_deg", "matrix", "accel1_position_m", "accel2_position_m")
#: A rotation is proper when ``|C^T C - I|`` and ``|det C - 1|`` are below this (a matrix
#: written with 9 significant digits, as from a CAD tool, passes; a 1e-3 error does not).
ORTHONORMAL_TOL = 1e-6
#: Entries of ``C`` smaller than this in magnitude draw on no sensor axis (rounding of
#: angles that are multiples of 90 degrees leaves ~1e-16).
ZERO_ENTRY = 1e-12
_AXES = "xyz"


@dataclass(frozen=True)
class Mounting:
    """How a sensor group is mounted.

    Attributes
    ----------
    rotation : ndarray, shape (3, 3)
        ``C``, from sensor to body axes: ``v_body = C @ v_sensor``.
    description : str
        How it was given, for the one-line notice (``axes x=-y, y=x, z=z``).
    positions_m : ndarray, shape (2, 3), optional
        Both triads' positions from the c.g. in body axes [m].
    given : (key, value), optional
        The rotation as the file gave it (``("axes", "x=-y, y=x, z=z")``), written back.
    """

    rotation: np.ndarray
    description: str
    positions_m: np.ndarray | None = None
    given: tuple[str, Any] | None = None

    def to_table(self) -> dict[str, Any]:
        """The TOML form (the rotation as given, else a ``matrix``; the positions)."""
        key, value = self.given or ("matrix", self.rotation.tolist())
        out: dict[str, Any] = {key: value}
        if self.positions_m is not None:
            out["accel1_position_m"] = self.positions_m[0].tolist()
            out["accel2_position_m"] = self.positions_m[1].tolist()
        return out


def axis_map(text: str | Mapping[str, Any], where: str = "mounting") -> Mounting:
    """Return the mounting of an axis map: ``"x=-y, y=x, z=z"`` or ``{x = "-y", ...}``.

    Each body axis names the sensor axis it reads, with an optional sign.

    Raises
    ------
    FlightError
        One line: a form that is not ``body=±sensor`` three times, an axis used twice or
        missing, a mirrored (left-handed) map.
    """
    if isinstance(text, str):
        pairs: dict[str, Any] = {}
        for part in text.split(","):
            match = re.fullmatch(r"\s*([xyz])\s*=\s*([+-]?\s*[xyz])\s*", part)
            if not match:
                raise FlightError(f"{where}: axes {text!r}: each part must be body=sensor "
                                  "such as x=-y (axes x, y, z; comma-separated)")
            if match.group(1) in pairs:
                raise FlightError(f"{where}: axes {text!r}: body axis {match.group(1)} "
                                  "given twice")
            pairs[match.group(1)] = match.group(2).replace(" ", "")
    elif isinstance(text, Mapping):
        pairs = dict(text)
    else:
        raise FlightError(f"{where}: axes must be a string \"x=-y, y=x, z=z\" or a table "
                          f"x = \"-y\" ..., got {text!r}")
    if sorted(pairs) != list(_AXES):
        raise FlightError(f"{where}: axes must give each body axis x, y, z once, got "
                          f"{', '.join(map(str, pairs)) or 'none'}")
    rotation = np.zeros((3, 3))
    for body, sensor in pairs.items():
        if not isinstance(sensor, str) or not re.fullmatch(r"[+-]?[xyz]", sensor):
            raise FlightError(f"{where}: axes.{body} must be a sensor axis such as \"-y\", "
                              f"got {sensor!r}")
        rotation[_AXES.index(body), _AXES.index(sensor[-1])] = -1.0 if sensor[0] == "-" else 1.0
    used = [s[-1] for s in pairs.values()]
    twice = sorted({a for a in used if used.count(a) > 1})
    if twice:
        raise FlightError(f"{where}: axes: sensor axis {', '.join(twice)} used twice (not a "
                          "rotation)")
    text = ", ".join(f"{b}={pairs[b]}" for b in _AXES)
    return Mounting(_proper(rotation, where, "axes " + text), "axes " + text, None,
                    ("axes", text))


def euler_mounting(angles_deg: Any, where: str = "mounting") -> Mounting:
    """Return the mounting of 3-2-1 angles ``[roll, pitch, yaw]`` [deg] (module docstring)."""
    values = _numbers(angles_deg, 3, where, "angles_deg")
    roll, pitch, yaw = np.radians(values)
    # the body_to_ned matrix of aeroid's attitude, here of the sensor relative to the body
    rotation = np.array(body_to_ned(roll, pitch, yaw), dtype=float)
    rotation[np.abs(rotation) < ZERO_ENTRY] = 0.0
    description = (f"3-2-1 angles roll {values[0]:g}, pitch {values[1]:g}, yaw {values[2]:g} "
                   "deg (sensor axes from body axes: yaw about z, pitch about the new y, "
                   "roll about the new x)")
    return Mounting(rotation, description, None, ("angles_deg", values.tolist()))


def matrix_mounting(matrix: Any, where: str = "mounting") -> Mounting:
    """Return the mounting of a 3 x 3 matrix ``C`` (``v_body = C v_sensor``), if proper."""
    if not (isinstance(matrix, list | tuple | np.ndarray) and len(matrix) == 3):
        raise FlightError(f"{where}: matrix must be 3 rows of 3 numbers, got {matrix!r}")
    rotation = np.array([_numbers(row, 3, where, "matrix row") for row in matrix])
    description = "matrix " + "; ".join(" ".join(f"{v:g}" for v in row) for row in rotation)
    return Mounting(_proper(rotation, where, description), description)


def board_mounting(axes: str, angles_deg: Any, where: str) -> Mounting | None:
    """Return the mounting of an axis map or of 3-2-1 angles (one of them, or None)."""
    if axes and len(angles_deg):
        raise FlightError(f"{where}: give an axis map or angles, not both")
    if axes:
        return axis_map(axes, where)
    return euler_mounting(list(angles_deg), where) if len(angles_deg) else None


def _numbers(values: Any, n: int, where: str, name: str) -> np.ndarray:
    ok = (isinstance(values, list | tuple | np.ndarray) and len(values) == n
          and all(isinstance(v, int | float | np.floating) and not isinstance(v, bool)
                  and math.isfinite(v) for v in values))
    if not ok:
        raise FlightError(f"{where}: {name} must be {n} finite numbers, got {values!r}")
    return np.array(values, dtype=float)


def _proper(rotation: np.ndarray, where: str, description: str) -> np.ndarray:
    """Return ``rotation`` when it is a proper rotation, else raise one line."""
    error = float(np.max(np.abs(rotation.T @ rotation - np.eye(3))))
    if error > ORTHONORMAL_TOL:
        raise FlightError(f"{where}: {description} is not a rotation (not orthonormal: "
                          f"|C^T C - I| = {error:.3g})")
    det = float(np.linalg.det(rotation))
    if abs(det - 1.0) > ORTHONORMAL_TOL:
        raise FlightError(f"{where}: {description} is not a proper rotation (determinant "
                          f"{det:+.3g}: one axis mirrored; check the signs)")
    return rotation


def read_mounting(table: Any, where: str) -> Mounting:
    """Return the mounting of a ``[groups.imu.mounting]`` table (module docstring)."""
    if not isinstance(table, Mapping):
        raise FlightError(f"{where}.mounting must be a table")
    extra = sorted(set(table) - set(MOUNTING_KEYS))
    if extra:
        raise FlightError(f"{where}.mounting: unknown key(s) {', '.join(extra)} (known: "
                          f"{', '.join(MOUNTING_KEYS)})")
    forms = [k for k in ("axes", "angles_deg", "matrix") if k in table]
    if len(forms) != 1:
        raise FlightError(f"{where}.mounting: give the rotation once, as one of axes, "
                          f"angles_deg or matrix (got {', '.join(forms) or 'none'})")
    form = forms[0]
    read = {"axes": axis_map, "angles_deg": euler_mounting, "matrix": matrix_mounting}[form]
    mounting = read(table[form], f"{where}.mounting")
    given = [k for k in ("accel1_position_m", "accel2_position_m") if k in table]
    if given and len(given) != 2:
        raise FlightError(f"{where}.mounting: give both accel1_position_m and "
                          "accel2_position_m (the model has two triads), or neither")
    if given:
        positions = np.array([_numbers(table[k], 3, f"{where}.mounting", k) for k in given])
        if np.linalg.norm(positions[0] - positions[1]) == 0.0:
            raise FlightError(f"{where}.mounting: the two triads' positions must differ")
        mounting = Mounting(mounting.rotation, mounting.description, positions,
                            mounting.given)
    return mounting


def read_ranges(table: Mapping[str, Any], where: str) -> dict[str, float]:
    """Return the group's stated ranges (``accel_range`` [m/s^2], ``gyro_range`` [rad/s])."""
    ranges = {}
    for key in RANGE_KEYS:
        if key in table:
            value = table[key]
            if (not isinstance(value, int | float) or isinstance(value, bool)
                    or not math.isfinite(value) or not value > 0):
                raise FlightError(f"{where}: {key} must be a positive number (SI: m/s^2 "
                                  f"for accel_range, rad/s for gyro_range), got {value!r}")
            ranges[key] = float(value)
    return ranges


@dataclass(frozen=True)
class Mounted:
    """A group's channels taken from sensor to body axes (:func:`mount`)."""

    channels: dict[str, np.ndarray]
    noise_sd: dict[str, float]
    saturated: dict[str, np.ndarray]
    notes: tuple[str, ...]


def mount(sensor: Mapping[str, np.ndarray], noise_sd: Mapping[str, float],
          mounting: Mounting | None, ranges: Mapping[str, float], where: str) -> Mounted:
    """Return the body-axis channels, noise sd and saturation masks of sensor readings.

    Parameters
    ----------
    sensor : mapping of str to ndarray, shape (n,)
        The logged channels in sensor axes (SI).
    noise_sd : mapping of str to float
        Their white-noise sd (SI).
    mounting : Mounting, optional
        None: the sensor's axes are the body's.
    ranges : mapping
        ``accel_range`` [m/s^2] and ``gyro_range`` [rad/s], optional each.
    where : str
        The file and group, for messages.

    Raises
    ------
    FlightError
        One line: a logged sensor channel that enters no body axis (the axes it shares a
        body axis with are not logged).
    """
    rotation = np.eye(3) if mounting is None else mounting.rotation
    n = len(next(iter(sensor.values()))) if sensor else 0
    clipped = {c: np.zeros(n, dtype=bool) for c in sensor}
    for key, limit in ranges.items():
        for c in RANGE_KEYS[key]:
            if c in sensor:
                clipped[c] = np.abs(sensor[c]) >= limit
    channels: dict[str, np.ndarray] = {}
    sd: dict[str, float] = {}
    saturated: dict[str, np.ndarray] = {}
    entered: set[str] = set()
    for triad in TRIADS:
        for i, body in enumerate(triad):
            uses = [triad[j] for j in range(3) if abs(rotation[i, j]) > ZERO_ENTRY]
            if not all(c in sensor for c in uses):
                continue
            entered.update(uses)
            channels[body] = sum((rotation[i, triad.index(c)] * sensor[c] for c in uses),
                                 start=np.zeros(n))
            if all(c in noise_sd for c in uses):
                sd[body] = float(math.sqrt(sum((rotation[i, triad.index(c)] * noise_sd[c]) ** 2
                                               for c in uses)))
            if any(c in RANGE_KEYS_OF and RANGE_KEYS_OF[c] in ranges for c in uses):
                saturated[body] = np.logical_or.reduce([clipped[c] for c in uses])
    others = [c for c in sensor if c not in RANGE_KEYS_OF]
    for c in others:  # not an IMU axis: as logged
        channels[c] = np.asarray(sensor[c], dtype=float)
        if c in noise_sd:
            sd[c] = float(noise_sd[c])
    unused = [c for c in sensor if c in RANGE_KEYS_OF and c not in entered]
    if unused:
        raise FlightError(f"{where}: sensor channel(s) {', '.join(unused)} enter no body axis "
                          "whose sensor axes are all logged (log the triad's other axes, or "
                          "drop the column)")
    notes = []
    if mounting is not None:
        rows = "; ".join(" ".join(f"{v:+.6g}" for v in row) for row in rotation)
        notes.append(f"{where}: mounted: {mounting.description} (sensor to body C = [{rows}])"
                     " applied to accelerometers and gyros")
    for key, limit in ranges.items():
        counts = {c: int(m.sum()) for c, m in saturated.items() if c in RANGE_KEYS[key]}
        counts = {c: k for c, k in counts.items() if k}
        notes.append(f"{where}: {key} {limit:g}: "
                     + (", ".join(f"{c} {k}" for c, k in counts.items())
                        + " sample(s) saturated, left out of the likelihood"
                        if counts else "no sample saturated"))
    return Mounted(channels, sd, saturated, tuple(notes))


#: Each IMU axis channel and its range key.
RANGE_KEYS_OF: dict[str, str] = {c: key for key, cs in RANGE_KEYS.items() for c in cs}


def unmount(channels: Mapping[str, np.ndarray], mounting: Mounting | None
            ) -> dict[str, np.ndarray]:
    """Return body-axis IMU channels in the sensor's axes (``C^T v``; complete triads)."""
    if mounting is None:
        return dict(channels)
    out = {c: v for c, v in channels.items() if c not in RANGE_KEYS_OF}
    for triad in TRIADS:
        if all(c in channels for c in triad):
            body = np.stack([channels[c] for c in triad])
            sensor = mounting.rotation.T @ body
            out.update({c: sensor[j] for j, c in enumerate(triad)})
        elif any(c in channels for c in triad):
            raise FlightError(f"cannot write a mounted triad {', '.join(triad)} without all "
                              "three axes")
    return out


def used_samples(metadata: Mapping[str, Any], channels: tuple[str, ...], n: int
                 ) -> np.ndarray | None:
    """Return the mask of samples in the likelihood (n, len(channels)), or None (all).

    From a flight's ``metadata["saturated"]``: channel -> indices of saturated samples.

    Raises
    ------
    FlightError
        One line: entries that are not sample indices of the flight.
    """
    given = metadata.get("saturated")
    if not given:
        return None
    mask = np.ones((n, len(channels)), dtype=bool)
    for c, indices in dict(given).items():
        k = np.asarray(indices)
        if k.size and (k.dtype.kind not in "iu" or k.min() < 0 or k.max() >= n):
            raise FlightError(f"metadata saturated.{c}: not sample indices of the "
                              f"{n}-sample flight")
        if c not in channels:
            raise FlightError(f"metadata saturated.{c}: not one of the channels fitted "
                              f"({', '.join(channels)})")
        mask[k.astype(int), channels.index(c)] = False
    return None if mask.all() else mask
