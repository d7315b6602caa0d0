"""Damped Gauss-Newton with the noise-covariance relaxation (Klein & Morelli, ch. 6).

The output-error baseline's solver: measurement noise Gaussian, white, with unknown
diagonal covariance ``R``; Gauss-Newton on the weighted least-squares cost
``1/2 sum_k e_k^T R^-1 e_k`` with Levenberg damping, and ``R_jj = mean_k e_kj^2``
re-estimated after every accepted step (the relaxation technique), until the
Gauss-Newton step is below ``tol`` standard deviations and ``R`` has settled. With the
per-sample noise law (``signal``) the re-estimate is that law's likelihood maximum
(:func:`most_likely_law`), so neither half-step can lower the likelihood.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from aeroid import estimation
from aeroid.estimation import report_progress

#: A trial step is accepted when it does not raise the cost by more than this fraction
#: (rounding: at a noise-free optimum the cost is flat to the last digits).
COST_RTOL = 1e-12
#: A step below this (in units of the prior values) with R settled also ends the fit.
STALL_STEP = 1e-8
#: R has settled when no R_jj changed by more than this fraction at the last update.
R_SETTLED_RTOL = 1e-3
#: Largest Levenberg damping tried before an iteration is declared stuck.
MAX_DAMPING = 1e8


class OutputModel(Protocol):
    """What the solver needs of a model: outputs and their Jacobian in scaled parameters."""

    def outputs(self, p: np.ndarray) -> np.ndarray:
        """Return the predicted outputs ``y(p)``, shape (n, m)."""
        ...

    def outputs_jacobian(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return ``y(p)`` (n, m) and ``dy/dp`` (m, n, n_p)."""
        ...


#: Noise models of the measurement errors (:meth:`Problem.noise`).
NOISE_MODELS: tuple[str, ...] = ("channel", "signal")
#: Floor of the signal-independent part ``a_c`` of the ``signal`` noise model, as a
#: fraction of the channel's mean squared residual: a sample whose modelled variance
#: would be ~0 (a zero crossing under multiplicative noise) gets at most 1/A_FLOOR_REL
#: times the channel's typical weight. The floor is a numerical guard, not a belief about
#: the noise, and the Fisher covariance takes the floored variance as the true one: at
#: 1e-4 (the former value) output-error's intervals were 1.1-1.4x its actual spread under
#: the paper's noise, coverage 0.989 and 0.489 % mean error; at 1e-6 coverage 0.964 and
#: 0.468 % (``aeroid study studies/paper_table5_prior.toml``, 50 runs, at commits
#: b008e8f and 9d489cc; data with additive noise have a_c well above either floor).
A_FLOOR_REL = 1e-6
#: The noise law's likelihood maximisation (:func:`most_likely_law`) ends when no
#: channel's negative log-likelihood falls by more than this in an iteration (a law
#: that much less likely moves no coefficient visibly), or after LAW_MAX_ITERATIONS.
LAW_NLL_TOL = 1e-6
LAW_MAX_ITERATIONS = 100
#: Smallest fraction of a scoring step tried before that channel's law stays put.
LAW_MIN_STEP = 1e-9


@dataclass(frozen=True)
class Problem:
    """A fit for the Gauss-Newton loop: measurements, model, noise model and prior.

    Attributes
    ----------
    z : ndarray, shape (n, m)
        Measurements.
    model : OutputModel
    r_floor : ndarray, shape (m,)
        Floor of every variance (keeps the weights finite on noise-free data).
    noise_model : {"channel", "signal"}
        ``channel``: one variance per channel, ``R_c = mean_k e_kc^2`` (Klein & Morelli);
        ``signal``: per sample, ``R_kc = a_c + b_c yhat_kc^2`` with ``a_c, b_c >= 0`` the
        maximum-likelihood law (:func:`most_likely_law`, started from the weighted
        non-negative least squares of ``e_kc^2`` on ``[1, yhat_kc^2]``,
        :func:`aeroid.estimation.fit_noise_law`, or from ``b_c = 0`` where that is
        likelier), ``a_c`` floored at :data:`A_FLOOR_REL` of the mean squared residual.
    prior_mean, prior_weight : ndarray, shape (n_p,), optional
        A Gaussian prior on the scaled parameters (MAP): mean and inverse variance (0: no
        prior on that parameter).
    """

    z: np.ndarray
    model: OutputModel
    r_floor: np.ndarray
    noise_model: str = "channel"
    prior_mean: np.ndarray | None = None
    prior_weight: np.ndarray | None = None

    def residuals(self, p: np.ndarray) -> np.ndarray:
        """Return ``z - y(p)``, shape (n, m)."""
        return self.z - self.model.outputs(p)

    def residuals_jacobian(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return ``z - y(p)`` (n, m) and ``dy/dp`` (m, n, n_p)."""
        y, J = self.model.outputs_jacobian(p)
        return self.z - y, J

    def noise(self, e: np.ndarray) -> np.ndarray:
        """Return the ML estimate of the error variances from residuals ``e`` (floored).

        Shape (m,) for ``channel``, (n, m) for ``signal``.
        """
        ms = np.maximum(np.mean(e * e, axis=0), self.r_floor)
        if self.noise_model == "channel":
            return ms
        y2 = (self.z - e) ** 2
        floor = A_FLOOR_REL * ms
        a, b = estimation.fit_noise_law(e * e, y2, floor=floor)
        # the regression's law is the start; one variance per channel (b = 0), a member
        # of the law, where it is the likelier
        uniform = _law_nll(e * e, y2, ms, 0.0) < _law_nll(e * e, y2, a, b)
        a, b = most_likely_law(e * e, y2, np.where(uniform, ms, a),
                               np.where(uniform, 0.0, b), floor=floor)
        return np.maximum(a + b * y2, self.r_floor)

    def prior_terms(self, p: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """Return the prior's cost, gradient term and information (all zero without one)."""
        if self.prior_weight is None or self.prior_mean is None:
            return 0.0, np.zeros_like(p), np.zeros((p.size, p.size))
        d = self.prior_mean - p
        return (0.5 * float(np.sum(self.prior_weight * d * d)), self.prior_weight * d,
                np.diag(self.prior_weight))


def _law_nll(e2: np.ndarray, s2: np.ndarray, a: np.ndarray | float,
             b: np.ndarray | float) -> np.ndarray:
    """Negative log-likelihood per channel of the law ``a + b s2``, shape (m,)."""
    var = a + b * s2
    return 0.5 * np.sum(e2 / var + np.log(var), axis=0)


def most_likely_law(e2: np.ndarray, s2: np.ndarray, a: np.ndarray, b: np.ndarray, *,
                    floor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the maximum-likelihood noise law ``var = a + b s2`` per channel from a start.

    Newton's method on the Gaussian likelihood of the residuals where its curvature is
    positive, else Fisher scoring (whose full step is the reweighted regression of
    :func:`aeroid.estimation.fit_noise_law`), each step halved until the likelihood
    does not fall, within ``a >= floor``, ``b >= 0``. The regression alone makes a fixed
    number of unguarded steps and can oscillate: on the residuals of a poor iterate (a
    paper-noise flight, ay1) it alternated between ``b = 0`` with a variance 50 times
    below the residuals' and ``a`` at its floor, a likelihood 1.2e4 worse than one
    variance per channel, and Gauss-Newton then fitted those weights into a poorer
    optimum (issue 18: 2 of 200 paper-condition runs from a prior 10-25 % off).

    Parameters
    ----------
    e2, s2 : ndarray, shape (n, m)
        Squared residuals and squared model outputs.
    a, b : ndarray, shape (m,)
        The start.
    floor : ndarray, shape (m,)
        Lower bound of ``a``.
    """
    floor = np.broadcast_to(np.asarray(floor, dtype=float), np.shape(a))
    a, b = np.maximum(a, floor), np.maximum(b, 0.0)
    active = np.arange(a.size)  # channels still moving
    for _ in range(LAW_MAX_ITERATIONS):
        if active.size == 0:
            break
        ca, cb, fl, e2c, s2c = a[active], b[active], floor[active], e2[:, active], s2[:, active]
        nll = _law_nll(e2c, s2c, ca, cb)
        var = ca + cb * s2c
        w = 1.0 / (var * var)
        r = w * (e2c - var)
        u0, u1 = np.sum(r, 0), np.sum(r * s2c, 0)
        # Newton where the likelihood's curvature is positive, else Fisher scoring
        h = w * (2.0 * e2c / var - 1.0)
        i00, i01, i11 = np.sum(h, 0), np.sum(h * s2c, 0), np.sum(h * s2c * s2c, 0)
        convex = (i00 > 0) & (i00 * i11 - i01 * i01 > 0)
        i00 = np.where(convex, i00, np.sum(w, 0))
        i01 = np.where(convex, i01, np.sum(w * s2c, 0))
        i11 = np.where(convex, i11, np.sum(w * s2c * s2c, 0))
        with np.errstate(all="ignore"):
            det = i00 * i11 - i01 * i01
            da, db = (i11 * u0 - i01 * u1) / det, (i00 * u1 - i01 * u0) / det
            # a step out of a bound it sits on: along the other parameter alone
            on_b = (cb <= 0.0) & (db < 0.0)
            da, db = np.where(on_b, u0 / i00, da), np.where(on_b, 0.0, db)
            on_a = (ca <= fl) & (da < 0.0) & ~on_b
            da, db = np.where(on_a, 0.0, da), np.where(on_a, u1 / i11, db)
        finite = np.isfinite(da) & np.isfinite(db)
        da, db = np.where(finite, da, 0.0), np.where(finite, db, 0.0)
        gain = np.zeros(active.size)
        todo = finite.copy()
        step = 1.0
        while np.any(todo) and step > LAW_MIN_STEP:
            ta, tb = np.maximum(ca + step * da, fl), np.maximum(cb + step * db, 0.0)
            trial = _law_nll(e2c[:, todo], s2c[:, todo], ta[todo], tb[todo])
            ok = np.zeros(active.size, dtype=bool)
            ok[todo] = trial <= nll[todo]
            idx = active[ok]
            a[idx], b[idx] = ta[ok], tb[ok]
            gain[ok] = nll[ok] - trial[ok[todo]]
            todo &= ~ok
            step *= 0.5
        active = active[gain > LAW_NLL_TOL]
    return a, b


def _cost(e: np.ndarray, var: np.ndarray) -> float:
    value = 0.5 * float(np.sum(e * e / var))
    return value if math.isfinite(value) else math.inf


def _nll(e: np.ndarray, var: np.ndarray) -> float:
    """Negative log-likelihood without constants: ``1/2 sum_k sum_c log R_kc + cost``."""
    log_det = float(np.sum(np.broadcast_to(np.log(var), e.shape)))
    return _cost(e, var) + 0.5 * log_det


def fisher_information(J: np.ndarray, e: np.ndarray, var: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Return the Fisher information ``sum J^T R^-1 J`` and gradient ``sum J^T R^-1 e``.

    ``J`` (m, n, n_p), ``e`` (n, m), ``var`` (m,) or (n, m).
    """
    w = 1.0 / np.sqrt(np.broadcast_to(var, e.shape))  # (n, m)
    Jw = (J * w.T[:, :, None]).reshape(-1, J.shape[-1])
    ew = (e * w).T.reshape(-1)
    return Jw.T @ Jw, Jw.T @ ew


def posterior_information(prob: Problem, J: np.ndarray, e: np.ndarray, var: np.ndarray,
                          p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`fisher_information` plus the prior's information and gradient term."""
    M, g = fisher_information(J, e, var)
    _, g_prior, M_prior = prob.prior_terms(p)
    return M + M_prior, g + g_prior


def sandwich(cov: np.ndarray, J: np.ndarray, e: np.ndarray, var: np.ndarray) -> np.ndarray:
    """Return the sandwich (robust) covariance ``M^-1 B M^-1`` in scaled parameters.

    ``B = sum_k g_k g_k^T`` with ``g_k = J_k^T R_k^-1 e_k`` the score of sample ``k``: right
    when the modelled variances are wrong, at the price of a noisier estimate of the
    covariance. ``cov`` is ``M^-1``.
    """
    w = 1.0 / np.broadcast_to(var, e.shape)  # (n, m)
    g = np.einsum("cki,kc->ki", J, w * e)  # (n, n_p)
    return cov @ (g.T @ g) @ cov


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
    history_cost = [_nll(e, r_diag) + prob.prior_terms(p)[0]]
    converged, message, it = False, "", 0
    for it in range(1, max_iterations + 1):
        cost = _cost(e, r_diag) + prob.prior_terms(p)[0]
        M, g = posterior_information(prob, J, e, r_diag, p)
        try:
            cov_now = np.linalg.inv(M)
            gauss_newton_step = cov_now @ g
            ratio = np.abs(gauss_newton_step) / np.sqrt(np.abs(np.diag(cov_now)) + 1e-300)
            small = bool(np.all(np.isfinite(ratio)) and np.max(ratio) < tol)
        except np.linalg.LinAlgError:
            gauss_newton_step = ratio = np.full(p.size, np.inf)
            small = False
        if small:
            r_new = prob.noise(e)
            settled = bool(np.max(np.abs(r_new / r_diag - 1.0)) < R_SETTLED_RTOL)
            r_diag = r_new
            history_cost[-1] = _nll(e, r_diag) + prob.prior_terms(p)[0]
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
                new_cost = _cost(e_new, r_diag) + prob.prior_terms(p + step)[0]
                if new_cost <= cost * (1.0 + COST_RTOL):
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
        # at a noise-free optimum the undamped step can raise the cost by rounding, so
        # only heavily damped (tiny) steps are accepted and the damping never falls:
        # the undamped Gauss-Newton step itself then says whether the parameters are
        # still moving (seen on an AVX-512 EPYC: 36 iterations at damping 10-1000,
        # steps of 1e-13, "max_iterations reached" on the JSBSim climb with events)
        undamped_stalled = bool(np.all(np.isfinite(gauss_newton_step))
                                and np.max(np.abs(gauss_newton_step)) < STALL_STEP)
        damping = max(damping / 10.0, 1e-12)
        p = p + step
        e, J = prob.residuals_jacobian(p)
        n_eval += 1
        r_new = prob.noise(e)
        settled = bool(np.max(np.abs(r_new / r_diag - 1.0)) < R_SETTLED_RTOL)
        r_diag = r_new
        history_p.append(p.copy())
        history_cost.append(_nll(e, r_diag) + prob.prior_terms(p)[0])
        report_progress(it, max_iterations, stage="Gauss-Newton", cost=history_cost[-1])
        if settled and float(np.max(np.abs(step))) < STALL_STEP and (
                near_gauss_newton or undamped_stalled):
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

