"""The fin law evaluated open loop on a measured roll angle: switch instants between samples.

A log gives the roll angle at its sample instants only. Between them it is interpolated
by a cubic: :class:`scipy.interpolate.CubicSpline` (not-a-knot) through the unwrapped
angle, or, given the Euler roll rate ``phi_dot`` at the samples, the cubic Hermite
interpolant :class:`scipy.interpolate.CubicHermiteSpline`. The switching function
``s(t) = sin 2 phi(t) + A(t) sin(phi(t) + phi0(t))`` is evaluated at ``subdivisions``
points per sample interval; every change of ``sign(s)`` between neighbours is a bracket,
and all brackets are halved together (bisection on the sign, ``sign(0) = +1``) until they
are narrower than :data:`SWITCH_TOL_S`. Two switches in one sample interval are found
when they are more than ``dt / subdivisions`` apart; a pair closer than that (the
switching function grazing zero) is missed as a pair.

A relay that reads its law at a clock (``FinLaw.evaluation``: ``latched`` at the log's
sample instants, ``control_rate`` at ``m / control_rate_hz``) switches at the first
clock instant whose command differs from the one before (:func:`clocked_switches`): the
command is read from the measured roll angle at the sample instants, from the
interpolated one at the instants of a clock of its own.

The located instants are as good as the interpolated roll angle. Measured against the
simulator's true instants on the reference flight with a continuous relay (500 Hz, roll
rate ~50 rad/s, 32 switches; ``tests/unit/test_fin_law.py``): the spline's are within
8.4e-10 s, the Hermite interpolant's with the noise-free Euler roll rate within 4.8e-10 s
but with the rates of a Gaussian-noise flight 5.4e-8 s off. The noise models leave the
roll angle alone, so the spline (the default) is as good on a noisy flight.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np
from scipy.interpolate import CubicHermiteSpline, CubicSpline

from aeroid.model._inputs import Schedule


class RelayLaw(Protocol):
    """What the schedule reads of a fin law: :class:`aeroid.model.FinLaw` is one.

    Named here, not imported, so that this module does not import the one that calls it
    (``FinLaw.schedule`` and ``FinLaw.switches`` are built on this module).
    """

    @property
    def delta_max_rad(self) -> float: ...
    @property
    def delay_s(self) -> float: ...
    @property
    def evaluation(self) -> str: ...
    @property
    def control_rate_hz(self) -> float | None: ...

    def switching_function(self, phi: np.ndarray | float,
                           t: np.ndarray | float | None = None) -> np.ndarray: ...

    def command(self, phi: np.ndarray | float,
                t: np.ndarray | float | None = None) -> np.ndarray: ...

    def actuate(self, t0: float, initial: float, times: np.ndarray,
                values: np.ndarray) -> Schedule: ...


#: Width [s] to which every bracketed switch instant is bisected: far below what the
#: interpolated roll angle can tell (microseconds), far above float64's spacing at
#: flight times of hours (1e-12 s at 1e3 s).
SWITCH_TOL_S = 1e-11
#: A clock instant within this fraction of a period of a sample time is at the sample
#: time (``m / f`` rounded), as the simulator's relay loop takes it.
CLOCK_SNAP = 1e-9
#: A first deflection this close to a stop (relative to ``delta_max``) is at the stop;
#: farther inside, the fin is moving (:func:`law_schedule`).
STOP_RTOL = 1e-9


def _check(t: np.ndarray, phi: np.ndarray, phi_rate: np.ndarray | None, subdivisions: int
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    t = np.asarray(t, dtype=float).reshape(-1)
    phi = np.asarray(phi, dtype=float).reshape(-1)
    if t.size < 2 or phi.shape != t.shape:
        raise ValueError(f"fin law schedule: need the same number (>= 2) of times and roll "
                         f"angles, got {t.size} and {phi.size}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(phi))):
        raise ValueError("fin law schedule: times and roll angles must be finite")
    if np.any(np.diff(t) <= 0):
        raise ValueError("fin law schedule: sample times must increase strictly")
    if phi_rate is not None:
        phi_rate = np.asarray(phi_rate, dtype=float).reshape(-1)
        if phi_rate.shape != t.shape or not np.all(np.isfinite(phi_rate)):
            raise ValueError("fin law schedule: phi_rate needs one finite value per sample")
    if isinstance(subdivisions, bool) or not isinstance(subdivisions, int | np.integer) \
            or subdivisions < 1:
        raise ValueError(f"fin law schedule: subdivisions must be an integer >= 1, "
                         f"got {subdivisions!r}")
    return t, phi, phi_rate


def locate_switches(law: RelayLaw, t: np.ndarray, phi: np.ndarray, *,
                    phi_rate: np.ndarray | None = None, subdivisions: int = 8
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Return the instants in ``(t[0], t[-1]]`` where the law's command switches.

    Parameters
    ----------
    law : RelayLaw
    t : ndarray, shape (n,)
        Sample times [s], increasing.
    phi : ndarray, shape (n,)
        Measured roll angle [rad] (wrapped or not: it is unwrapped first).
    phi_rate : ndarray, shape (n,), optional
        Euler roll rate ``dphi/dt`` [rad/s] at the samples: cubic Hermite interpolation
        instead of the spline.
    subdivisions : int
        Points per sample interval at which the sign of the switching function is read.

    Returns
    -------
    times : ndarray, shape (m,)
        Commanded switch instants [s] (no delay), to :data:`SWITCH_TOL_S`.
    values : ndarray, shape (m,)
        The command after each switch, ``+-delta_max_rad``.
    """
    t, phi, phi_rate = _check(t, phi, phi_rate, subdivisions)
    phi = np.unwrap(phi)
    curve = (CubicSpline(t, phi) if phi_rate is None
             else CubicHermiteSpline(t, phi, phi_rate))
    frac = np.arange(subdivisions) / subdivisions
    grid = np.append((t[:-1, None] + np.diff(t)[:, None] * frac[None, :]).ravel(), t[-1])

    def positive(when: np.ndarray) -> np.ndarray:
        return np.asarray(law.switching_function(curve(when), when) >= 0.0)

    sign = positive(grid)
    k = np.flatnonzero(sign[1:] != sign[:-1])
    lo, hi, before = grid[k], grid[k + 1], sign[k]
    if k.size:
        steps = math.ceil(math.log2(max(float(np.max(hi - lo)) / SWITCH_TOL_S, 1.0)))
        for _ in range(steps):
            mid = 0.5 * (lo + hi)
            same = positive(mid) == before
            lo = np.where(same, mid, lo)
            hi = np.where(same, hi, mid)
    values = np.where(before, -law.delta_max_rad, law.delta_max_rad)
    return 0.5 * (lo + hi), values


def clocked_switches(law: RelayLaw, t: np.ndarray, phi: np.ndarray, *,
                     phi_rate: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, float]:
    """Return the switches of a relay that reads its law at a clock, and the command at t[0].

    The clock's instants from ``t[0] - law.delay_s`` on are read (the roll angle
    extrapolated by the cubic before ``t[0]``), so that the switches commanded within the
    delay before the record, which act inside it, are known too.

    Parameters
    ----------
    law : RelayLaw
        With ``evaluation`` ``latched`` (the clock is the sample times ``t``, continued
        back at the same interval) or ``control_rate`` (instants ``m /
        law.control_rate_hz``).
    t, phi, phi_rate
        As :func:`locate_switches`.

    Returns
    -------
    times : ndarray, shape (m,)
        Clock instants in ``(t[0] - delay_s, t[-1]]`` at which the command changes [s]
        (before the delay).
    values : ndarray, shape (m,)
        The command from each [rad].
    command : float
        The command acting on the fin at ``t[0]``: read at the last clock instant at or
        before ``t[0] - delay_s``.
    """
    t, phi, phi_rate = _check(t, phi, phi_rate, 1)
    phi = np.unwrap(phi)
    curve = (CubicSpline(t, phi) if phi_rate is None
             else CubicHermiteSpline(t, phi, phi_rate))
    back = t[0] - law.delay_s
    if law.evaluation == "latched":
        period = (t[-1] - t[0]) / (t.size - 1)
        before = np.arange(math.ceil(law.delay_s / period - CLOCK_SNAP), 0, -1)
        instants = np.concatenate([t[0] - period * before, t])
        angle = np.concatenate([curve(instants[:before.size]), phi])
    elif law.evaluation == "control_rate":
        rate = float(law.control_rate_hz)  # type: ignore[arg-type]
        period = 1.0 / rate
        first = math.floor(back * rate + CLOCK_SNAP)
        instants = np.arange(first, math.floor(t[-1] * rate + CLOCK_SNAP) + 1) / rate
        angle = curve(instants)
    else:
        raise ValueError(f"fin law schedule: a {law.evaluation!r} law has no clock")
    command = np.asarray(law.command(angle, instants), dtype=float)
    acting = int(np.searchsorted(instants, back + CLOCK_SNAP * period, side="right")) - 1
    change = np.flatnonzero(command[1:] != command[:-1]) + 1
    change = change[change > acting]
    return instants[change], command[change], float(command[max(acting, 0)])


def law_switches(law: RelayLaw, t: np.ndarray, phi: np.ndarray, *,
                 phi_rate: np.ndarray | None = None, subdivisions: int = 8
                 ) -> tuple[np.ndarray, np.ndarray, float]:
    """Return the commanded switches and the command acting on the fin at ``t[0]``.

    :func:`locate_switches` for a continuous law (switches in ``(t[0], t[-1]]``, the
    command at ``t[0]``), :func:`clocked_switches` for one read at a clock.
    """
    if law.evaluation != "continuous":
        return clocked_switches(law, t, phi, phi_rate=phi_rate)
    times, values = locate_switches(law, t, phi, phi_rate=phi_rate, subdivisions=subdivisions)
    t0 = float(np.asarray(t, dtype=float).reshape(-1)[0])
    phi0 = float(np.asarray(phi, dtype=float).reshape(-1)[0])
    return times, values, float(law.command(phi0, t0))


def law_schedule(law: RelayLaw, t: np.ndarray, phi: np.ndarray, *, initial: float | None = None,
                 phi_rate: np.ndarray | None = None, subdivisions: int = 8) -> Schedule:
    """Return the fin deflection the law gives on a measured roll angle (open loop).

    The commanded switches are located by :func:`locate_switches` (a law read at a clock:
    :func:`clocked_switches`), delayed by ``law.delay_s`` and rate limited
    (:meth:`FinLaw.actuate`).

    Before the record: the switches commanded in the ``delay_s`` before ``t[0]`` act
    inside the record but cannot be located from it. The fin is at ``initial`` at
    ``t[0]`` (pass the deflection logged at the first sample; default the law's command
    at ``t[0]``, right when nothing was commanded in the delay before the record):

    * at the law's command at ``t[0]``: it rests there until the first located switch
      acts;
    * at the other stop: one switch to the command was commanded within the delay before
      ``t[0]``; it acts at ``t[0] + delay_s / 2`` (half-way through the interval it acts
      in: at most ``delay_s / 2`` off; at ``t[0]`` without a delay);
    * between the stops (by more than :data:`STOP_RTOL` of ``delta_max``): a ramp in
      progress (a rate limit), taken to be heading for the law's command at ``t[0]``
      from ``t[0]`` on.

    Parameters
    ----------
    initial : float, optional
        Fin deflection at ``t[0]`` [rad].
    Other parameters
        As :func:`locate_switches`.

    Returns
    -------
    Schedule
        The deflection from ``t[0]`` on [rad].
    """
    times, values, command = law_switches(law, t, phi, phi_rate=phi_rate,
                                          subdivisions=subdivisions)
    t0 = float(np.asarray(t, dtype=float).reshape(-1)[0])
    if initial is None:
        initial = command
    initial = float(initial)
    if not math.isfinite(initial):
        raise ValueError(f"fin law schedule: initial deflection must be finite, got {initial}")
    if initial != command:
        moving = abs(initial) < law.delta_max_rad * (1.0 - STOP_RTOL)
        acts = t0 if moving else t0 + 0.5 * law.delay_s
        times = np.concatenate([[acts - law.delay_s], times])
        values = np.concatenate([[command], values])
    return law.actuate(t0, initial, times, values)


__all__ = ["CLOCK_SNAP", "STOP_RTOL", "SWITCH_TOL_S", "RelayLaw", "clocked_switches",
           "law_schedule", "law_switches", "locate_switches"]
