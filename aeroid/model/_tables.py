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
the model) and the speed of sound ``a`` a constant of the flight: ISA at the airframe's
altitude, or the given air temperature (:meth:`MachTables.from_table`). The model has no
position equations, so the temperature does not change along the record.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from aeroid.errors import AirframeError
from aeroid.model import _atmosphere as atmosphere
from aeroid.model import _equations as eq
from aeroid.model._coefficients import NAMES

Scalar = Any  # a float, an ndarray or a CasADi symbol: the functions here are element-wise

#: Separator of a table point's name: ``Cx@M1.4`` is Cx at Mach 1.4.
POINT_SEPARATOR = "@M"
#: Closest knots [Mach]: the hat between knots closer than this is steeper than any
#: flight record can inform (1e-3 Mach is 0.3 m/s), and their names would collide.
MIN_KNOT_SPACING = 1e-3
#: Mach range of a table's knots: a knot outside is a typo (a speed in m/s, a percent).
KNOT_RANGE = (0.0, 10.0)
#: Air temperature range [K] of a given temperature (the ISA's 216.65 K layer to a hot
#: day at sea level, with margin); outside, a unit mistake (deg C).
TEMPERATURE_RANGE_K = (150.0, 350.0)


def hat(mach: Scalar, knots: Sequence[float], i: int) -> Scalar:
    """Return the hat function of knot ``i`` of ``knots`` at ``mach`` (element-wise).

    1 at ``knots[i]``, 0 at the other knots, linear between neighbours; the first and
    last hats are 1 beyond their end of the table (end values held). One knot: 1.
    """
    k = len(knots)
    if k == 1:
        return 0.0 * mach + 1.0
    one = 0.0 * mach + 1.0
    rising = one if i == 0 else (mach - knots[i - 1]) / (knots[i] - knots[i - 1])
    falling = one if i == k - 1 else (knots[i + 1] - mach) / (knots[i + 1] - knots[i])
    return np.maximum(np.minimum(np.minimum(rising, falling), 1.0), 0.0)


def basis(knots: Sequence[float], mach: np.ndarray) -> np.ndarray:
    """Return the hat basis of ``knots`` at ``mach``, shape (n, k) (numpy).

    Row ``j`` holds ``B_i(mach_j)``; every row sums to 1, and ``basis @ values`` is the
    table at those Mach numbers.
    """
    mach = np.asarray(mach, dtype=float).reshape(-1)
    return np.stack([hat(mach, knots, i) for i in range(len(knots))], axis=-1)


def table_value(mach: Scalar, knots: Sequence[float], values: Sequence[Scalar]) -> Scalar:
    """Return the table ``sum_i B_i(mach) values[i]`` (element-wise)."""
    total = 0.0
    for i, value in enumerate(values):
        total = total + hat(mach, knots, i) * value
    return total


def mach_number(u: Scalar, v: Scalar, w: Scalar, speed_of_sound: float) -> Scalar:
    """Return the Mach number ``V_T / a`` of the body velocities [m/s] (element-wise)."""
    return eq.air_data(u, v, w)[0] / speed_of_sound


def point_name(name: str, knot: float) -> str:
    """Return the parameter name of a table point: ``Cx@M1.4``."""
    return f"{name}{POINT_SEPARATOR}{knot:g}"


def check_knots(knots: Any, where: str) -> tuple[float, ...]:
    """Return ``knots`` as increasing floats, or raise a one-line :class:`AirframeError`."""
    if isinstance(knots, str | bytes) or not isinstance(knots, Sequence | np.ndarray):
        raise AirframeError(f"{where}: knots must be a list of Mach numbers, got {knots!r}")
    try:
        values = tuple(float(k) for k in knots)
    except (TypeError, ValueError):
        raise AirframeError(f"{where}: knots must be numbers, got {list(knots)!r}") from None
    if isinstance(knots, Sequence) and any(isinstance(k, bool) for k in knots):
        raise AirframeError(f"{where}: knots must be numbers, got {list(knots)!r}")
    if not values:
        raise AirframeError(f"{where}: no knots (give at least one Mach number)")
    low, high = KNOT_RANGE
    if not all(math.isfinite(k) and low < k <= high for k in values):
        raise AirframeError(f"{where}: knots must be Mach numbers in ({low:g}, {high:g}], "
                            f"got {list(values)}")
    gaps = np.diff(values)
    if np.any(gaps < MIN_KNOT_SPACING):
        raise AirframeError(f"{where}: knots must increase by at least {MIN_KNOT_SPACING:g} "
                            f"Mach, got {list(values)}")
    names = [f"{k:g}" for k in values]
    if len(set(names)) != len(names):
        raise AirframeError(f"{where}: knots {names} have the same name; give them fewer "
                            "digits apart")
    return values


def choose_knots(mach: np.ndarray, count: int) -> tuple[float, ...]:
    """Return ``count`` knots evenly spaced over the range of ``mach``, rounded to 0.01.

    The end knots are the lowest and highest Mach of the data rounded outward to 0.01, so
    no sample lies beyond the table.
    """
    if int(count) != count or count < 1:
        raise AirframeError(f"tables: knot count must be a positive integer, got {count!r}")
    mach = np.asarray(mach, dtype=float)
    mach = mach[np.isfinite(mach)]
    if mach.size == 0:
        raise AirframeError("tables: no finite Mach number in the data to choose knots from")
    # rounded outward to 0.01 Mach (a rounding error of the speed does not move a knot)
    low = math.floor(float(mach.min()) * 100 + 1e-6) / 100
    high = math.ceil(float(mach.max()) * 100 - 1e-6) / 100
    if count == 1 or high - low < MIN_KNOT_SPACING * (count - 1):
        if count > 1:
            raise AirframeError(f"tables: the data span Mach {mach.min():.4g}-{mach.max():.4g},"
                                f" too narrow for {count} knots")
        return (round(0.5 * (low + high), 2),)
    return tuple(round(float(k), 2) for k in np.linspace(low, high, int(count)))


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
    """

    knots: tuple[tuple[str, tuple[float, ...]], ...]
    speed_of_sound_mps: float

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
            low, high = TEMPERATURE_RANGE_K
            if not (isinstance(temperature_k, int | float) and low <= temperature_k <= high):
                raise AirframeError(f"tables: temperature_K must be in {low:g}..{high:g} K "
                                    f"(kelvin, not deg C), got {temperature_k!r}")
            sound = math.sqrt(atmosphere.GAMMA * atmosphere.R_AIR * float(temperature_k))
        else:
            sound = float(atmosphere.speed_of_sound(altitude_m))
        return cls(tuple((name, tuple(k)) for name, k in knots.items()), sound)

    # the parameter vector ------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        """The tabled coefficients, in :data:`aeroid.model.NAMES` order."""
        return tuple(name for name, _ in self.knots)

    def knots_of(self, name: str) -> tuple[float, ...]:
        """Return the knots of coefficient ``name``."""
        return dict(self.knots)[name]

    @property
    def layout(self) -> tuple[tuple[str, slice], ...]:
        """Each coefficient of :data:`NAMES` with its slice of the parameter vector."""
        out, start = [], 0
        given = dict(self.knots)
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
        given = dict(self.knots)
        names: list[str] = []
        for name in NAMES:
            names += [point_name(name, k) for k in given[name]] if name in given else [name]
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
    def coefficients(self, parameters: Sequence[Scalar], mach: Scalar) -> eq.Coefficients:
        """Return the coefficients at ``mach`` (element-wise).

        ``parameters`` is a sequence of :attr:`n_parameters` element-wise values (CasADi
        entries ``theta[i]``, or numpy arrays broadcastable with ``mach``).
        """
        given = dict(self.knots)
        values = []
        for name, s in self.layout:
            part = [parameters[i] for i in range(s.start, s.stop)]
            values.append(table_value(mach, given[name], part) if name in given else part[0])
        return eq.Coefficients(*values)

    def at_state(self, parameters: Sequence[Scalar], state: eq.State) -> eq.Coefficients:
        """Return the coefficients at the Mach number of ``state`` (element-wise)."""
        return self.coefficients(parameters,
                                 mach_number(state.u, state.v, state.w, self.speed_of_sound_mps))

    # numpy arrays --------------------------------------------------------------------
    def mach(self, states: np.ndarray) -> np.ndarray:
        """Return the Mach number of ``states`` (..., 9), shape (...)."""
        s = np.asarray(states, dtype=float)
        return mach_number(s[..., 0], s[..., 1], s[..., 2], self.speed_of_sound_mps)

    def coefficient_array(self, parameters: np.ndarray, states: np.ndarray) -> np.ndarray:
        """Return the coefficients at the Mach of each state, shape (..., 9) (numpy)."""
        p = np.moveaxis(np.asarray(parameters, dtype=float), -1, 0)
        c = self.coefficients(list(p), self.mach(states))
        return np.stack(np.broadcast_arrays(*c), axis=-1)

    def to_table(self) -> dict[str, list[float]]:
        """Return the file form of the knots, ``{name: [Mach, ...]}`` (``[tables]``)."""
        return {name: list(k) for name, k in self.knots}


__all__ = ["KNOT_RANGE", "MIN_KNOT_SPACING", "POINT_SEPARATOR", "MachTables", "basis",
           "check_knots", "choose_knots", "hat", "mach_number", "point_name", "table_value"]


#: Key of ``[tables]`` giving the air temperature [K] (else ISA at the altitude).
TEMPERATURE_KEY = "temperature_K"


@dataclass(frozen=True)
class TableSpec:
    """The airframe file's ``[tables]``: knots (or a knot count) per coefficient.

    ``Cx = [1.1, 1.5, 2.2]`` gives the knots [Mach]; ``Cx = 5`` asks for five knots
    spread over the flight's Mach range (:func:`choose_knots`, resolved per flight by
    :meth:`resolve`); ``temperature_K`` the air temperature of the speed of sound (left
    out: ISA at ``[atmosphere] altitude_m``).
    """

    knots: tuple[tuple[str, tuple[float, ...] | int], ...]
    temperature_k: float | None = None

    @classmethod
    def from_table(cls, table: Mapping[str, Any], where: str) -> TableSpec:
        """Read ``[tables]``; one-line :class:`AirframeError` naming ``where`` and the key."""
        unknown = sorted(k for k in table if k not in (*NAMES, TEMPERATURE_KEY))
        if unknown:
            raise AirframeError(f"{where}: unknown key(s) {', '.join(unknown)} (allowed: "
                                f"coefficient names {', '.join(NAMES)} and {TEMPERATURE_KEY})")
        knots: list[tuple[str, tuple[float, ...] | int]] = []
        for name in (n for n in NAMES if n in table):
            value = table[name]
            if isinstance(value, int) and not isinstance(value, bool):
                if value < 1:
                    raise AirframeError(f"{where} {name}: a knot count must be >= 1, "
                                        f"got {value}")
                knots.append((name, value))
            else:
                knots.append((name, check_knots(value, f"{where} {name}")))
        if not knots:
            raise AirframeError(f"{where}: no coefficient is tabled (give e.g. Cx = [1.1, 2.2])")
        temperature = table.get(TEMPERATURE_KEY)
        if temperature is not None:
            low, high = TEMPERATURE_RANGE_K
            if isinstance(temperature, bool) or not isinstance(temperature, int | float) \
                    or not low <= temperature <= high:
                raise AirframeError(f"{where} {TEMPERATURE_KEY} must be in {low:g}..{high:g} "
                                    f"K (kelvin, not deg C), got {temperature!r}")
            temperature = float(temperature)
        return cls(tuple(knots), temperature)

    def to_table(self) -> dict[str, Any]:
        """Return the ``[tables]`` form (:meth:`from_table` reads it back equal)."""
        out: dict[str, Any] = {name: k if isinstance(k, int) else list(k)
                               for name, k in self.knots}
        if self.temperature_k is not None:
            out[TEMPERATURE_KEY] = self.temperature_k
        return out

    def speed_of_sound(self, altitude_m: float | None) -> float:
        """Return the speed of sound [m/s]: from ``temperature_K``, else ISA at ``altitude_m``."""
        if self.temperature_k is not None:
            return math.sqrt(atmosphere.GAMMA * atmosphere.R_AIR * self.temperature_k)
        if altitude_m is None:
            raise AirframeError("[tables]: Mach needs the speed of sound: give [tables] "
                                "temperature_K, or [atmosphere] altitude_m for ISA")
        return float(atmosphere.speed_of_sound(altitude_m))

    @property
    def needs_data(self) -> bool:
        """Whether some knots are a count, to be chosen from a flight's Mach range."""
        return any(isinstance(k, int) for _, k in self.knots)

    def resolve(self, altitude_m: float | None, states: np.ndarray | None = None
                ) -> MachTables:
        """Return the :class:`MachTables` of a flight (its states choose counted knots)."""
        sound = self.speed_of_sound(altitude_m)
        knots = []
        for name, k in self.knots:
            if isinstance(k, int):
                if states is None:
                    raise AirframeError(f"[tables] {name}: {k} knots are chosen from a "
                                        "flight's Mach range; no flight given")
                s = np.asarray(states, dtype=float)
                k = choose_knots(mach_number(s[:, 0], s[:, 1], s[:, 2], sound), k)
            knots.append((name, k))
        return MachTables(tuple(knots), sound)


__all__ += ["TEMPERATURE_KEY", "TableSpec"]
