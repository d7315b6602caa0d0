"""The closed relay loop with the switch instants inside the truth integration.

The truth is integrated with RK4 on the grid ``t_j = j h``, ``h = dt / truth_substeps``,
with the fin deflection a piecewise-linear :class:`~aeroid.model.Schedule`: every RK4
step is split at the schedule's knots (:func:`aeroid.model.propagate` with the
schedule's pieces, one RK4 step per piece). The schedule grows as the relay switches:

* ``continuous``: the command switches where the switching function of the TRUE roll
  angle crosses zero. After a chunk of steps integrated with the schedule known so far,
  the first grid step whose end has the other sign holds the crossing; it is located by
  re-integrating from the step's start over a shorter length (one RK4 step per piece up
  to the candidate instant) and solving for the zero (:func:`scipy.optimize.brentq`, or
  bisection on the sign when the bracket's ends do not straddle zero), to
  :data:`LOCATE_TOL_S`.
* ``control_rate``: a digital relay evaluated at the instants ``m / f_c`` of its own
  clock and held. The sign at a control instant is read from the grid where both ends
  of its step agree, and from a re-integration to the instant where they do not (one
  crossing per step: the first control instant past it is found by bisection over the
  instants).

Each commanded switch acts ``delay_s`` later and, with a rate limit, as a ramp
(:class:`aeroid.model._actuator.Track`); the integration restarts from the start of
the step that held the switch. Two crossings within one grid step (the switching
function grazing zero within ``h``) are missed as a pair. Before t = 0 the fin is taken
at rest at the law's command at t = 0.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from aeroid.model import PHI, Constants, FinLaw, Pieces, Schedule, Track, propagate

#: Width [s] to which a continuous switch instant is located: far below what moves the
#: states (a switch 1e-9 s off changes them by ~1e-9 x the fin's effect), and two or
#: three re-integrations more than 1e-9 s.
LOCATE_TOL_S = 1e-12
#: A knot or control instant within this fraction of a grid step of a grid point is
#: put on the grid point (a knot a rounding error off a sample instant would cut a
#: sliver piece).
GRID_SNAP = 1e-9
#: A control instant within this fraction of a control period of a grid step's end
#: belongs to that step (``m / f_c`` rounded).
CLOCK_SNAP = 1e-9
#: Grid steps integrated per chunk before looking for a switch (a switch restarts the
#: chunk; the reference flight switches every ~120 steps).
CHUNK_STEPS = 64


class StepInput:
    """The fin deflection over one grid step ``[ta, tend]``, cut at ``tb <= tend`` on demand.

    ``knots``: distinct knot times strictly inside the step, ``right``/``left``: the
    deflection just after/before each; ``start``: at ``ta`` (after a jump there);
    ``end``: just before ``tend``.
    """

    def __init__(self, ta: float, tend: float, knots: np.ndarray, right: np.ndarray,
                 left: np.ndarray, start: float, end: float) -> None:
        self.ta, self.tend = ta, tend
        self.knots = knots
        self.starts = np.append(start, right)  # at the start of each piece
        self.edges = np.append(ta, knots)      # start time of each piece
        self.stops = np.append(left, end)      # just before the end of each piece
        self.ends = np.append(knots, tend)     # end time of each piece

    def pieces(self, tb: float) -> Pieces:
        """Return the pieces of ``[ta, tb]`` as one interval (fractions of ``tb - ta``)."""
        m = int(np.searchsorted(self.knots, tb, side="left"))  # knots before tb
        t0, t1 = self.edges[m], self.ends[m]
        v0, v1 = self.starts[m], self.stops[m]
        at_tb = v0 + (v1 - v0) * (tb - t0) / (t1 - t0) if t1 > t0 else v1
        ends = np.append((self.knots[:m] - self.ta) / (tb - self.ta), 1.0)
        stops = np.append(self.stops[:m], at_tb)
        return Pieces(ends[None, :], self.starts[None, :m + 1], stops[None, :])


class RelayLoop:
    """One closed-loop truth integration (module docstring).

    Parameters
    ----------
    law : FinLaw
    coefficients : ndarray, shape (9,)
    const : Constants
    state0 : ndarray, shape (9,)
        State at t = 0.
    h : float
        Grid step [s].
    n_steps : int
        Grid steps to integrate.
    control_rate_hz : float or None
        The relay's own clock (``control_rate``); None: continuous.
    backend : str
        :func:`aeroid.model.propagate` backend.
    """

    def __init__(self, law: FinLaw, coefficients: np.ndarray, const: Constants,
                 state0: np.ndarray, h: float, n_steps: int, *,
                 control_rate_hz: float | None, backend: str) -> None:
        self.law, self.const, self.backend = law, const, backend
        self.coefficients = np.asarray(coefficients, dtype=float)
        self.x0 = np.asarray(state0, dtype=float)
        self.h, self.n_steps = float(h), int(n_steps)
        self.control_rate_hz = control_rate_hz
        command = float(law.command(self.x0[PHI], 0.0))
        self.sign = command > 0
        self.track = Track(0.0, command, law.rate_limit_radps, snap=self.snap)
        self.schedule = self.track.schedule()
        self.commands: tuple[list[float], list[float]] = ([], [])
        self.evaluations = 0

    # helpers ---------------------------------------------------------------------------
    def grid(self, j: int | np.ndarray) -> np.ndarray:
        """Return the grid time(s) of step index ``j`` [s]."""
        return np.asarray(j, dtype=float) * self.h

    def snap(self, when: float) -> float:
        """Return ``when`` [s], or the grid point it is within :data:`GRID_SNAP` of."""
        j = round(when / self.h)
        grid = j * self.h
        return grid if abs(when - grid) <= GRID_SNAP * self.h else when

    def positive(self, x: np.ndarray, when: np.ndarray | float) -> np.ndarray:
        """Return ``s >= 0`` for state(s) ``x`` at time(s) ``when``."""
        return np.asarray(self.law.switching_function(x[..., PHI], when) >= 0.0)

    def step_input(self, ta: float, tend: float) -> StepInput:
        """Return the deflection over ``[ta, tend]`` as the schedule gives it now."""
        sched = self.schedule
        lo = np.searchsorted(sched.times, ta, side="right")
        hi = np.searchsorted(sched.times, tend, side="left")
        inner = np.unique(sched.times[lo:hi])
        return StepInput(ta, tend, inner, sched.at(inner), sched.before(inner),
                         float(sched.at(ta)), float(sched.before(tend)))

    def advance(self, x: np.ndarray, step: StepInput, tb: float) -> np.ndarray:
        """Return the state at ``tb`` from ``x`` at ``step.ta`` (one RK4 step per piece)."""
        if tb <= step.ta:
            return x
        self.evaluations += 1
        return propagate(x, self.coefficients, step.pieces(tb), tb - step.ta, self.const,
                         backend=self.backend)[0, -1]

    def chunk(self, x: np.ndarray, j: int, jj: int) -> np.ndarray:
        """Return the states at grid points ``j..jj`` from ``x`` at ``j``, shape (jj-j+1, 9)."""
        times = self.grid(np.arange(j, jj + 1))
        sched = self.schedule
        lo = max(int(np.searchsorted(sched.times, times[0], side="right")) - 1, 0)
        hi = int(np.searchsorted(sched.times, times[-1], side="left")) + 1
        near = Schedule(sched.times[lo:hi], sched.values[lo:hi])
        return propagate(x, self.coefficients, near.segments(times), self.h, self.const,
                         backend=self.backend)[0]

    def command_switch(self, when: float, positive: bool) -> None:
        """Record a commanded switch at ``when`` to the sign ``positive``."""
        value = self.law.delta_max_rad if positive else -self.law.delta_max_rad
        self.sign = positive
        self.commands[0].append(when)
        self.commands[1].append(value)
        self.track.switch(when + self.law.delay_s, value)
        self.schedule = self.track.schedule()

    # finding the next switch -------------------------------------------------------------
    def locate(self, xa: np.ndarray, ta: float, lo: float, hi: float) -> float:
        """Return the zero of the switching function in ``(lo, hi]`` (continuous relay)."""
        step = self.step_input(ta, hi)

        def s(when: float) -> float:
            x = self.advance(xa, step, when)
            return float(self.law.switching_function(x[PHI], when))

        f_lo, f_hi = s(lo), s(hi)
        if (f_lo >= 0.0) == self.sign and (f_hi >= 0.0) != self.sign and f_lo * f_hi <= 0:
            when = float(brentq(s, lo, hi, xtol=LOCATE_TOL_S, rtol=4 * np.finfo(float).eps))
        else:
            start = lo
            while hi - lo > LOCATE_TOL_S:  # ends not straddling zero: bisect on the sign
                mid = 0.5 * (lo + hi)
                if (s(mid) >= 0.0) == self.sign:
                    lo = mid
                else:
                    hi = mid
            when, lo = 0.5 * (lo + hi), start
        return min(max(when, float(np.nextafter(lo, hi))), hi)  # strictly after ``lo``

    def next_continuous(self, states: np.ndarray, j: int, after: float
                        ) -> tuple[int, float, bool] | None:
        """Return (step, instant, sign) of the first crossing in the chunk, or None."""
        signs = self.positive(states, self.grid(np.arange(j, j + len(states))))
        steps = np.flatnonzero(signs[1:] != self.sign)
        if steps.size == 0:
            return None
        i = int(steps[0])
        ta, tb = float(self.grid(j + i)), float(self.grid(j + i + 1))
        when = self.locate(states[i], ta, max(ta, after), tb)
        return i, when, not self.sign

    def next_control(self, states: np.ndarray, j: int, after: float
                     ) -> tuple[int, float, bool] | None:
        """Return (step, instant, sign) of the first control instant that switches, or None."""
        rate = float(self.control_rate_hz)  # type: ignore[arg-type]
        signs = self.positive(states, self.grid(np.arange(j, j + len(states))))
        for i in np.flatnonzero((signs[:-1] != self.sign) | (signs[1:] != self.sign)):
            ta, tb = float(self.grid(j + i)), float(self.grid(j + i + 1))
            first = math.floor(max(ta, after) * rate + CLOCK_SNAP) + 1
            last = math.floor(tb * rate + CLOCK_SNAP)
            if last < first:
                continue
            found = self._first_flip(states[i], ta, tb, signs[i], signs[i + 1], first, last, rate)
            if found is not None:
                return int(i), found, not self.sign
        return None

    def _first_flip(self, xa: np.ndarray, ta: float, tb: float, sign_a: bool, sign_b: bool,
                    first: int, last: int, rate: float) -> float | None:
        """Return the first control instant in the step whose sign differs, or None."""
        step = self.step_input(ta, tb)

        def instant(m: int) -> float:
            return self.snap(m / rate)

        def flips(m: int) -> bool:
            when = instant(m)
            if when >= tb:
                return bool(sign_b != self.sign)
            return bool(self.positive(self.advance(xa, step, when), when) != self.sign)

        if sign_a == sign_b:  # no crossing inside the step: every instant has sign_a
            return instant(first)
        if flips(first):
            return instant(first)
        if not flips(last):
            return None
        while last - first > 1:  # flips(first) is False, flips(last) is True
            mid = (first + last) // 2
            if flips(mid):
                last = mid
            else:
                first = mid
        return instant(last)

    # the loop ------------------------------------------------------------------------------
    def run(self, every: int) -> np.ndarray:
        """Integrate; return the states at grid points ``0, every, 2 every, ...``."""
        out = np.empty((self.n_steps // every + 1, self.x0.size))
        find = self.next_continuous if self.control_rate_hz is None else self.next_control
        x, j, after = self.x0, 0, -math.inf
        while j < self.n_steps:
            jj = min(j + CHUNK_STEPS, self.n_steps)
            states = self.chunk(x, j, jj)
            found = find(states, j, after)
            keep = len(states) if found is None else found[0] + 1
            first = -(-j // every) * every
            out[first // every:(j + keep - 1) // every + 1] = states[first - j:keep:every]
            if found is None:
                x, j = states[-1], jj
                continue
            i, when, sign = found
            self.command_switch(when, sign)
            x, j, after = states[i], j + i, when
        if self.n_steps == 0:
            out[0] = self.x0
        return out


__all__ = ["CHUNK_STEPS", "CLOCK_SNAP", "GRID_SNAP", "LOCATE_TOL_S", "RelayLoop"]
