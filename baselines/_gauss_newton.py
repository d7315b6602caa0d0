"""Damped Gauss-Newton with the noise-covariance relaxation (Klein & Morelli, ch. 6).

The output-error baseline's solver: measurement noise Gaussian, white, with unknown
diagonal covariance ``R``; Gauss-Newton on the weighted least-squares cost
``1/2 sum_k e_k^T R^-1 e_k`` with Levenberg damping, and ``R_jj = mean_k e_kj^2``
re-estimated after every accepted step (the relaxation technique), until the
Gauss-Newton step is below ``tol`` standard deviations and ``R`` has settled.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from aeroid.model import Buffered

#: A trial step is accepted when it does not raise the cost by more than this fraction
#: (rounding: at a noise-free optimum the cost is flat to the last digits).
COST_RTOL = 1e-12
#: A step below this (in units of the prior values) with R settled also ends the fit.
STALL_STEP = 1e-8
#: R has settled when no R_jj changed by more than this fraction at the last update.
R_SETTLED_RTOL = 1e-3
#: Largest Levenberg damping tried before an iteration is declared stuck.
MAX_DAMPING = 1e8


@dataclass(frozen=True)
class Problem:
    """A flight turned into arrays for the Gauss-Newton loop."""

    z: np.ndarray          # (n, 9) measurements
    scale: np.ndarray      # (n_p,)
    x0_meas: np.ndarray    # (9,)
    delta: np.ndarray      # (1, n)
    pos: np.ndarray        # (6,)
    simulate: Buffered
    jacobian: Buffered
    r_floor: np.ndarray    # (9,)
    compiled: bool         # the per-step functions run as compiled C

    def residuals(self, p: np.ndarray) -> np.ndarray:
        """Return ``z - y(p)``, shape (n, 9)."""
        (y,) = self.simulate(p)
        n = self.z.shape[0]
        return self.z - y.reshape(9, n).T

    def residuals_jacobian(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return ``z - y(p)`` (n, 9) and ``dy/dp`` (9, n, n_p)."""
        y, dy = self.jacobian(p)
        n = self.z.shape[0]
        # dY (9, n n_p) column-major: entry (j, k n_p + i) at (k n_p + i) 9 + j
        J = dy.reshape(n, -1, 9).transpose(2, 0, 1).copy()
        return self.z - y.reshape(9, n).T, J

    def noise(self, e: np.ndarray) -> np.ndarray:
        """Return the ML estimate of diag(R), shape (9,), from residuals (floored)."""
        return np.maximum(np.mean(e * e, axis=0), self.r_floor)


def _cost(e: np.ndarray, r_diag: np.ndarray) -> float:
    value = 0.5 * float(np.sum(e * e / r_diag))
    return value if math.isfinite(value) else math.inf


def _nll(e: np.ndarray, r_diag: np.ndarray) -> float:
    """Negative log-likelihood without constants: ``n/2 sum log R_jj + cost``."""
    return _cost(e, r_diag) + 0.5 * e.shape[0] * float(np.sum(np.log(r_diag)))


def fisher_information(J: np.ndarray, e: np.ndarray, r_diag: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Return the Fisher information ``sum J^T R^-1 J`` and gradient ``sum J^T R^-1 e``."""
    w = 1.0 / np.sqrt(r_diag)
    Jw = (J * w[:, None, None]).reshape(-1, J.shape[-1])
    ew = (e * w[None, :]).T.reshape(-1)
    return Jw.T @ Jw, Jw.T @ ew


@dataclass(frozen=True)
class Fit:
    """One Gauss-Newton run: final parameters, residuals, Jacobian, R and its history."""

    p: np.ndarray
    e: np.ndarray
    J: np.ndarray
    r_diag: np.ndarray
    nll: float
    history_p: list
    history_cost: list
    n_iterations: int
    n_evaluations: int
    converged: bool
    message: str


def gauss_newton(prob: Problem, p0: np.ndarray, *, max_iterations: int, tol: float) -> Fit:
    """Run damped Gauss-Newton with the R relaxation from scaled parameters ``p0``.

    Each iteration: the Fisher information ``M`` and gradient ``g`` at the current
    point with the current ``R``; if the undamped Gauss-Newton step ``M^-1 g`` is
    below ``tol`` Cramér-Rao standard deviations in every parameter, ``R`` is
    re-estimated and the fit has converged once ``R`` has settled (relative change
    below :data:`R_SETTLED_RTOL`); otherwise a Levenberg-damped step that lowers the
    cost (damping x10 per rejected trial, /10 after a success) is taken and ``R`` is
    re-estimated from the new residuals (relaxation at every step: holding ``R``
    until Gauss-Newton converged, Klein & Morelli's textbook variant, took 2-3x more
    iterations on the reference flight).
    """
    p = np.array(p0, dtype=float)
    e, J = prob.residuals_jacobian(p)
    n_eval = 1
    if not np.all(np.isfinite(e)):
        raise FloatingPointError("the model diverges at the starting point")
    r_diag = prob.noise(e)
    damping = 1e-3
    history_p = [p.copy()]
    history_cost = [_nll(e, r_diag)]
    converged, message, it = False, "", 0
    for it in range(1, max_iterations + 1):
        cost = _cost(e, r_diag)
        M, g = fisher_information(J, e, r_diag)
        try:
            cov_now = np.linalg.inv(M)
            ratio = np.abs(cov_now @ g) / np.sqrt(np.abs(np.diag(cov_now)) + 1e-300)
            small = bool(np.all(np.isfinite(ratio)) and np.max(ratio) < tol)
        except np.linalg.LinAlgError:
            ratio = np.full(p.size, np.inf)
            small = False
        if small:
            r_new = prob.noise(e)
            settled = bool(np.max(np.abs(r_new / r_diag - 1.0)) < R_SETTLED_RTOL)
            r_diag = r_new
            history_cost[-1] = _nll(e, r_diag)
            if settled:
                converged = True
                message = f"converged after {it} iterations"
                break
            continue
        diag = np.diag(M).copy()
        diag[diag <= 0] = 1.0
        while True:
            try:
                step = np.linalg.solve(M + damping * np.diag(diag), g)
            except np.linalg.LinAlgError:
                step = np.full_like(p, np.nan)
            if np.all(np.isfinite(step)):
                e_new = prob.residuals(p + step)
                n_eval += 1
                if _cost(e_new, r_diag) <= cost * (1.0 + COST_RTOL):
                    break
            damping *= 10.0
            if damping > MAX_DAMPING:
                break
        if damping > MAX_DAMPING:
            # no step lowers the cost: a numerical minimum (noise-free data end here,
            # the cost being at rounding level); accepted when the Gauss-Newton step
            # is within one standard deviation
            converged = bool(np.all(np.isfinite(ratio)) and np.max(ratio) < 1.0)
            message = ("converged: no cost-decreasing step (numerical minimum)"
                       if converged else "no cost-decreasing step (damping limit reached)")
            break
        near_gauss_newton = damping <= 1e-2
        damping = max(damping / 10.0, 1e-12)
        p = p + step
        e, J = prob.residuals_jacobian(p)
        n_eval += 1
        r_new = prob.noise(e)
        settled = bool(np.max(np.abs(r_new / r_diag - 1.0)) < R_SETTLED_RTOL)
        r_diag = r_new
        history_p.append(p.copy())
        history_cost.append(_nll(e, r_diag))
        if settled and near_gauss_newton and float(np.max(np.abs(step))) < STALL_STEP:
            # noise-free data: the residuals are the model's own discretisation error,
            # the standard deviations shrink with them and the sd-relative test is
            # never met; nearly undamped steps have stopped moving the parameters
            converged = True
            message = f"converged after {it} iterations (parameters stalled)"
            break
    else:
        message = f"max_iterations ({max_iterations}) reached"
    return Fit(p, e, J, r_diag, history_cost[-1], history_p, history_cost, it, n_eval,
                converged, message)

