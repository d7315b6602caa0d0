"""The model's inputs between samples: the fin deflection and the exogenous quantities.

A log records the fin deflection and the flight conditions at the sample instants only;
integrating the model between samples needs them as functions of time.

Fin deflection (:class:`Schedule`): a piecewise-linear function of time given by knots
``(time, value)``; two knots at the same time are a jump (a relay switch), a sloped piece
is a rate-limited move. Constructors:

* :meth:`Schedule.hold`: each logged value holds until the next sample (a digital relay
  latched at the log clock, as in the paper's reference scenario);
* :meth:`Schedule.midpoint`: a change seen between two samples happened halfway
  (unbiased when the true instant is uniform in the interval);
* :meth:`Schedule.events`: switch instants and values given (a higher-rate deflection
  log on its own time base, or a column of switch times);
* :meth:`Schedule.shifted`: every knot delayed by ``tau`` (an actuator time delay).

For the integrators a schedule becomes, per sample interval, at most ``S`` segments
(:meth:`Schedule.segments`): the fraction of the interval at which each segment ends and
the deflection at its start and end; an RK4 step is split at every knot, not
approximated. The deflection at a sample instant (what the accelerometers see then) is
the right-continuous value (:meth:`Schedule.at`).

Exogenous quantities (:data:`EXOGENOUS`): air density, mass, thrust, inertias,
gravity, the wind (a gust: the air's NED velocity per sample) and the air temperature
(the speed of sound of Mach tables) may be given per sample; the integrators interpolate
them linearly in time between samples (:func:`exogenous_table`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from aeroid.model._equations import Constants

#: Constants that may vary per sample, in the column order of an exogenous table.
EXOGENOUS: tuple[str, ...] = ("rho", "mass", "thrust", "ix", "iy", "iz", "gravity",
                              "wind_n", "wind_e", "wind_d", "temperature")
#: Exogenous quantities of any sign (the others must be positive).
SIGNED: tuple[str, ...] = ("thrust", "gravity", "wind_n", "wind_e", "wind_d")
#: Relative tolerance on a uniform time base (as the flight validation's).
TIME_RTOL = 1e-6
#: A knot closer than this fraction of the sample interval to a sample instant is taken
#: at the instant (rounding of the knot times must not create sliver pieces).
KNOT_SNAP = 1e-9


class Pieces(NamedTuple):
    """A schedule cut per sample interval (:meth:`Schedule.segments`).

    ``end`` (n - 1, S): end of each piece as a fraction of the interval; ``start``,
    ``stop`` (n - 1, S): the deflection at the start and the end of each piece [rad].
    """

    end: np.ndarray
    start: np.ndarray
    stop: np.ndarray


def held(delta: np.ndarray) -> Pieces:
    """Return the pieces of a deflection held over each interval, ``delta`` (n - 1,)."""
    d = np.ascontiguousarray(delta, dtype=float).reshape(-1, 1)
    return Pieces(np.ones_like(d), d, d.copy())


@dataclass(frozen=True)
class Schedule:
    """The fin deflection [rad] as a piecewise-linear function of time.

    Attributes
    ----------
    times : ndarray, shape (m,)
        Knot times [s], non-decreasing; two equal times make a jump.
    values : ndarray, shape (m,)
        Deflection at each knot [rad]. Before the first knot the first value holds,
        after the last the last value.
    """

    times: np.ndarray
    values: np.ndarray

    def __post_init__(self) -> None:
        times = np.asarray(self.times, dtype=float).reshape(-1)
        values = np.asarray(self.values, dtype=float).reshape(-1)
        if times.size == 0 or times.shape != values.shape:
            raise ValueError("schedule: need one value per knot time and at least one knot")
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(values))):
            raise ValueError("schedule: knot times and values must be finite")
        if np.any(np.diff(times) < 0):
            raise ValueError("schedule: knot times must be non-decreasing")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "values", values)

    # construction ----------------------------------------------------------------
    @classmethod
    def hold(cls, t: np.ndarray, delta: np.ndarray) -> Schedule:
        """Each logged value holds from its sample until the next (zero-order hold)."""
        t, delta = _samples(t, delta)
        change = np.flatnonzero(np.diff(delta) != 0.0) + 1
        times = np.concatenate([[t[0]], np.repeat(t[change], 2)])
        values = np.concatenate([[delta[0]], np.column_stack([delta[change - 1],
                                                              delta[change]]).ravel()])
        return cls(times, values)

    @classmethod
    def midpoint(cls, t: np.ndarray, delta: np.ndarray) -> Schedule:
        """A change between two samples happened halfway between them."""
        t, delta = _samples(t, delta)
        change = np.flatnonzero(np.diff(delta) != 0.0) + 1
        mid = 0.5 * (t[change - 1] + t[change])
        times = np.concatenate([[t[0]], np.repeat(mid, 2)])
        values = np.concatenate([[delta[0]], np.column_stack([delta[change - 1],
                                                              delta[change]]).ravel()])
        return cls(times, values)

    @classmethod
    def events(cls, initial: float, times: np.ndarray, values: np.ndarray) -> Schedule:
        """Switches (jumps) to ``values[j]`` at ``times[j]``, starting from ``initial``."""
        times = np.asarray(times, dtype=float).reshape(-1)
        values = np.asarray(values, dtype=float).reshape(-1)
        if times.shape != values.shape:
            raise ValueError("schedule: need one value per switch time")
        if times.size == 0:
            return cls(np.zeros(1), np.array([float(initial)]))
        before = np.concatenate([[float(initial)], values[:-1]])
        knots_t = np.concatenate([[times[0]], np.repeat(times, 2)])
        knots_v = np.concatenate([[float(initial)], np.column_stack([before,
                                                                     values]).ravel()])
        return cls(knots_t, knots_v)

    def shifted(self, tau: float) -> Schedule:
        """Return the schedule delayed by ``tau`` [s] (an actuator time delay)."""
        return Schedule(self.times + float(tau), self.values)

    # evaluation ------------------------------------------------------------------
    def at(self, t: np.ndarray) -> np.ndarray:
        """Return the deflection at times ``t`` (right-continuous: after a jump at ``t``)."""
        return self._value(t, side="right")

    def before(self, t: np.ndarray) -> np.ndarray:
        """Return the left limit of the deflection at ``t`` (before a jump at ``t``)."""
        return self._value(t, side="left")

    def _value(self, t: np.ndarray, side: str) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        # the last knot before t (side="left") or at or before t (side="right")
        i = np.searchsorted(self.times, t, side=side) - 1
        below = i < 0
        i = np.clip(i, 0, self.times.size - 1)
        j = np.minimum(i + 1, self.times.size - 1)
        t0, t1 = self.times[i], self.times[j]
        v0, v1 = self.values[i], self.values[j]
        span = np.where(t1 > t0, t1 - t0, 1.0)
        frac = np.clip((t - t0) / span, 0.0, 1.0)
        value = np.where((j > i) & (t1 > t0), v0 + (v1 - v0) * frac, v0)
        return np.where(below, self.values[0], value)

    def segments(self, t: np.ndarray) -> Pieces:
        """Return the schedule cut into constant or linear pieces per sample interval.

        A piece ends at every distinct knot time strictly inside an interval; a knot
        within :data:`KNOT_SNAP` of a sample instant is taken at the instant.

        Parameters
        ----------
        t : ndarray, shape (n,)
            Uniform sample times [s].

        Returns
        -------
        end : ndarray, shape (n - 1, S)
            End of each piece as a fraction of the interval, non-decreasing, the last
            used one 1.0 (unused pieces repeat 1.0: zero length).
        start_value, end_value : ndarray, shape (n - 1, S)
            Deflection at the start and the end of each piece [rad]; within a piece it
            is linear in time.
        """
        t = np.asarray(t, dtype=float).reshape(-1)
        n_int = t.size - 1
        dt = (t[-1] - t[0]) / n_int
        # knots within KNOT_SNAP of a sample instant move onto it (so that the values at
        # the sample instants see them too)
        k_near = np.clip(np.rint((self.times - t[0]) / dt).astype(int), 0, t.size - 1)
        near = np.abs(self.times - t[k_near]) < KNOT_SNAP * dt
        if np.any(near & (self.times != t[k_near])):
            return Schedule(np.where(near, t[k_near], self.times), self.values).segments(t)
        times, first = np.unique(self.times, return_index=True)
        last = np.searchsorted(self.times, times, side="right") - 1
        left, right = self.values[first], self.values[last]
        pos = (times - t[0]) / dt
        k = np.floor(pos).astype(int)
        frac = pos - k
        snap_up = frac > 1.0 - KNOT_SNAP
        k, frac = np.where(snap_up, k + 1, k), np.where(snap_up | (frac < KNOT_SNAP), 0.0, frac)
        inside = (k >= 0) & (k < n_int) & (frac > 0.0)
        k, frac, left, right = k[inside], frac[inside], left[inside], right[inside]
        counts = np.bincount(k, minlength=n_int)
        n_pieces = int(counts.max(initial=0)) + 1
        end = np.ones((n_int, n_pieces))
        start_value = np.repeat(self.at(t[:-1])[:, None], n_pieces, axis=1)
        end_value = np.repeat(self.before(t[1:])[:, None], n_pieces, axis=1)
        for interval in np.flatnonzero(counts):
            sel = k == interval  # knots are sorted in time, so these are in order
            m = int(counts[interval])
            end[interval, :m] = frac[sel]
            start_value[interval, 1:m + 1] = right[sel]
            end_value[interval, :m] = left[sel]
            end_value[interval, m + 1:] = end_value[interval, m]
            start_value[interval, m + 1:] = end_value[interval, m]
        return Pieces(end, start_value, end_value)


@dataclass(frozen=True, eq=False)
class Record:
    """What the model needs of a record besides its parameters: the inputs in time.

    Attributes
    ----------
    dt : float
        Sample interval [s].
    delta : ndarray, shape (n,)
        Fin deflection at the sample instants [rad] (what the accelerometers see).
    pieces : Pieces
        The deflection between samples, per interval (:meth:`Schedule.segments`).
    exogenous : ndarray, shape (n, len(EXOGENOUS)), or None
        Exogenous quantities at the samples (:data:`EXOGENOUS` columns), interpolated
        linearly in time; None: the model constants hold.
    """

    dt: float
    delta: np.ndarray
    pieces: Pieces
    exogenous: np.ndarray | None = None

    def __post_init__(self) -> None:
        delta = np.ascontiguousarray(self.delta, dtype=float).reshape(-1)
        pieces = Pieces(*(np.ascontiguousarray(a, dtype=float) for a in self.pieces))
        if delta.size < 2 or pieces.end.shape[0] != delta.size - 1 or pieces.end.ndim != 2:
            raise ValueError(f"record: {delta.size} samples need pieces for "
                             f"{delta.size - 1} intervals, got {pieces.end.shape}")
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise ValueError(f"record: dt must be a positive number of seconds, got {self.dt}")
        object.__setattr__(self, "delta", delta)
        object.__setattr__(self, "pieces", pieces)
        if self.exogenous is not None:
            exo = np.ascontiguousarray(self.exogenous, dtype=float)
            if exo.shape != (delta.size, len(EXOGENOUS)):
                raise ValueError(f"record: exogenous table must have shape "
                                 f"({delta.size}, {len(EXOGENOUS)}), got {exo.shape}")
            object.__setattr__(self, "exogenous", exo)

    @classmethod
    def held(cls, delta: np.ndarray, dt: float, exogenous: np.ndarray | None = None) -> Record:
        """Each logged deflection holds until the next sample."""
        delta = np.asarray(delta, dtype=float).reshape(-1)
        return cls(float(dt), delta, held(delta[:-1]), exogenous)

    @classmethod
    def scheduled(cls, schedule: Schedule, t: np.ndarray,
                  exogenous: np.ndarray | None = None) -> Record:
        """The deflection of ``schedule`` at and between the sample times ``t``."""
        t = np.asarray(t, dtype=float).reshape(-1)
        return cls(float((t[-1] - t[0]) / (t.size - 1)), schedule.at(t), schedule.segments(t),
                   exogenous)

    @property
    def n_samples(self) -> int:
        """Samples in the record."""
        return int(self.delta.size)

    @property
    def n_pieces(self) -> int:
        """Pieces per interval (1 for a held deflection)."""
        return int(self.pieces.end.shape[1])

    def symbolic_inputs(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return the arrays the CasADi record takes: delta (1, n), pieces (3 S, n - 1),
        exogenous (len(EXOGENOUS) or 0, n)."""
        pieces = np.vstack([self.pieces.end.T, self.pieces.start.T, self.pieces.stop.T])
        exo = (self.exogenous.T if self.exogenous is not None
               else np.zeros((0, self.n_samples)))
        return self.delta[None, :], pieces, exo


def _samples(t: np.ndarray, delta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(t, dtype=float).reshape(-1)
    delta = np.asarray(delta, dtype=float).reshape(-1)
    if t.shape != delta.shape or t.size < 2:
        raise ValueError("schedule: need the same number (>= 2) of times and deflections")
    return t, delta


def exogenous_table(const: Constants, n_samples: int,
                    per_sample: Mapping[str, np.ndarray] | None = None) -> np.ndarray:
    """Return the exogenous quantities at every sample, shape (n_samples, len(EXOGENOUS)).

    Columns :data:`EXOGENOUS`; a quantity given in ``per_sample`` (an array of n values)
    replaces the constant of ``const``.

    Raises
    ------
    ValueError
        For an unknown name, a wrong length, or a non-finite or non-positive value (any
        thrust, gravity and wind are allowed).
    """
    table = np.tile(np.array([float(getattr(const, name)) for name in EXOGENOUS]),
                    (n_samples, 1))
    for name, values in (per_sample or {}).items():
        if name not in EXOGENOUS:
            raise ValueError(f"exogenous input {name!r} is not one of {', '.join(EXOGENOUS)}")
        values = np.asarray(values, dtype=float).reshape(-1)
        if values.size != n_samples:
            raise ValueError(f"exogenous input {name!r}: {values.size} values for "
                             f"{n_samples} samples")
        if not np.all(np.isfinite(values)):
            raise ValueError(f"exogenous input {name!r} has non-finite values")
        if name not in SIGNED and np.any(values <= 0):
            raise ValueError(f"exogenous input {name!r} must be positive")
        table[:, EXOGENOUS.index(name)] = values
    return table


def _generated(name: str, body: str) -> Callable[..., Constants]:
    namespace: dict[str, Any] = {"Constants": Constants}
    exec(body, namespace)  # noqa: S102 - source built here from tuple field names only
    return namespace[name]  # type: ignore[no-any-return]


def _row_source() -> str:
    fields = [f"row[{EXOGENOUS.index(f)}]" if f in EXOGENOUS else f"base.{f}"
              for f in Constants._fields]
    return "def with_exogenous(base, row):\n    return Constants(" + ", ".join(fields) + ")\n"


def _lerp_source() -> str:
    fields = [f"a.{f} + (b.{f} - a.{f}) * frac" for f in Constants._fields]
    return "def lerp(a, b, frac):\n    return Constants(" + ", ".join(fields) + ")\n"


#: ``with_exogenous(base, row)``: ``base`` with the exogenous quantities of one table row
#: (:data:`EXOGENOUS` order). Element-wise (numpy, numba, CasADi), written from the field
#: names, so a new exogenous quantity needs no change here.
with_exogenous = _generated("with_exogenous", _row_source())
#: ``lerp(a, b, frac)``: constants interpolated linearly between ``a`` and ``b``.
lerp = _generated("lerp", _lerp_source())


def normalised(const: Constants, varying: bool) -> Constants:
    """Return ``const`` with the exogenous fields zeroed when per-sample values replace them.

    Built models are cached by their constants; a per-sample atmosphere leaves the constant
    density NaN (never equal to itself), and the replaced values do not enter the model.
    """
    const = Constants(*(float(v) for v in const))
    return const._replace(**dict.fromkeys(EXOGENOUS, 0.0)) if varying else const


def is_uniform(t: np.ndarray) -> bool:
    """Return whether ``t`` is a uniform time base (to :data:`TIME_RTOL`)."""
    steps = np.diff(np.asarray(t, dtype=float))
    dt = float(np.median(steps))
    return bool(dt > 0 and np.all(np.abs(steps - dt) <= TIME_RTOL * dt + 1e-12)
                and math.isfinite(dt))
