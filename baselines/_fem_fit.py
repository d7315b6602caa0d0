"""The filter-error method's likelihood and its optimizer (Maine & Iliff; Jategaonkar, ch. 5).

The negative log-likelihood of the innovations ``nu_k`` (measurement minus the filter's
prediction, :func:`baselines._fem_filter.run_filters`) with covariance ``S_k``:

    L(p) = 1/2 sum_k (nu_k^T S_k^-1 nu_k + log det S_k)  [+ 1/2 sum_i ((theta_i - mu_i) / s_i)^2]

(the bracket: the coefficients' Gaussian priors). Its score and Fisher information come
from the sensitivities of ``nu_k`` and ``S_k`` to the parameters:

    g_i = sum_k [nu^T S^-1 dnu_i - 1/2 nu^T S^-1 dS_i S^-1 nu + 1/2 tr(S^-1 dS_i)]
    M_ij = sum_k [dnu_i^T S^-1 dnu_j + 1/2 tr(S^-1 dS_i S^-1 dS_j)]

the sensitivities by differences of the whole filter (FVSysID's ``ml_fem`` does the same:
the gain's dependence on the parameters is in them), all perturbed filters in one batched
run: forward differences for the iterations' steps, central ones at the end for the
standard errors. Fisher scoring with Levenberg-Marquardt damping: ``(M + lambda diag M)
dp = -g``, three step lengths, and the full step with the gust intensity's step
:data:`SIGMA_STRIDE` times longer or at its lower bound, tried in one batched run; the best
one kept when it lowers ``L``. The Cramér-Rao covariance is ``M^-1`` at the optimum.

Parameters are scaled to order one: the free coefficients as ``theta / prior``, the gust
intensity as ``log(sigma / 1 m/s)``, a steady wind in m/s. The gust intensity has a lower
bound, :data:`LOG_SIGMA_MIN` (still air drives ``sigma`` to 0, ``log sigma`` to -inf);
at the bound, with the score pointing below it, it is held there and left out of the
step and the covariance (``at_bound``).

The measurement-noise update (FVSysID's relaxation, :func:`_innovation_noise`) is not a
descent step of ``L``: far from the optimum the gusts take up the model's error, the
state part ``H P^- H^T`` of a channel exceeds its innovations' mean square and the
relaxation sets its variance to the floor, where the filter follows that channel and a
poorer optimum holds it (README example log, prior start: the tail triad's ay2, az2 at
sd 3e-4 against the noise's 0.05, gusts 3.4 m/s in still air, cost -14 138 against
-14 733 from the truth; the first relaxation raised ``L`` by 435). So the relaxed
variances are a proposal, taken channel by channel, in full or a fraction of the way in
log variance (:data:`NOISE_FRACTIONS`), only where that lowers ``L`` at the new
parameters (:func:`noise_step`; measured on make_flight_log.py's recipe, seeds 1-10 and
2024: still-air false alarms 10/11 -> 0/11; ``benchmarks/bench_fem_noise.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from baselines._fem_dryden import DrydenGust, run_dryden_filters
from baselines._fem_filter import FilterRuns, GustModel, run_filters
from baselines._fem_model import N_WIND
from baselines._oe_airdata import calibration_scales

#: Central-difference step of the scaled parameters: the innovations are smooth in them
#: (truncation ~h^2 = 1e-8 relative), rounding ~eps / h = 2e-12 relative.
FD_STEP = 1e-4
#: Lower bound of ``log(sigma / 1 m/s)``: 1 mm/s of gust intensity, whose loads are below
#: 1e-3 of a tactical accelerometer's noise on the reference flight (1 mm/s at 505 m/s is
#: 2e-6 rad of incidence).
LOG_SIGMA_MIN = math.log(1e-3)
#: Step lengths tried per iteration (one batched run).
STEP_LENGTHS = (1.0, 0.5, 0.2)
#: The gust intensity's step is also tried this many times longer, and at the bound: the
#: Fisher step of ``log sigma`` is ~0.7-1 per iteration on its way to the bound in still
#: air (measured: 10 iterations on the reference flight, where output-error takes 6).
SIGMA_STRIDE = 3.0
#: Levenberg-Marquardt damping: start, growth after a failed iteration, shrink after a
#: good one, largest before giving up.
DAMPING = (1e-3, 10.0, 0.1, 1e8)
#: Fractions of the way (in log variance) to a channel's relaxed noise variance tried after
#: an iteration, the first that lowers the likelihood's cost kept (none: the variance stays).
NOISE_FRACTIONS = (1.0, 0.5, 0.25)


@dataclass(frozen=True)
class Problem:
    """What the likelihood needs (built by :mod:`baselines.filter_error`).

    Attributes
    ----------
    model : GustModel
    zs : ndarray, shape (n, m)
    x0 : ndarray, shape (N_STATE,)
    P0x : ndarray, shape (N_STATE, N_STATE)
    decay : float
        ``exp(-dt / tau)`` of the gusts.
    theta_base : ndarray, shape (N_COEFFICIENTS,)
        The coefficients with the held ones at their values (the free ones overwritten).
    free : ndarray of int
        Indices of the free coefficients.
    scale : ndarray, shape (n_free,)
        Scale of each free coefficient (its prior, 1 where the prior is 0).
    estimate_wind : bool
        The steady wind's components (north, east, down [m/s]) after ``log sigma``
        (tested, but not offered by :class:`baselines.filter_error.FilterErrorEstimator`:
        not identifiable against the gusts' initial state on a record ~L/V long, its
        module docstring).
    prior_mean, prior_info : ndarray, shape (n_free,)
        Gaussian priors on the free coefficients (information 0: none), physical units.

    With air data (``model.calibration``: their calibration parameters, scaled by
    :func:`baselines._oe_airdata.calibration_scales`) those come last in ``p``.
    gust : DrydenGust, optional
        The Dryden shaping filters as the gust states (:mod:`baselines._fem_dryden`; then
        ``model`` is :func:`baselines._fem_dryden.dryden_gust_model`'s); None (default): the
        first-order gusts of ``decay``.
    """

    model: GustModel
    zs: np.ndarray
    x0: np.ndarray
    P0x: np.ndarray
    decay: float
    theta_base: np.ndarray
    free: np.ndarray
    scale: np.ndarray
    estimate_wind: bool
    prior_mean: np.ndarray
    prior_info: np.ndarray
    gust: DrydenGust | None = None

    @property
    def n_parameters(self) -> int:
        """Scaled parameters: the free coefficients, log sigma, the wind if estimated, the
        air data's calibration."""
        return self.free.size + 1 + (N_WIND if self.estimate_wind else 0) + self.n_calibration

    @property
    def n_calibration(self) -> int:
        """The air data's calibration parameters (last in ``p``; 0 without air data)."""
        return len(self.model.calibration)

    def calibration(self, p: np.ndarray) -> np.ndarray:
        """The air data's calibration (r, n_calibration) of the rows ``p`` (r, n_p), physical
        (factors, offsets [rad])."""
        n_cal = self.n_calibration
        return p[:, p.shape[1] - n_cal:] * calibration_scales(list(self.model.calibration))

    @property
    def i_sigma(self) -> int:
        """Index of ``log sigma`` in the parameters."""
        return int(self.free.size)

    def unpack(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Coefficients (r, N_COEFFICIENTS), steady wind (r, N_WIND), sigma (r,) of ``p``
        (r, n_p)."""
        theta = np.tile(self.theta_base, (p.shape[0], 1))
        theta[:, self.free] = p[:, :self.free.size] * self.scale
        sigma = np.exp(p[:, self.i_sigma])
        wind = (p[:, self.i_sigma + 1:self.i_sigma + 1 + N_WIND] if self.estimate_wind
                else np.zeros((p.shape[0], N_WIND)))
        return theta, wind, sigma

    def run(self, p: np.ndarray, R: np.ndarray) -> FilterRuns:
        """The filters of the parameter rows ``p`` (r, n_p) with noise variances ``R``."""
        theta, wind, sigma = self.unpack(p)
        if self.gust is not None:
            return run_dryden_filters(self.model, self.gust, theta, wind, sigma, self.x0,
                                      self.P0x, R, self.zs,
                                      self.calibration(p) if self.n_calibration else None)
        return run_filters(self.model, theta, wind, sigma, self.decay, self.x0, self.P0x, R,
                           self.zs, self.calibration(p) if self.n_calibration else None)

    def prior_cost(self, p: np.ndarray) -> np.ndarray:
        """``1/2 sum ((theta - mu) / s)^2`` of each row of ``p`` (r,)."""
        theta = p[:, :self.free.size] * self.scale
        return 0.5 * np.sum(self.prior_info * (theta - self.prior_mean) ** 2, axis=1)


def nll(runs: FilterRuns) -> np.ndarray:
    """``1/2 sum_k (nu^T S^-1 nu + log det S)`` of each run (r,); inf where a run failed
    (not finite, or an innovation covariance not positive definite)."""
    ok = runs.ok.copy()
    eye = np.eye(runs.S.shape[-1])
    try:
        L = np.linalg.cholesky(np.where(ok[:, None, None, None], runs.S, eye))
    except np.linalg.LinAlgError:
        for j in np.flatnonzero(ok):
            try:
                np.linalg.cholesky(runs.S[j])
            except np.linalg.LinAlgError:
                ok[j] = False
        L = np.linalg.cholesky(np.where(ok[:, None, None, None], runs.S, eye))
    white = np.linalg.solve(L, runs.innovation[..., None])[..., 0]  # L^-1 nu
    logdet = 2.0 * np.sum(np.log(np.diagonal(L, axis1=-2, axis2=-1)), axis=-1)
    cost = 0.5 * np.sum(np.sum(white * white, axis=-1) + logdet, axis=-1)
    return np.where(ok, cost, np.inf)


def score_information(nu: np.ndarray, S: np.ndarray, dnu: np.ndarray, dS: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The score ``g`` (n_p,) and Fisher information ``M`` (n_p, n_p) of the innovations.

    Parameters
    ----------
    nu : ndarray, shape (n, m)
    S : ndarray, shape (n, m, m)
    dnu : ndarray, shape (n_p, n, m)
        Sensitivities of the innovations.
    dS : ndarray, shape (n_p, n, m, m)
        Sensitivities of their covariance.
    """
    Sinv_nu = np.linalg.solve(S, nu[..., None])[..., 0]  # (n, m)
    Sinv_dnu = np.linalg.solve(S[None], dnu[..., None])[..., 0]  # (n_p, n, m)
    Sinv_dS = np.linalg.solve(S[None], dS)  # (n_p, n, m, m)
    g = (np.einsum("knm,nm->k", dnu, Sinv_nu)
         - 0.5 * np.einsum("nm,knml,nl->k", Sinv_nu, dS, Sinv_nu)
         + 0.5 * np.einsum("knmm->k", Sinv_dS))
    M = (np.einsum("inm,jnm->ij", dnu, Sinv_dnu)
         + 0.5 * np.einsum("inml,jnlm->ij", Sinv_dS, Sinv_dS))
    return g, 0.5 * (M + M.T)


def sensitivities(problem: Problem, p: np.ndarray, R: np.ndarray, *, central: bool = True,
                  step: float = FD_STEP) -> tuple[FilterRuns, np.ndarray, np.ndarray, bool]:
    """The filter at ``p`` and the differences of its innovations and their covariance,
    ``dnu`` (n_p, n, m) and ``dS`` (n_p, n, m, m), in one batched run: central, or forward
    (``n_p + 1`` filters instead of ``2 n_p + 1``; error ~``step`` relative)."""
    n_p = p.size
    rows = np.tile(p, (2 * n_p + 1 if central else n_p + 1, 1))
    rows[1:n_p + 1] += step * np.eye(n_p)
    if central:
        rows[n_p + 1:] -= step * np.eye(n_p)
    runs = problem.run(rows, R)
    center = FilterRuns(runs.innovation[:1], runs.S[:1], runs.ok[:1], runs.x[:1])
    back = n_p + 1 if central else 0
    width = 2.0 * step if central else step
    dnu = (runs.innovation[1:n_p + 1] - runs.innovation[back:back + n_p]
           if central else runs.innovation[1:] - runs.innovation[:1]) / width
    dS = (runs.S[1:n_p + 1] - runs.S[back:back + n_p]
          if central else runs.S[1:] - runs.S[:1]) / width
    return center, dnu, dS, bool(np.all(runs.ok))


def information(problem: Problem, p: np.ndarray, R: np.ndarray) -> np.ndarray:
    """The innovations' Fisher information (n_p, n_p) at the scaled parameters ``p`` with
    noise variances ``R`` (central differences, the priors' added): its inverse is the
    Cramér-Rao covariance there, e.g. at the truth of a simulated flight."""
    center, dnu, dS, _ = sensitivities(problem, p, R)
    _, M = score_information(center.innovation[0], center.S[0], dnu, dS)
    nf = problem.free.size
    M[:nf, :nf] += np.diag(problem.prior_info * problem.scale**2)
    return M


@dataclass
class Fit:
    """The end of :func:`fisher_scoring` (scaled parameters)."""

    p: np.ndarray
    cost: float
    information: np.ndarray
    R: np.ndarray
    runs: FilterRuns
    converged: bool
    message: str
    n_iterations: int
    n_evaluations: int
    at_bound: bool
    history_p: list[np.ndarray] = field(default_factory=list)
    history_cost: list[float] = field(default_factory=list)
    #: Per iteration with the noise update: the fraction of the way to the relaxed
    #: variances taken (1: in full; 0: refused, it raised the cost; :func:`noise_step`).
    noise_fractions: list[float] = field(default_factory=list)


def _innovation_noise(runs: FilterRuns, R: np.ndarray, floor: np.ndarray,
                      which: np.ndarray | bool = True) -> np.ndarray:
    """FVSysID-style noise update: ``R_c = mean_k(nu_c^2 - (H P^- H^T)_cc)``, floored, of
    the channels ``which`` (all by default; the others keep ``R``)."""
    state_part = np.diagonal(runs.S[0], axis1=-2, axis2=-1) - R
    new = np.maximum(np.mean(runs.innovation[0] ** 2 - state_part, axis=0), floor)
    return np.where(which, new, R)


def noise_step(problem: Problem, p: np.ndarray, runs: FilterRuns, cost: float,
               R: np.ndarray, floor: np.ndarray, which: np.ndarray | bool
               ) -> tuple[np.ndarray, float, int]:
    """The noise variances after an iteration at ``p`` (``runs``, ``cost``: its filter and
    ``L`` with ``R``), channel by channel in turn: its relaxed variance, or a fraction of
    the way to it, the first that lowers ``L`` (module docstring); its variance kept when
    none does. Returns the variances, the largest fraction taken (0: none) and the
    number of filters run."""
    proposal = _innovation_noise(runs, R, floor, which)
    R = R.copy()
    taken, tried = 0.0, 0
    for c in np.flatnonzero(np.broadcast_to(which, R.shape) & (proposal != R)):
        for fraction in NOISE_FRACTIONS:
            trial = R.copy()
            trial[c] = R[c] * (proposal[c] / R[c]) ** fraction
            tried += 1
            trial_cost = float(nll(problem.run(p[None], trial))[0]
                               + problem.prior_cost(p[None])[0])
            if trial_cost < cost:
                R, cost, taken = trial, trial_cost, max(taken, fraction)
                break
    return R, taken, tried


def fisher_scoring(problem: Problem, p0: np.ndarray, R: np.ndarray, *,
                   update_noise: bool | np.ndarray, r_floor: np.ndarray, max_iterations: int,
                   tol: float) -> Fit:
    """Minimise :func:`nll` (plus the priors) from ``p0`` (module docstring).

    Converged when no free parameter's undamped Fisher-scoring step (``M^-1 g``: the
    distance to the optimum of the quadratic model, not the damped step taken) exceeds
    ``tol`` of its Cramér-Rao sd (and,
    with ``update_noise``, the noise variances changed by less than 1 %). ``R`` (m,): the
    measurement-noise variances, re-estimated from the innovations after every iteration
    when ``update_noise`` (a bool, or one per channel: the IMU's held from the metadata,
    the probe's re-estimated).
    """
    p = np.array(p0, dtype=float)
    n_p = p.size
    damping = DAMPING[0]
    history_p, history_cost = [p.copy()], []
    noise_fractions: list[float] = []
    n_eval = 0
    message = f"not converged after {max_iterations} iterations"
    converged = at_bound = False
    for iteration in range(1, max_iterations + 1):
        center, dnu, dS, ok = sensitivities(problem, p, R, central=False)
        n_eval += n_p + 1
        if not ok:
            raise FloatingPointError("a filter diverged (covariance not positive definite "
                                     "or the state not finite) while differencing")
        cost = float(nll(center)[0] + problem.prior_cost(p[None])[0])
        history_cost.append(cost)
        g, M = score_information(center.innovation[0], center.S[0], dnu, dS)
        nf = problem.free.size
        M[:nf, :nf] += np.diag(problem.prior_info * problem.scale**2)
        g[:nf] += problem.prior_info * problem.scale * (p[:nf] * problem.scale
                                                       - problem.prior_mean)
        i_s = problem.i_sigma
        at_bound = bool(p[i_s] <= LOG_SIGMA_MIN + 1e-12 and g[i_s] > 0)
        active = np.array([i != i_s or not at_bound for i in range(n_p)])
        Ma, ga = M[np.ix_(active, active)], g[active]
        try:
            cov_a = np.linalg.inv(Ma)
        except np.linalg.LinAlgError:
            cov_a = np.full_like(Ma, np.nan)
        # the distance to the optimum: the undamped Fisher-scoring step in Cramér-Rao sd
        # (not the step taken: the damping shrinks it along a flat valley, measured 0.7 %
        # of the way to an optimum 1.25 sd off, and a damped step below tol is no optimum)
        remaining = np.abs(cov_a @ ga) / np.sqrt(np.abs(np.diag(cov_a)))
        while True:
            A = Ma + damping * np.diag(np.diag(Ma))
            step = np.zeros(n_p)
            step[active] = -np.linalg.solve(A, ga)
            trials = np.array([p + a * step for a in STEP_LENGTHS] + [p + step, p + step])
            trials[-2, i_s] += (SIGMA_STRIDE - 1.0) * step[i_s]
            trials[-1, i_s] = LOG_SIGMA_MIN
            trials[:, i_s] = np.maximum(trials[:, i_s], LOG_SIGMA_MIN)
            trial_runs = problem.run(trials, R)
            n_eval += len(trials)
            trial_cost = nll(trial_runs) + problem.prior_cost(trials)
            best = int(np.argmin(trial_cost))
            if trial_cost[best] < cost:
                break
            damping *= DAMPING[1]
            if damping > DAMPING[3]:
                # no step lowers the cost: at the optimum within rounding
                converged = bool(np.all(remaining < 10 * tol))
                message = ("converged: no step lowers the likelihood's cost further"
                           if converged else "stopped: no step lowers the cost")
                return Fit(p, cost, M, R, center, converged, message, iteration, n_eval,
                           at_bound, history_p, history_cost, noise_fractions)
        p = trials[best]
        history_p.append(p.copy())
        damping = max(damping * DAMPING[2], 1e-12)
        settled = True
        if np.any(update_noise):
            best_runs = FilterRuns(trial_runs.innovation[best:best + 1],
                                   trial_runs.S[best:best + 1], trial_runs.ok[best:best + 1],
                                   trial_runs.x[best:best + 1])
            new_R, fraction, tried = noise_step(
                problem, p, best_runs, float(trial_cost[best]), R, r_floor,
                np.asarray(update_noise, dtype=bool))
            n_eval += tried
            noise_fractions.append(fraction)
            settled = bool(np.all(np.abs(new_R / R - 1.0) < 0.01))
            R = new_R
        if np.all(remaining < tol) and settled:
            converged, message = True, f"converged after {iteration} iterations"
            break
    center, dnu, dS, _ = sensitivities(problem, p, R)
    n_eval += 2 * n_p + 1
    cost = float(nll(center)[0] + problem.prior_cost(p[None])[0])
    g, M = score_information(center.innovation[0], center.S[0], dnu, dS)
    nf = problem.free.size
    M[:nf, :nf] += np.diag(problem.prior_info * problem.scale**2)
    at_bound = bool(p[problem.i_sigma] <= LOG_SIGMA_MIN + 1e-12 and g[problem.i_sigma] > 0)
    history_cost.append(cost)
    return Fit(p, cost, M, R, center, converged, message, len(history_p) - 1, n_eval,
               at_bound, history_p, history_cost, noise_fractions)
