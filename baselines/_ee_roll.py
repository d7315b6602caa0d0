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
untouched. It is used where the regressors take a wind that varies per sample (the air
data's), else the row stays per sample: measured over 30 true-wind fits
(``python benchmarks/bench_air_data_roll.py``), tactical IMU: in Dryden sd 3 the roll
moment's residual 0.69-1.96x its noise (2.17-3.47x per sample: 8/30 refused), Cl0's mean
|error| 0.87 % (1.11 %); in still air the same as per sample (0.82 %); but under the
paper's noise (``--noise paper``: 5 % on p, which then also sits in Clp's regressor) the
window takes Cl0 from 89 to 222 % (still air) and from 80 to 267 % (Dryden sd 3), so it
is not used without air data.

The roll pair's standard errors (:func:`with_roll_covariance`). The target's noise is the
p gyro's white noise through ``D``, whose gain vanishes at zero frequency: the residual's
autocovariances sum to ~0 and the Newey-West estimate of its long-run variance, which
sums them, was too small where the slow regressors look (Cl0's and Clp's intervals ~1.4x
too narrow: mean z^2 2.0 over 30 still-air flights, coverage 0.83). The structure is
known, so the covariance is the sandwich ``s^2 (A^T A)^-1 A^T D D^T A (A^T A)^-1`` with
the scale ``s^2`` from the residual (:func:`roll_covariance`; ``D`` applied in its bands,
:func:`derivative_adjoint`): mean z^2 1.00 over the same 30 flights (0.91 under the
paper's noise), 0.93 on 30 Dryden
sd 3 flights with the true wind (benchmarks/bench_air_data.py for the smoothed winds).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator

import numpy as np
from scipy.integrate import cumulative_trapezoid
from scipy.signal import savgol_coeffs, savgol_filter

from aeroid import estimation as rc
from aeroid.flights import Flight

#: The roll moment's row of the loads (the SEBM sub-problem "MX"), read from its definition.
ROLL_ROW = next(p.row for p in rc.SEBM_PROBLEMS if p.label == "MX")

Blocks = Iterable[tuple[int, int, np.ndarray]]


def roll_window(flight: Flight) -> int:
    """The p derivative's window [samples] of :func:`aeroid.estimation.reconstruct` with
    its defaults on ``flight`` (clipped to the record as it clips it)."""
    return rc.roll_window_samples(flight.n_samples)


def through_roll_window(flight: Flight, x: np.ndarray) -> np.ndarray:
    """``S[x]``: ``x`` (n, ...) seen as the p derivative's window sees ``pdot`` (module
    docstring)."""
    integral = cumulative_trapezoid(x, dx=flight.dt, axis=0, initial=0.0)
    return savgol_filter(integral, roll_window(flight), rc.ROLL_POLYORDER, deriv=1,
                         delta=flight.dt, axis=0, mode="interp")


class RollBlocks:
    """A callable like ``blocks`` (yielding ``(start, stop, X[start:stop])`` with ``X``
    (n, 6, n_coefficients)) whose roll-moment row went through :func:`through_roll_window`
    when the regressors' ``wind`` (n, 3) [m/s] varies from sample to sample (the air data's;
    module docstring), else the blocks themselves.

    :attr:`roll_row` (n, n_coefficients), that row as the fit saw it, for
    :func:`with_roll_covariance`. Windowed, the window needs the whole row first: one pass
    over ``blocks()`` collects it before the fit's. Per sample, the fit's own first full
    pass collects it (a pass of its own only if asked before one).
    """

    def __init__(self, flight: Flight, wind: np.ndarray | None, blocks: Callable[[], Blocks]):
        self._blocks = blocks
        self.windowed = wind is not None and bool(np.any(np.ptp(wind, axis=0) > 0))
        self._row: np.ndarray | None = None
        if self.windowed:
            self._row = through_roll_window(flight, _collect(blocks()))

    def __call__(self) -> Iterator[tuple[int, int, np.ndarray]]:
        """Yield the blocks (the roll row windowed, or collected on this pass)."""
        rows: list[np.ndarray] | None = [] if self._row is None else None
        for start, stop, part in self._blocks():
            if self.windowed:
                part = np.array(part, dtype=float)
                part[:, ROLL_ROW, :] = self._row[start:stop]
            elif rows is not None:
                rows.append(np.array(part[:, ROLL_ROW, :], dtype=float))
            yield start, stop, part
        if rows is not None:  # a whole pass: its row
            self._row = np.concatenate(rows, axis=0)

    @property
    def roll_row(self) -> np.ndarray:
        """The roll-moment row of the regressors the fit saw, shape (n, n_coefficients)."""
        if self._row is None:
            self._row = _collect(self._blocks())
        return self._row


def _collect(blocks: Blocks) -> np.ndarray:
    """The roll-moment row of ``blocks`` concatenated, shape (n, n_coefficients)."""
    return np.concatenate([part[:, ROLL_ROW, :] for _, _, part in blocks], axis=0)


def roll_window_blocks(flight: Flight, wind: np.ndarray | None, blocks: Callable[[], Blocks]
                       ) -> RollBlocks:
    """Return ``blocks`` with the roll row through the window where ``wind`` varies
    (:class:`RollBlocks`)."""
    return RollBlocks(flight, wind, blocks)


def _derivative_rows(flight: Flight) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The p derivative operator ``D`` (n, n) in bands: the interior rows' weights (w,),
    the first and the last ``w // 2`` rows' (their window's polynomial fit, as
    ``savgol_filter(mode="interp")``), each (w // 2, w)."""
    w, dt = roll_window(flight), flight.dt
    m = w // 2

    def coeffs(pos: int | None) -> np.ndarray:
        return savgol_coeffs(w, rc.ROLL_POLYORDER, deriv=1, delta=dt, pos=pos, use="dot")

    return (coeffs(None), np.stack([coeffs(k) for k in range(m)]),
            np.stack([coeffs(w - m + k) for k in range(m)]))


def derivative_adjoint(flight: Flight, x: np.ndarray) -> np.ndarray:
    """``D^T x`` for ``x`` (n, c), ``D`` the p derivative operator (banded, O(n w))."""
    h, head, tail = _derivative_rows(flight)
    n, w, m = len(x), len(h), len(h) // 2
    out = np.zeros(x.shape)
    inner = x[m:n - m]
    for i, weight in enumerate(h):  # row k (m <= k < n - m) puts h[i] x_k at k - m + i
        out[i:i + len(inner)] += weight * inner
    out[:w] += head.T @ x[:m]
    out[n - w:] += tail.T @ x[n - m:]
    return out


def roll_covariance(flight: Flight, regressors: np.ndarray, target: np.ndarray,
                    theta: np.ndarray) -> np.ndarray:
    """The covariance of the roll sub-problem's least squares from its noise's known
    structure (module docstring): ``s^2 (A^T A)^-1 A^T D D^T A (A^T A)^-1``.

    ``regressors`` ``A`` (n, k) the roll row's (through the window), ``target`` (n,) its
    loads, ``theta`` (k,) their estimate. The target's noise is the p gyro's white noise
    through ``D`` times a constant ``s``, fitted to the residual: ``E|e|^2 = s^2 (|D|_F^2
    - tr((A^T A)^-1 A^T D D^T A))``.
    """
    h, head, tail = _derivative_rows(flight)
    n = len(target)
    frobenius = (n - 2 * (len(h) // 2)) * h @ h + np.sum(head**2) + np.sum(tail**2)
    g = derivative_adjoint(flight, regressors)  # D^T A
    inv = np.linalg.inv(regressors.T @ regressors)
    dd = g.T @ g  # A^T D D^T A
    e = target - regressors @ theta
    s2 = float(e @ e) / (frobenius - float(np.trace(inv @ dd)))
    cov = s2 * inv @ dd @ inv
    return 0.5 * (cov + cov.T)


def with_roll_covariance(flight: Flight, blocks: RollBlocks, y: np.ndarray, theta: np.ndarray,
                         cov: np.ndarray, covariance: str, holds: object = None,
                         smoothing: str = "none") -> np.ndarray:
    """``cov`` with the roll sub-problem's block from :func:`roll_covariance`, in place of
    the Newey-West default (``covariance = "hac"``), on unsmoothed loads (``smoothing =
    "none"``, the default: smoothed ones have another noise structure) and without holds
    (whose priors and held terms the sub-problem's least squares then carries);
    ``blocks`` from :func:`roll_window_blocks`."""
    if covariance != "hac" or holds is not None or smoothing != "none":
        return cov
    cols = list(next(p.coefficients for p in rc.SEBM_PROBLEMS if p.row == ROLL_ROW))
    a = blocks.roll_row[:, cols]
    out = np.array(cov, dtype=float)
    out[np.ix_(cols, cols)] = roll_covariance(flight, a, y[:, ROLL_ROW], theta[cols])
    return out


__all__ = ["ROLL_ROW", "RollBlocks", "derivative_adjoint", "roll_covariance", "roll_window",
           "roll_window_blocks", "through_roll_window", "with_roll_covariance"]
