"""Coefficients as piecewise-linear tables in Mach number, written once.

A tabled coefficient is ``C(M) = sum_i B_i(M) c_i``: its values ``c_i`` at the knots
``M_1 < ... < M_k`` (the table points, parameters of a fit named like ``Cx@M1.4``)
times the hat functions ``B_i`` of those knots, each 1 at its own knot, 0 at the others
and linear between. Beyond the end knots the end values hold (the end hats are clipped
at 1), so the basis sums to 1 everywhere and reproduces any function linear in Mach
between the end knots exactly.

Like :mod:`aeroid.model._equations`, everything that maps a table to coefficient values
is element-wise (arithmetic, ``np.minimum``, ``np.maximum``, ``np.sqrt``), so numpy
evaluates it on arrays and CasADi on symbols (numpy's element-wise functions dispatch to
CasADi in its numpy mode): the output-error graph differentiates exactly the table the
simulator integrates. :func:`basis` stacks the hats into an ``(n, k)`` array for numpy.

A fit with tables estimates the parameter vector :meth:`MachTables.parameter_names`:
the coefficients in :data:`aeroid.model.NAMES` order, each tabled one replaced by its
table points. Mach is ``V_T / a`` with ``V_T`` from the body velocities (no wind, as in
the model) and the speed of sound ``a = sqrt(gamma R T)``
(:func:`aeroid.model.speed_of_sound_at`, the one definition): a constant of the flight
(ISA at the airframe's altitude, or ``[tables] temperature_K``), or, with
``per_sample_temperature``, from the air temperature of each sample and RK4 stage (the
model's exogenous input ``temperature``, a logged ``air_temperature`` channel).

A coefficient can instead be a table in the total angle of attack (``angle_knots``
[rad], points named ``Cma@A4deg``: :mod:`aeroid.model._alpha_tables` says why the total
angle); a fit may have Mach tables and angle tables of different coefficients. The hat
basis and the knot checks are :mod:`aeroid.model._table_basis`'s.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from aeroid.errors import AirframeError
from aeroid.model import _alpha_tables as angle
from aeroid.model import _atmosphere as atmosphere
from aeroid.model import _equations as eq
from aeroid.model._alpha_tables import (
    ANGLE_SEPARATOR,
    choose_angle_knots,
    split_point,
    total_angle,
)
from aeroid.model._coefficients import NAMES
from aeroid.model._table_basis import (
    KNOT_RANGE,
    MIN_KNOT_SPACING,
    basis,
    check_knots,
    choose_knots,
    hat,
    table_value,
)
from aeroid.model._table_file import angle_entry, given_temperature

Scalar = Any  # a float, an ndarray or a CasADi symbol: the functions here are element-wise

#: Separator of a table point's name: ``Cx@M1.4`` is Cx at Mach 1.4.
POINT_SEPARATOR = "@M"
#: Air temperature range [K] of a given temperature (the atmosphere's).
TEMPERATURE_RANGE_K = atmosphere.AIR_TEMPERATURE_RANGE_K


def mach_number(u: Scalar, v: Scalar, w: Scalar, speed_of_sound: Scalar) -> Scalar:
    """Return the Mach number ``V_T / a`` of the body velocities [m/s] (element-wise)."""
    return eq.air_data(u, v, w)[0] / speed_of_sound


def point_name(name: str, knot: float) -> str:
    """Return the parameter name of a table point: ``Cx@M1.4``."""
    return f"{name}{POINT_SEPARATOR}{knot:g}"


@dataclass(frozen=True)
class MachTables:
    """Which coefficients are tables in Mach, at which knots, and the speed of sound.

    Hashable (the CasADi graphs are cached on it).

    Attributes
    ----------
    knots : tuple of (name, tuple of float)
        The tabled coefficients in :data:`aeroid.model.NAMES` order, each with its
        increasing knots [Mach].
    speed_of_sound_mps : float
        The speed of sound of the flight [m/s].
    angle_knots : tuple of (name, tuple of float)
        The coefficients tabled in the total angle of attack, each with its increasing
        knots [rad] (none by default); a coefficient is in one of the two only.
    per_sample_temperature : bool
        Mach from the air temperature of each sample and RK4 stage (the constants'
        ``temperature``, an exogenous input) instead of ``speed_of_sound_mps``, which
        then only reports the flight's mean speed of sound. Default False.
    """

    knots: tuple[tuple[str, tuple[float, ...]], ...]
    speed_of_sound_mps: float
    angle_knots: tuple[tuple[str, tuple[float, ...]], ...] = ()
    per_sample_temperature: bool = False

    def __post_init__(self) -> None:
        unknown = [name for name, _ in self.knots if name not in NAMES]
        if unknown:
            raise AirframeError(f"tables: unknown coefficient(s) {', '.join(unknown)} "
                                f"(expected some of {', '.join(NAMES)})")
        given = dict(self.knots)
        if len(given) != len(self.knots):
            raise AirframeError("tables: a coefficient is tabled twice")
        ordered = tuple((name, check_knots(given[name], f"tables: {name}"))
                        for name in NAMES if name in given)
        object.__setattr__(self, "knots", ordered)
        by_angle = dict(self.angle_knots)
        wrong = [n for n in by_angle if n not in NAMES or n in given]
        if wrong or len(by_angle) != len(self.angle_knots):
            raise AirframeError(f"tables: {', '.join(wrong) or 'a coefficient'}: an angle "
                                "table of a coefficient that is unknown, tabled twice or also "
                                "a table in Mach (2-D tables are not available)")
        object.__setattr__(self, "angle_knots", tuple(
            (n, angle.check_angle_knots_rad(by_angle[n], f"tables: {n}"))
            for n in NAMES if n in by_angle))
        a = self.speed_of_sound_mps
        if isinstance(a, bool) or not (isinstance(a, int | float) and math.isfinite(a) and a > 0):
            raise AirframeError(f"tables: the speed of sound must be a positive number of "
                                f"m/s, got {a!r}")
        object.__setattr__(self, "speed_of_sound_mps", float(a))

    # construction --------------------------------------------------------------------
    @classmethod
    def from_knots(cls, knots: Mapping[str, Sequence[float]], *, altitude_m: float | None = None,
                   temperature_k: float | None = None) -> MachTables:
        """Build tables from ``{name: knots}`` and exactly one of an ISA altitude [m] or an
        air temperature [K] (the speed of sound ``sqrt(gamma R T)``)."""
        if (altitude_m is None) == (temperature_k is None):
            raise AirframeError("tables: give the speed of sound by exactly one of an ISA "
                                "altitude and an air temperature")
        if temperature_k is not None:
            sound = float(atmosphere.speed_of_sound_at(given_temperature(
                temperature_k, "tables: temperature_K")))
        else:
            sound = float(atmosphere.speed_of_sound(altitude_m))
        return cls(tuple((name, tuple(k)) for name, k in knots.items()), sound)

    # the parameter vector ------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        """The tabled coefficients, in :data:`aeroid.model.NAMES` order."""
        return tuple(name for name, _ in self.knots)

    def knots_of(self, name: str) -> tuple[float, ...]:
        """Return the knots of coefficient ``name`` (Mach; an angle table's [rad])."""
        return {**dict(self.knots), **dict(self.angle_knots)}[name]

    @property
    def angle_names(self) -> tuple[str, ...]:
        """The coefficients tabled in the total angle of attack, in NAMES order."""
        return tuple(name for name, _ in self.angle_knots)

    def point_names(self, name: str) -> tuple[str, ...]:
        """Return the parameter names of coefficient ``name``'s table points."""
        if name in self.angle_names:
            return tuple(angle.angle_point_name(name, k) for k in self.knots_of(name))
        return tuple(point_name(name, k) for k in self.knots_of(name))

    @property
    def layout(self) -> tuple[tuple[str, slice], ...]:
        """Each coefficient of :data:`NAMES` with its slice of the parameter vector."""
        out, start = [], 0
        given = {**dict(self.knots), **dict(self.angle_knots)}
        for name in NAMES:
            size = len(given[name]) if name in given else 1
            out.append((name, slice(start, start + size)))
            start += size
        return tuple(out)

    @property
    def n_parameters(self) -> int:
        """Length of the parameter vector (constants plus table points)."""
        return self.layout[-1][1].stop

    def parameter_names(self) -> tuple[str, ...]:
        """Names of the parameter vector: ``Cza``, ..., ``Cx@M1.1``, ``Cx@M1.4``, ..."""
        tabled = {*self.names, *self.angle_names}
        names: list[str] = []
        for name in NAMES:
            names += list(self.point_names(name)) if name in tabled else [name]
        return tuple(names)

    def expand(self, coefficients: np.ndarray) -> np.ndarray:
        """Return the parameter vector whose tables are flat at ``coefficients`` (..., 9)."""
        c = np.asarray(coefficients, dtype=float)
        parts = [np.repeat(c[..., [j]], s.stop - s.start, axis=-1)
                 for j, (_, s) in enumerate(self.layout)]
        return np.concatenate(parts, axis=-1)

    def mean_coefficients(self, parameters: np.ndarray) -> np.ndarray:
        """Return each coefficient's mean over its table points, shape (..., 9)."""
        p = np.asarray(parameters, dtype=float)
        return np.stack([p[..., s].mean(axis=-1) for _, s in self.layout], axis=-1)

    # evaluation (element-wise: numpy and CasADi) ---------------------------------------
    def coefficients(self, parameters: Sequence[Scalar], mach: Scalar,
                     alpha_total: Scalar | None = None) -> eq.Coefficients:
        """Return the coefficients at ``mach`` and total angle ``alpha_total`` [rad]
        (element-wise; the angle is needed only with angle tables).

        ``parameters`` is a sequence of :attr:`n_parameters` element-wise values (CasADi
        entries ``theta[i]``, or numpy arrays broadcastable with ``mach``).
        """
        given, by_angle = dict(self.knots), dict(self.angle_knots)
        if by_angle and alpha_total is None:
            raise AirframeError(f"tables: {', '.join(by_angle)} are tables in the angle of "
                                "attack; give the total angle of attack")
        values = []
        for name, s in self.layout:
            part = [parameters[i] for i in range(s.start, s.stop)]
            if name in given:
                values.append(table_value(mach, given[name], part))
            elif name in by_angle:
                values.append(table_value(alpha_total, by_angle[name], part))
            else:
                values.append(part[0])
        return eq.Coefficients(*values)

    def speed_of_sound(self, temperature_k: Scalar | None = None) -> Scalar:
        """Return the speed of sound [m/s]: the flight's, or with
        :attr:`per_sample_temperature` that of ``temperature_k`` [K] (element-wise)."""
        if not self.per_sample_temperature:
            return self.speed_of_sound_mps
        if temperature_k is None:  # never the flight's one number in silence
            raise AirframeError("tables: Mach from a per-sample air temperature needs the "
                                "temperature (the flight's air_temperature channel)")
        return atmosphere.speed_of_sound_at(temperature_k)

    def at_state(self, parameters: Sequence[Scalar], state: eq.State,
                 const: eq.Constants | None = None) -> eq.Coefficients:
        """Return the coefficients at the Mach number and total angle of attack of
        ``state`` (element-wise); ``const``: the constants whose ``temperature`` gives the
        speed of sound with :attr:`per_sample_temperature`."""
        sound = self.speed_of_sound(None if const is None else const.temperature)
        mach = mach_number(state.u, state.v, state.w, sound)
        alpha_total = (angle.total_angle(state.u, state.v, state.w) if self.angle_knots
                       else None)
        return self.coefficients(parameters, mach, alpha_total)

    # numpy arrays --------------------------------------------------------------------
    def mach(self, states: np.ndarray, temperature_k: np.ndarray | None = None) -> np.ndarray:
        """Return the Mach number of ``states`` (..., 9), shape (...); ``temperature_k``
        (...) [K]: the air temperature, needed with :attr:`per_sample_temperature`."""
        s = np.asarray(states, dtype=float)
        return mach_number(s[..., 0], s[..., 1], s[..., 2], self.speed_of_sound(temperature_k))

    def alpha_total(self, states: np.ndarray) -> np.ndarray:
        """Return the total angle of attack of ``states`` (..., 9), shape (...) [rad]."""
        s = np.asarray(states, dtype=float)
        return angle.total_angle(s[..., 0], s[..., 1], s[..., 2])

    def variable(self, name: str, states: np.ndarray,
                 temperature_k: np.ndarray | None = None) -> np.ndarray:
        """Return the variable of coefficient ``name``'s table at ``states`` (..., 9):
        Mach, or the total angle of attack [rad] for an angle table."""
        return (self.alpha_total(states) if name in self.angle_names
                else self.mach(states, temperature_k))

    def coefficient_array(self, parameters: np.ndarray, states: np.ndarray,
                          temperature_k: np.ndarray | None = None) -> np.ndarray:
        """Return the coefficients at each state's Mach (and total angle of attack),
        shape (..., 9) (numpy); ``temperature_k`` as :meth:`mach`."""
        p = np.moveaxis(np.asarray(parameters, dtype=float), -1, 0)
        alpha_total = self.alpha_total(states) if self.angle_knots else None
        c = self.coefficients(list(p), self.mach(states, temperature_k), alpha_total)
        return np.stack(np.broadcast_arrays(*c), axis=-1)

    def to_table(self) -> dict[str, Any]:
        """Return the file form of the knots, ``{name: [Mach, ...]}`` (``[tables]``; an
        angle table as ``{name: {alpha_deg = [deg, ...]}}``)."""
        out: dict[str, Any] = {name: list(k) for name, k in self.knots}
        out.update({name: {angle.ANGLE_KEY: [math.degrees(x) for x in k]}
                    for name, k in self.angle_knots})
        return out


__all__ = ["ANGLE_SEPARATOR", "choose_angle_knots", "split_point", "total_angle",
           "KNOT_RANGE", "MIN_KNOT_SPACING", "POINT_SEPARATOR", "MachTables", "basis",
           "check_knots", "choose_knots", "hat", "mach_number", "point_name", "table_value"]


#: Key of ``[tables]`` giving the air temperature [K] (else ISA at the altitude).
TEMPERATURE_KEY = "temperature_K"


@dataclass(frozen=True)
class TableSpec:
    """The airframe file's ``[tables]``: knots (or a knot count) per coefficient.

    ``Cx = [1.1, 1.5, 2.2]`` gives the knots [Mach]; ``Cx = 5`` asks for five knots
    spread over the flight's Mach range (:func:`choose_knots`, resolved per flight by
    :meth:`resolve`); ``temperature_K`` the air temperature of the speed of sound (left
    out: ISA at ``[atmosphere] altitude_m``). ``Cma = {alpha_deg = [0, 2, 4]}`` makes a
    table in the total angle of attack (``angle_knots``: the knots [deg] as given,
    radians in the resolved :class:`MachTables`), ``{alpha_deg = 4}`` four knots over
    the flight's range of it.
    """

    knots: tuple[tuple[str, tuple[float, ...] | int], ...]
    temperature_k: float | None = None
    angle_knots: tuple[tuple[str, tuple[float, ...] | int], ...] = ()

    @classmethod
    def from_table(cls, table: Mapping[str, Any], where: str) -> TableSpec:
        """Read ``[tables]``; one-line :class:`AirframeError` naming ``where`` and the key."""
        unknown = sorted(k for k in table if k not in (*NAMES, TEMPERATURE_KEY))
        if unknown:
            raise AirframeError(f"{where}: unknown key(s) {', '.join(unknown)} (allowed: "
                                f"coefficient names {', '.join(NAMES)} and {TEMPERATURE_KEY})")
        knots: list[tuple[str, tuple[float, ...] | int]] = []
        angles: list[tuple[str, tuple[float, ...] | int]] = []
        for name in (n for n in NAMES if n in table):
            value = table[name]
            if isinstance(value, Mapping):
                angles.append((name, angle_entry(value, f"{where} {name}")))
            elif isinstance(value, int) and not isinstance(value, bool):
                if value < 1:
                    raise AirframeError(f"{where} {name}: a knot count must be >= 1, "
                                        f"got {value}")
                knots.append((name, value))
            else:
                knots.append((name, check_knots(value, f"{where} {name}")))
        if not knots and not angles:
            raise AirframeError(f"{where}: no coefficient is tabled (give e.g. Cx = [1.1, 2.2])")
        temperature = table.get(TEMPERATURE_KEY)
        if temperature is not None:
            temperature = given_temperature(temperature, f"{where} {TEMPERATURE_KEY}")
        return cls(tuple(knots), temperature, tuple(angles))

    def to_table(self) -> dict[str, Any]:
        """Return the ``[tables]`` form (:meth:`from_table` reads it back equal)."""
        out: dict[str, Any] = {name: k if isinstance(k, int) else list(k)
                               for name, k in self.knots}
        out.update({name: {angle.ANGLE_KEY: k if isinstance(k, int) else list(k)}
                    for name, k in self.angle_knots})
        if self.temperature_k is not None:
            out[TEMPERATURE_KEY] = self.temperature_k
        return out

    def speed_of_sound(self, altitude_m: float | None) -> float:
        """Return the speed of sound [m/s]: from ``temperature_K``, else ISA at ``altitude_m``."""
        if self.temperature_k is not None:
            return float(atmosphere.speed_of_sound_at(self.temperature_k))
        if altitude_m is None:
            raise AirframeError("[tables]: Mach needs the speed of sound: give [tables] "
                                "temperature_K, or [atmosphere] altitude_m for ISA")
        return float(atmosphere.speed_of_sound(altitude_m))

    @property
    def needs_data(self) -> bool:
        """Whether some knots are a count, to be chosen from a flight's Mach range."""
        return any(isinstance(k, int) for _, k in (*self.knots, *self.angle_knots))

    def resolve(self, altitude_m: float | None, states: np.ndarray | None = None,
                temperature_k: np.ndarray | None = None) -> MachTables:
        """Return the :class:`MachTables` of a flight (its states choose counted knots);
        ``temperature_k`` (n,) [K], its logged air temperature: Mach per sample from it."""
        if temperature_k is not None and self.temperature_k is not None:
            raise AirframeError(f"[tables] {TEMPERATURE_KEY} = {self.temperature_k:g} and an "
                                "air_temperature channel: give one speed of sound (drop "
                                f"{TEMPERATURE_KEY} to use the logged temperature)")
        sound = (self.speed_of_sound(altitude_m) if temperature_k is None
                 else atmosphere.speed_of_sound_at(np.asarray(temperature_k, dtype=float)))
        knots = []
        for name, k in self.knots:
            if isinstance(k, int):
                if states is None:
                    raise AirframeError(f"[tables] {name}: {k} knots are chosen from a "
                                        "flight's Mach range; no flight given")
                s = np.asarray(states, dtype=float)
                k = choose_knots(mach_number(s[:, 0], s[:, 1], s[:, 2], sound), k)
            knots.append((name, k))
        angles = []
        for name, k in self.angle_knots:
            if isinstance(k, int):
                if states is None:
                    raise AirframeError(f"[tables] {name}: {k} knots are chosen from a "
                                        "flight's angle of attack range; no flight given")
                s = np.asarray(states, dtype=float)
                k = angle.choose_angle_knots(angle.total_angle(s[:, 0], s[:, 1], s[:, 2]), k)
            else:
                k = tuple(math.radians(x) for x in k)
            angles.append((name, k))
        if temperature_k is None:
            return MachTables(tuple(knots), sound, tuple(angles))
        return MachTables(tuple(knots), float(np.mean(sound)), tuple(angles), True)


__all__ += ["TEMPERATURE_KEY", "TableSpec"]
