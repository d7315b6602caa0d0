"""Equation-error's roll-moment regressors seen through the roll rate's derivative window.

The accelerometers cannot see the roll acceleration, so the roll moment of the EBM first
step is ``Ixx`` times the Savitzky-Golay derivative of the p gyro over
:data:`aeroid.estimation.ROLL_DERIVATIVE_WINDOW` samples (101: 0.2 s at 500 Hz; order
:data:`aeroid.estimation.ROLL_POLYORDER`), a smoothed moment, while the regressors of
its row (``qbar S d`` and ``qbar S d p d / 2V``) are taken sample by sample. In still air
the dynamic pressure is slow and the two agree; in turbulence the gusts along the path
move ``qbar`` within the window (3 m/s sd, tau ~1 s: ~2 m/s in 0.2 s, ~0.8 % of the
roll moment), the smoothed target cannot follow, and the fit check saw the roll moment's
residual at 2.6-3.4x its noise on fits given the true wind (4 of 8 refused in Dryden
sd 3, benchmarks/bench_air_data.py).

The derivative operator ``D`` (the same ``savgol_filter(..., deriv=1, mode="interp")``
with the same window) annihilates constants, so ``D[p] = D[integral of pdot dt]``: the
target is ``S[Ixx pdot]`` with ``S[x] = D[cumulative trapezoid of x]``, ends included.
:func:`roll_window_blocks` passes the roll row's regressors through the same ``S``, so
target and regressors see one window (to the trapezoid's O(dt^2)); the other rows are
untouched. Measured on the true-wind fits of the same 8 flights (Dryden sd 3): the roll
moment's residual 0.75-1.63x its noise (2.6-3.4x before), Cl0's mean |error| 0.83 %
(1.30 % before); in still air both within 0.02 % of before.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator

import numpy as np
from scipy.integrate import cumulative_trapezoid
from scipy.signal import savgol_filter

from aeroid import estimation as rc
from aeroid.flights import Flight

#: The roll moment's row of the loads (the SEBM sub-problem "MX"), read from its definition.
ROLL_ROW = next(p.row for p in rc.SEBM_PROBLEMS if p.label == "MX")

Blocks = Iterable[tuple[int, int, np.ndarray]]


def roll_window(flight: Flight) -> int:
    """The p derivative's window [samples] of :func:`aeroid.estimation.reconstruct` with
    its defaults on ``flight`` (clipped to the record as it clips it)."""
    n = flight.n_samples
    return min(rc.ROLL_DERIVATIVE_WINDOW, n - 1 + n % 2)


def through_roll_window(flight: Flight, x: np.ndarray) -> np.ndarray:
    """``S[x]``: ``x`` (n, ...) seen as the p derivative's window sees ``pdot`` (module
    docstring)."""
    integral = cumulative_trapezoid(x, dx=flight.dt, axis=0, initial=0.0)
    return savgol_filter(integral, roll_window(flight), rc.ROLL_POLYORDER, deriv=1,
                         delta=flight.dt, axis=0, mode="interp")


def roll_window_blocks(flight: Flight, blocks: Callable[[], Blocks]
                       ) -> Callable[[], Iterator[tuple[int, int, np.ndarray]]]:
    """Return a callable like ``blocks`` (yielding ``(start, stop, X[start:stop])`` with
    ``X`` (n, 6, n_coefficients)) whose roll-moment row went through :func:`through_roll_window`.

    One pass over ``blocks()`` collects that row (n, n_coefficients); each call of the
    returned callable then yields ``blocks()``'s blocks with it replaced.
    """
    row = np.concatenate([part[:, ROLL_ROW, :] for _, _, part in blocks()], axis=0)
    seen = through_roll_window(flight, row)

    def replaced() -> Iterator[tuple[int, int, np.ndarray]]:
        for start, stop, part in blocks():
            part = np.array(part, dtype=float)
            part[:, ROLL_ROW, :] = seen[start:stop]
            yield start, stop, part

    return replaced


__all__ = ["ROLL_ROW", "roll_window", "roll_window_blocks", "through_roll_window"]
