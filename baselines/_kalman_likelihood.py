"""Filter-error's likelihood at a gust filter's estimate: information, one step (private).

The mathematics of :mod:`baselines._kalman_information` (which says what the EKF/UKF
report with it): the problem built as filter-error builds it around the filter's
coefficients, the intensity that maximises the innovations' likelihood there, the
information ``M`` (filter-error's own ``sensitivities`` and ``score_information``) and
its inverse, and Le Cam's one Fisher-scoring step (issue 26).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from aeroid.flights import Flight
from aeroid.model import NAMES
from baselines import _common, _fem_fit, _fem_setup
from baselines._fem_filter import gust_model
from baselines._kalman_gust import GUST_SD_BOUNDS_MPS

#: The likelihood's intensity to 1 % (its own sd from one record is ~10 %).
PROFILE_LOG_TOL = 0.01


@dataclass(frozen=True)
class InnovationCovariance:
    """The innovations' information at an estimate (module docstring).

    Attributes
    ----------
    covariance : ndarray, shape (N_COEFFICIENTS, N_COEFFICIENTS)
        The coefficients' covariance (held coefficients: rows and columns 0).
    stderr : ndarray, shape (N_COEFFICIENTS,)
        Its square-root diagonal (held: 0).
    information : ndarray, shape (n_free + 1, n_free + 1)
        ``M`` of the scaled parameters (the free coefficients over their scale, then
        ``log sigma``), the priors' information included.
    score : ndarray, shape (n_free + 1,)
        The gradient of the negative log-likelihood (plus the priors') there.
    gust_sd_mps, gust_sd_stderr_mps : float
        The intensity at which it was evaluated, and its sd from ``M^-1`` (NaN when held:
        ``sigma_free`` False).
    noise_source : str
        Where the measurement noise came from (``metadata`` or ``innovations``).
    R : ndarray, shape (m,)
        The measurement-noise variances used.
    ok : bool
        Every differenced filter finite and ``M`` invertible.
    """

    covariance: np.ndarray
    stderr: np.ndarray
    information: np.ndarray
    score: np.ndarray
    gust_sd_mps: float
    gust_sd_stderr_mps: float
    noise_source: str
    R: np.ndarray
    ok: bool
    runs: Any = None  # the filter at the point (FilterRuns): its innovations and gust path


def gust_problem(flight: Flight, theta: np.ndarray, *, scale_length_m: float,
                 substeps: int, input_mode: str, delay_s: float, holds: Any = None
                 ) -> tuple[_fem_fit.Problem, _fem_setup.Noise]:
    """Filter-error's likelihood problem for ``flight`` around coefficients ``theta``,
    built as :class:`baselines.filter_error.FilterErrorEstimator` builds it (its
    measurement noise, initial state and gust decay; ``holds``: their values and priors)."""
    zs = _common.measurements(flight)
    noise = _fem_setup.measurement_noise(flight, zs, "auto", "gust information")
    x0, P0x = _fem_setup.initial_state(flight, zs, noise.R)
    decay, _, _ = _fem_setup.gust_decay(flight, scale_length_m)
    base = np.array(theta, dtype=float) if holds is None else holds.with_held(theta)
    free, scale, mean, info_prior = _fem_setup.free_parameters(
        flight.airframe.prior_vector(), holds)
    problem = _fem_fit.Problem(gust_model(flight, substeps, input_mode, delay_s), zs, x0,
                               P0x, decay, base, free, scale, False, mean, info_prior)
    return problem, noise


def likelihood_gust_sd(problem: _fem_fit.Problem, R: np.ndarray) -> float:
    """The intensity [m/s] that maximises the innovations' likelihood at the coefficients
    ``problem.theta_base`` (bounded Brent over ``log sigma`` in
    :data:`baselines._kalman_gust.GUST_SD_BOUNDS_MPS`, one filter run per trial)."""
    free = problem.free
    p = np.concatenate([problem.theta_base[free] / problem.scale, [0.0]])

    def cost(log_sd: float) -> float:
        p[-1] = log_sd
        value = float(_fem_fit.nll(problem.run(p[None], R))[0])
        return value if math.isfinite(value) else 1e300

    lo, hi = (math.log(b) for b in GUST_SD_BOUNDS_MPS)
    found = minimize_scalar(cost, bounds=(lo, hi), method="bounded",
                            options={"xatol": PROFILE_LOG_TOL})
    return math.exp(float(found.x))


def noise_at(problem: _fem_fit.Problem, noise: _fem_setup.Noise, gust_sd_mps: float
             ) -> np.ndarray:
    """The measurement-noise variances (m,): ``noise.R`` from the flight's noise metadata,
    or without it re-estimated once from the innovations at ``problem.theta_base`` and
    ``gust_sd_mps``: filter-error's guarded relaxation step (:func:`baselines._fem_fit.
    noise_step`: each channel's relaxed variance taken in full or a fraction of the way
    in log variance, only where the likelihood's cost falls). Taken in full regardless, it
    threw the tail triad's ay2, az2 to the floor (sd 2.6e-4 against the noise's 0.05) on
    every still-air flight fitted with ``gust_sd_mps = 3``, and the fit check refused them
    as not white; in Dryden sd 3 m/s, seeds 1-10, the EKF's ``estimate_gust_sd`` passed
    8/10 with it, 10/10 now (``benchmarks/bench_fem_noise.py --methods ekf-sd3,ekf-est``)."""
    if not np.any(noise.update):
        return noise.R
    p = point(problem, gust_sd_mps)
    runs = problem.run(p[None], noise.R)
    cost = float(_fem_fit.nll(runs)[0] + problem.prior_cost(p[None])[0])
    R, _, _ = _fem_fit.noise_step(problem, p, runs, cost, noise.R, noise.floor,
                                  np.asarray(noise.update, dtype=bool))
    return R


def innovation_covariance(problem: _fem_fit.Problem, noise: _fem_setup.Noise,
                          gust_sd_mps: float, R: np.ndarray | None = None, *,
                          sigma_free: bool = True) -> InnovationCovariance:
    """The information ``M`` at ``problem.theta_base`` and ``gust_sd_mps``, and its inverse
    (``R``: the noise variances, default :func:`noise_at`'s). ``sigma_free`` False: the
    intensity is held (at its search's lower bound: still air, as filter-error's
    ``at_bound``), its row and column of ``M`` left out of the inverse."""
    free, nf = problem.free, problem.free.size
    p = np.concatenate([problem.theta_base[free] / problem.scale, [math.log(gust_sd_mps)]])
    R = noise_at(problem, noise, gust_sd_mps) if R is None else R
    center, dnu, dS, ok = _fem_fit.sensitivities(problem, p, R)
    g, M = _fem_fit.score_information(center.innovation[0], center.S[0], dnu, dS)
    M[:nf, :nf] += np.diag(problem.prior_info * problem.scale**2)
    g[:nf] += problem.prior_info * problem.scale * (p[:nf] * problem.scale
                                                   - problem.prior_mean)
    cov = np.zeros((len(NAMES), len(NAMES)))
    used = nf + 1 if sigma_free else nf
    cov_p = np.full_like(M, np.nan)
    try:
        cov_p[:used, :used] = np.linalg.inv(M[:used, :used])
    except np.linalg.LinAlgError:
        ok = False
    diag = np.diag(cov_p)[:used]
    ok = ok and bool(np.all(np.isfinite(diag)) and np.all(diag > 0))
    cov[np.ix_(free, free)] = cov_p[:nf, :nf] * np.outer(problem.scale, problem.scale)
    sd_sigma = gust_sd_mps * math.sqrt(abs(cov_p[nf, nf]))  # delta method: sigma = e^p
    return InnovationCovariance(cov, np.sqrt(np.abs(np.diag(cov))), M, g, float(gust_sd_mps),
                                float(sd_sigma), noise.source, R, ok, center)


def point(problem: _fem_fit.Problem, gust_sd_mps: float) -> np.ndarray:
    """The scaled parameters (n_free + 1,) of ``problem.theta_base`` and ``gust_sd_mps``."""
    return np.concatenate([problem.theta_base[problem.free] / problem.scale,
                           [math.log(gust_sd_mps)]])


def scoring_step(found: InnovationCovariance) -> tuple[np.ndarray, np.ndarray]:
    """The undamped Fisher-scoring step ``-M^-1 g`` (n_free + 1,) of the scaled parameters
    at ``found`` (a held intensity, NaN sd: its entry 0), and that step in its own standard
    errors (``M^-1``'s diagonal; NaN where held)."""
    n = found.score.size
    used = n if math.isfinite(found.gust_sd_stderr_mps) else n - 1
    step, in_se = np.zeros(n), np.full(n, np.nan)
    M = found.information[:used, :used]
    step[:used] = -np.linalg.solve(M, found.score[:used])
    in_se[:used] = np.abs(step[:used]) / np.sqrt(np.abs(np.diag(np.linalg.inv(M))))
    return step, in_se


def one_step_point(problem: _fem_fit.Problem, found: InnovationCovariance
                   ) -> tuple[np.ndarray, float]:
    """Le Cam's one-step point from ``problem.theta_base``: one Fisher-scoring step
    ``-M^-1 g`` of the innovations' likelihood (with filter-error's step lengths
    :data:`baselines._fem_fit.STEP_LENGTHS`, the one that lowers it most); returns the
    scaled parameters (n_free + 1,: the free coefficients over their scale, ``log sigma``)
    and the step length taken (0: none lowered it, the start returned)."""
    p = point(problem, found.gust_sd_mps)
    step, _ = scoring_step(found)
    rows = np.vstack([p] + [p + a * step for a in _fem_fit.STEP_LENGTHS])
    cost = _fem_fit.nll(problem.run(rows, found.R)) + problem.prior_cost(rows)
    best = int(np.argmin(cost))
    return rows[best], 0.0 if best == 0 else float(_fem_fit.STEP_LENGTHS[best - 1])


def one_step(problem: _fem_fit.Problem, found: InnovationCovariance
             ) -> tuple[np.ndarray, float]:
    """:func:`one_step_point`'s coefficients (N_COEFFICIENTS,) and step length."""
    p, length = one_step_point(problem, found)
    theta, _, _ = problem.unpack(p[None])
    return theta[0], length
