"""Least squares of the equation-error baseline: the SEBM sub-problems and their covariance.

:func:`solve_subproblems` takes the regressors of the EBM second step as the one-shot
``n x 6 x 9`` array or as its time blocks (:func:`aeroid.estimation.regressor_blocks`),
copying only each sub-problem's own columns; :mod:`baselines.equation_error` uses the
blocks (the method and its measurements are documented there).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np
import scipy.linalg

import aeroid
from aeroid import estimation as rc
from baselines._held import ee_prior_rows
from baselines.newey_west import (
    MAX_CORRELATION_LENGTH,
    hac_covariance,
    residual_correlation_length,
)

#: scipy.linalg.lstsq driver: SVD-based like the default gelsd (minimum-norm answer when
#: rank deficient) but 2-4x faster on the one-step (4509 x 9) problem here (measured).
LAPACK_DRIVER = "gelss"
#: (label, FM row, coefficient indices) of the SEBM sub-problems (eqs. 39-42): read from
#: their one definition, :data:`aeroid.estimation.SEBM_PROBLEMS`.
SUBPROBLEMS: tuple[tuple[str, int, tuple[int, ...]], ...] = tuple(
    (p.label, p.row, p.coefficients) for p in rc.SEBM_PROBLEMS)
#: Lateral rows joined with ``lateral_rows``: (target problem, FM row).
LATERAL = {"FAZ": 1, "MY": 5}



def _correlation(A: np.ndarray) -> np.ndarray:
    """Correlation matrix of the columns of ``A`` (uncentred: the regressions have no
    intercept, so collinearity is about the angle between columns)."""
    norms = np.sqrt(np.sum(A * A, axis=0))
    norms[norms == 0] = 1.0
    An = A / norms
    return An.T @ An


def _lstsq(A: np.ndarray, b: np.ndarray, *, n_time: int | None = None,
           covariance: str = "hac") -> tuple[np.ndarray, np.ndarray, float, dict]:
    """Least squares with column scaling.

    ``covariance="ols"`` gives ``sigma^2 (A^T A)^-1`` (white residuals);
    ``"hac"`` the Newey-West covariance over ``n_time`` time samples (rows time-major)
    with the lag window set to twice the residuals' correlation length: Bartlett
    weights halve the autocovariance at ``lags / 2``, so a window of the correlation
    length itself would count only about half of it. The correlation length is capped
    at ``min(n_time // 4, MAX_CORRELATION_LENGTH)``.

    Returns
    -------
    theta, covariance, residual variance, and ``{"lags": bandwidth, "capped": bool}``
    (``lags`` 0 with ``"ols"``; ``capped``: the correlation length reached its cap).
    """
    scale = np.sqrt(np.sum(A * A, axis=0))
    scale[scale == 0] = 1.0
    sol, _, rank, _ = scipy.linalg.lstsq(A / scale, b, lapack_driver=LAPACK_DRIVER)
    theta = sol / scale
    dof = max(A.shape[0] - A.shape[1], 1)
    resid = b - A @ theta
    sigma2 = float(resid @ resid) / dof
    As = A / scale
    if covariance == "hac":
        n_time = A.shape[0] if n_time is None else n_time
        cap = min(n_time // 4, MAX_CORRELATION_LENGTH)
        length = residual_correlation_length(resid.reshape(n_time, -1), cap=cap)
        lags = 2 * length
        bandwidth = {"lags": lags, "capped": length >= cap}
        cov = hac_covariance(As, resid, n_time, lags) * (A.shape[0] / dof)
        cov = cov / np.outer(scale, scale)
    else:
        cov = sigma2 * np.linalg.pinv(As.T @ As) / np.outer(scale, scale)
        bandwidth = {"lags": 0, "capped": False}
    if rank < A.shape[1]:
        cov[:] = np.nan
    return theta, cov, sigma2, bandwidth


def _subproblem_arrays(X, y: np.ndarray, sd: np.ndarray, lateral_rows: bool) -> list:
    """Return ``[(label, cols, A, b)]`` of the sub-problems, rows weighted by ``1 / sd``.

    ``A`` (n k, len(cols)) and ``b`` (n k,) are time-major (the k rows of one sample
    consecutive, for the HAC covariance); ``X`` is the (n, 6, 9) array or the blocks of
    :func:`aeroid.estimation.regressor_blocks`, whose entries are copied into ``A`` block by
    block (the full ``X`` is never held).
    """
    n = y.shape[0]
    problems = []
    for label, row, cols in SUBPROBLEMS:
        rows = [row] + ([LATERAL[label]] if lateral_rows and label in LATERAL else [])
        b = np.stack([y[:, r] / sd[r] for r in rows], axis=1).reshape(-1)
        # column-major, as numpy's fancy indexing of X gives it: the least-squares
        # solution's last bits depend on the layout, and they stay those of the one-shot X
        # (column, sample, row) in C order is A, (n k, len(cols)), in Fortran order
        problems.append((label, list(cols), rows, np.empty((len(cols), n, len(rows))), b))
    blocks = [(0, n, X)] if isinstance(X, np.ndarray) else X
    for start, stop, part in blocks:
        for _, cols, rows, columns, _ in problems:
            for i, r in enumerate(rows):
                columns[:, start:stop, i] = (part[:, r, cols] / sd[r]).T
    return [(label, cols, columns.reshape(len(cols), -1).T, b)
            for label, cols, _, columns, b in problems]


def solve_subproblems(X, y: np.ndarray, sd: np.ndarray, *,
                      lateral_rows: bool = False, covariance: str = "hac",
                      held: dict[int, float] | None = None, holds: Any = None) -> tuple:
    """Solve the four SEBM least-squares sub-problems of the EBM regression.

    Parameters
    ----------
    X : ndarray, shape (n, 6, 9), or iterable of (start, stop, ndarray)
        Regressors (:func:`aeroid.estimation.ebm_regression`), or their time blocks
        (:func:`aeroid.estimation.regressor_blocks`: the same numbers, the memory of one
        block plus the sub-problems' own columns, 9 per sample instead of 54).
    y : ndarray, shape (n, 6) [N, N m]
        Reconstructed forces and moments.
    sd : ndarray, shape (6,)
        Noise sd per force/moment channel (row weights; they matter only with
        ``lateral_rows``, which stacks two channels in one problem).
    lateral_rows : bool
    covariance : {"hac", "ols"}
        Newey-West or white-residual covariance (:func:`_lstsq`).
    held : dict of int -> float, optional
        Coefficient index -> value of held coefficients: their columns move to the left
        side (``b - A_h theta_h``); their covariance is zero.
    holds : CoefficientSpec, optional
        Its priors join their sub-problem as weighted pseudo-observations
        (:func:`baselines._held.ee_prior_rows`).

    Returns
    -------
    theta : ndarray, shape (9,)
    covariance : ndarray, shape (9, 9)
        Block diagonal, per sub-problem (Newey-West, or ``sigma^2 (X^T X)^-1``).
    correlation : ndarray, shape (9, 9)
        Regressor correlation within each sub-problem, NaN across.
    sigma2 : dict
        Residual variance (weighted units) per sub-problem.
    cost : float
        Total weighted residual sum of squares.
    bandwidth : dict
        Per sub-problem, the Newey-West bandwidth ``{"lags": int, "capped": bool}``
        (:func:`_lstsq`).
    """
    n_c = aeroid.model.N_COEFFICIENTS
    theta = np.full(n_c, np.nan)
    cov = np.zeros((n_c, n_c))
    corr = np.full((n_c, n_c), np.nan)
    sigma2, bandwidth, cost = {}, {}, 0.0
    problems = _subproblem_arrays(X, y, sd, lateral_rows)
    while problems:  # each problem's columns are freed once it is solved
        label, cols, A, b = problems.pop(0)
        if held:  # held terms to the left side
            local = [i for i, c in enumerate(cols) if c in held]
            b = b - A[:, local] @ np.array([held[cols[i]] for i in local])
            theta[[cols[i] for i in local]] = [held[cols[i]] for i in local]
            A, cols = np.delete(A, local, axis=1), [c for c in cols if c not in held]
            if not cols:
                continue
        th, cv, s2, bandwidth[label] = _lstsq(A, b, n_time=y.shape[0], covariance=covariance)
        th, cv = ee_prior_rows(A, b, th, cv, s2, cols, holds)
        theta[cols] = th
        cov[np.ix_(cols, cols)] = cv
        corr[np.ix_(cols, cols)] = _correlation(A)
        sigma2[label] = s2
        cost += s2 * max(A.shape[0] - len(cols), 1)
        del A, b
    return theta, cov, corr, sigma2, cost, bandwidth



def one_step_target(flight: Any, c: np.ndarray, A: np.ndarray, smoothing: str
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The one-step regression's measurements, target and regressors of ``flight``.

    ``c`` and ``A``: the accelerations' affine form ``c + A theta`` (both triads and the
    rate derivatives). Returns ``meas`` (n, outputs), ``target = meas - c`` and ``A``,
    smoothed as ``smoothing`` says (``forces``: the target; ``both``: the regressors too).
    """
    n = flight.n_samples
    meas = np.concatenate([flight.accelerations().reshape(n, 6),
                           rc.rate_derivatives(flight)], axis=1)
    target = meas - c
    if smoothing in ("forces", "both"):
        target = rc.smooth(target)
    if smoothing == "both":
        A = rc.smooth(A, axis=0)
    return meas, target, A

def with_position_consider(result: Any, given: np.ndarray, sd: np.ndarray,
                           theta_at: Callable[[np.ndarray], np.ndarray]) -> Any:
    """``result`` with the uncertain accelerometer positions as consider parameters.

    ``given`` and ``sd``: the six position components [m] and their sds (> 0: uncertain);
    ``theta_at(positions)``: the estimate re-solved at other positions. The sensitivity
    ``G`` is the central difference at +-1 sd; the covariance gains ``G diag(sd^2) G^T``
    (``info['position_sensitivity']``, ``info['position_components']``).
    """
    free = np.flatnonzero(sd)
    G = np.empty((np.size(result.theta), free.size))
    for j, c in enumerate(free):
        ends = []
        for sign in (1.0, -1.0):
            pos = np.array(given, dtype=float)
            pos[c] += sign * sd[c]
            ends.append(np.asarray(theta_at(pos), dtype=float))
        G[:, j] = (ends[0] - ends[1]) / (2.0 * sd[c])
    cov = result.covariance + (G * sd[free] ** 2) @ G.T
    info = {**result.info, "position_sensitivity": G,
            "position_components": [int(c) for c in free]}
    return dataclasses.replace(result, covariance=cov, stderr=np.sqrt(np.abs(np.diag(cov))),
                               info=info)


def moved_positions(airframe: Any, pos: np.ndarray) -> Any:
    """``airframe`` with its two triads at ``pos`` (six components [m])."""
    return airframe.replace(accel1_position_m=tuple(pos[:3]), accel2_position_m=tuple(pos[3:]))
