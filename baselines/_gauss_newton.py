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
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from aeroid import estimation
from aeroid.estimation import report_progress
from baselines._gn_region import (  # noqa: F401 - SmoothRegion re-exported: the models return it
    SmoothRegion,
    held_step,
    step_across,
)
from baselines._noise_law import (  # noqa: F401 - re-exported: the solver's noise laws
    A_FLOOR_REL,
    LAW_MAX_ITERATIONS,
    LAW_MIN_STEP,
    LAW_NLL_TOL,
    _law_nll,
    most_likely_law,
)

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
    # optional: ``mask`` (n, m) bool or None, the outputs in the likelihood (Problem's);
    # optional: ``smooth_region(p) -> SmoothRegion`` for a model whose outputs are
    # piecewise smooth in some parameter, with ``edge_note`` (a phrase) saying what an
    # edge is (:func:`gauss_newton`)


#: Noise models of the measurement errors (:meth:`Problem.noise`).
NOISE_MODELS: tuple[str, ...] = ("channel", "signal")
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
    mask : ndarray of bool, shape (n, m), optional
        The entries in the likelihood (False: a saturated sample, out of it; default the
        model's ``mask`` if it has one). A masked
        entry's residual and Jacobian are zero and its variance 1 (no term in the cost
        or its log-determinant), and the variances are estimated from the entries in:
        the fit equals the fit of the data without those entries.
    """

    z: np.ndarray
    model: OutputModel
    r_floor: np.ndarray
    noise_model: str = "channel"
    prior_mean: np.ndarray | None = None
    prior_weight: np.ndarray | None = None
    mask: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.mask is None and getattr(self.model, "mask", None) is not None:
            object.__setattr__(self, "mask", self.model.mask)  # the model's (OutputModel)

    def residuals(self, p: np.ndarray) -> np.ndarray:
        """Return ``z - y(p)``, shape (n, m) (0 at masked entries)."""
        e = self.z - self.model.outputs(p)
        return e if self.mask is None else np.where(self.mask, e, 0.0)

    def residuals_jacobian(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return ``z - y(p)`` (n, m) and ``dy/dp`` (m, n, n_p) (0 at masked entries)."""
        y, J = self.model.outputs_jacobian(p)
        if self.mask is not None:
            return np.where(self.mask, self.z - y, 0.0), J * self.mask.T[:, :, None]
        return self.z - y, J

    def noise(self, e: np.ndarray) -> np.ndarray:
        """Return the ML estimate of the error variances from residuals ``e`` (floored).

        Shape (m,) for ``channel``, (n, m) for ``signal`` or with a ``mask``.
        """
        if self.mask is not None:
            return self.masked_noise(e)
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

    def masked_noise(self, e: np.ndarray) -> np.ndarray:
        """:meth:`noise` of each channel's entries in the likelihood; 1 at the others."""
        out, mask = np.ones(e.shape), np.ones(e.shape, bool) if self.mask is None else self.mask
        for c in range(e.shape[1]):
            rows = mask[:, c]
            if rows.any():
                alone = Problem(self.z[rows, c:c + 1], None,  # type: ignore[arg-type]
                                self.r_floor[c:c + 1], self.noise_model)  # noise: no model
                out[rows, c] = np.broadcast_to(alone.noise(e[rows, c:c + 1]),
                                               (int(rows.sum()), 1))[:, 0]
        return out

    def prior_terms(self, p: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """Return the prior's cost, gradient term and information (all zero without one)."""
        if self.prior_weight is None or self.prior_mean is None:
            return 0.0, np.zeros_like(p), np.zeros((p.size, p.size))
        d = self.prior_mean - p
        return (0.5 * float(np.sum(self.prior_weight * d * d)), self.prior_weight * d,
                np.diag(self.prior_weight))


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


def _trial(prob: Problem, p: np.ndarray, with_jacobian: bool
           ) -> tuple[np.ndarray, np.ndarray | None]:
    """A trial point's residuals, and with ``with_jacobian`` its Jacobian (else None).

    While steps are taken at their first trial (the Gauss-Newton end of the damping),
    the trial is evaluated with its Jacobian, which its acceptance then needs: one model
    evaluation per iteration instead of two (the Jacobian's outputs are those of
    :meth:`OutputModel.outputs`: the same graph with the sensitivities beside it). After
    a rejection the trials are evaluated without it (a rejected Jacobian costs ~5x the
    outputs: benchmarks/bench_oe_long.py).
    """
    if with_jacobian:
        return prob.residuals_jacobian(p)
    return prob.residuals(p), None


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


def gauss_newton(prob: Problem, p0: np.ndarray, *, max_iterations: int, tol: float,
                 stop: Callable[[int, list], str | None] | None = None) -> Fit:
    """Run damped Gauss-Newton with the R relaxation from scaled parameters ``p0``.

    ``stop(iteration, history_cost)``, when given, is asked after every step that did not
    converge: a text ends the fit there, unconverged, with that text as its message
    (:func:`baselines._oe_starts.give_up`).

    Each iteration: the Fisher information ``M`` and gradient ``g`` at the current
    point with the current ``R``; if the undamped Gauss-Newton step ``M^-1 g`` is
    below ``tol`` Cramér-Rao standard deviations in every parameter, ``R`` is
    re-estimated and the fit has converged once ``R`` has settled (relative change
    below :data:`R_SETTLED_RTOL`); otherwise a Levenberg-damped step that lowers the
    cost (damping x10 per rejected trial, /10 after a success) is taken and ``R`` is
    re-estimated from the new residuals (relaxation at every step: holding ``R``
    until Gauss-Newton converged, Klein & Morelli's textbook variant, took 2-3x more
    iterations on the reference flight).

    A model with ``smooth_region`` (outputs piecewise smooth in a parameter: the fin
    delay, whose cost jumps where a switch crosses a sample instant) gets two more moves.
    A trial step that crosses an edge and raises the cost is retried, at the same damping,
    with the crossing parameters held at the edge (:func:`held_step`) before the damping
    rises. And when the undamped step crosses an edge, the fit has converged at that edge
    once the held Gauss-Newton step is below ``tol`` standard deviations, ``R`` has settled
    and the cost just across the edge (the other parameters unchanged) is higher: a local
    minimum of the piecewise cost, where the smooth test alone is never met (the smooth
    piece's minimum lies across the edge; measured on a suite log's raw-IMU flight whose
    fin and IMU clocks share one grid: 150 iterations of steps of 1e-13 s, the undamped
    step 1.7 sd in ``sp``).
    """
    p = np.array(p0, dtype=float)
    e, J = prob.residuals_jacobian(p)
    n_eval = 1
    if not np.all(np.isfinite(e)):
        raise FloatingPointError("the model diverges at the starting point")
    r_diag = prob.noise(e)
    damping = 1e-3
    # the last step was taken at its first trial: the next trial is evaluated with its
    # Jacobian, which an accepted trial then needs (:func:`_trial`)
    first_try = False
    history_p = [p.copy()]
    history_cost = [_nll(e, r_diag) + prob.prior_terms(p)[0]]
    converged, message, it = False, "", 0
    smooth_region = getattr(prob.model, "smooth_region", None)
    region = None
    for it in range(1, max_iterations + 1):
        cost = _cost(e, r_diag) + prob.prior_terms(p)[0]
        M, g = posterior_information(prob, J, e, r_diag, p)
        try:
            cov_now = np.linalg.inv(M)
            gauss_newton_step = cov_now @ g
            sd = np.sqrt(np.abs(np.diag(cov_now)) + 1e-300)
            ratio = np.abs(gauss_newton_step) / sd
            small = bool(np.all(np.isfinite(ratio)) and np.max(ratio) < tol)
        except np.linalg.LinAlgError:
            gauss_newton_step = ratio = np.full(p.size, np.inf)
            small = False
        at_edge = False
        if smooth_region is not None:
            region = smooth_region(p)
            if not small and np.all(np.isfinite(ratio)):
                held = held_step(M, g, p, gauss_newton_step, region)
                if held is not None and np.max(np.abs(held[0]) / sd) < tol:
                    # the smooth piece's minimum lies across the edge: a minimum here
                    # when the cost jumps up across it
                    across = step_across(p, gauss_newton_step, region)
                    n_eval += 1
                    at_edge = small = bool(_cost(prob.residuals(across), r_diag)
                                           + prob.prior_terms(across)[0] > cost)
        if small:
            r_new = prob.noise(e)
            settled = bool(np.max(np.abs(r_new / r_diag - 1.0)) < R_SETTLED_RTOL)
            r_diag = r_new
            history_cost[-1] = _nll(e, r_diag) + prob.prior_terms(p)[0]
            if settled:
                converged = True
                message = f"converged after {it} iterations" + (
                    f" ({getattr(prob.model, 'edge_note', 'at an edge of a smooth region')})"
                    if at_edge else "")
                break
            continue
        diag = np.diag(M).copy()
        diag[diag <= 0] = 1.0
        tries, J_new = 0, None
        while True:
            try:
                step = np.linalg.solve(M + damping * np.diag(diag), g)
            except np.linalg.LinAlgError:
                step = np.full_like(p, np.nan)
            if np.all(np.isfinite(step)):
                e_new, J_new = _trial(prob, p + step, first_try and tries == 0)
                tries += 1
                n_eval += 1
                new_cost = _cost(e_new, r_diag) + prob.prior_terms(p + step)[0]
                if new_cost <= cost * (1.0 + COST_RTOL):
                    break
                J_new = None
                held = (None if region is None else
                        held_step(M + damping * np.diag(diag), g, p, step, region))
                if held is not None:  # the crossing raised the cost: stop at the edge
                    e_new = prob.residuals(p + held[0])
                    tries += 1
                    n_eval += 1
                    new_cost = _cost(e_new, r_diag) + prob.prior_terms(p + held[0])[0]
                    if new_cost <= cost * (1.0 + COST_RTOL):
                        step = held[0]
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
        first_try = tries == 1
        if J_new is not None:  # the accepted trial's own Jacobian
            e, J = e_new, J_new
        else:
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
        said = None if stop is None else stop(it, history_cost)
        if said:
            message = said
            break
    else:
        message = f"max_iterations ({max_iterations}) reached"
    return Fit(p, e, J, r_diag, history_cost[-1], history_p, history_cost, it, n_eval,
                converged, message)

