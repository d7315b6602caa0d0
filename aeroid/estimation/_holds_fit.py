"""What the methods share to fit with held and prior coefficients (:class:`CoefficientSpec`).

The Gaussian combination of an estimate with the priors (:func:`combine_with_prior`),
the Cramér-Rao floor of the free coefficients with the priors (:func:`floor_with_holds`),
a swarm's cost over the free coefficients with the priors' penalty (:func:`free_cost`),
and the result's bookkeeping: :func:`apply_holds` (held values, no standard errors),
:func:`check_free` (the fit check on the free ones) and :func:`holds_of`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any

import numpy as np

from aeroid.estimation._holds import CoefficientSpec
from aeroid.model import NAMES

if TYPE_CHECKING:
    from aeroid.estimation._result import EstimationResult
    from aeroid.estimation._table_holds import TableHolds

__all__ = ["apply_holds", "check_free", "combine_with_prior", "floor_with_holds",
           "free_cost", "holds_of"]


def combine_with_prior(theta: np.ndarray, covariance: np.ndarray, spec: CoefficientSpec
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Return the Gaussian combination of an estimate with the spec's priors.

    ``theta`` (k,) and ``covariance`` (k, k) over the free coefficients
    (``spec.free_names``): the posterior of a Gaussian likelihood with that mean and
    covariance and the independent priors, ``C = inv(inv(cov) + W)``,
    ``theta' = C (inv(cov) theta + W mu)``, ``W`` the prior's information. For a linear
    least-squares problem this is the solution with the prior as weighted
    pseudo-observations ``(theta_j - mu_j) / sd_j``. Computed in the covariance form
    (``K = C H^T (H C H^T + diag(sd^2))^-1``), equal to the information form. Without
    priors, the inputs unchanged.
    """
    theta = np.asarray(theta, dtype=float)
    covariance = np.asarray(covariance, dtype=float)
    free = spec.free_index
    mean, sd = spec.prior_mean_sd()
    rows = np.flatnonzero(np.isfinite(sd[free]))  # free coefficients with a prior
    if rows.size == 0:
        return theta, covariance
    # the covariance form of the same update (a Kalman update with the prior as a
    # measurement): only the small (n_prior, n_prior) matrix is inverted, so a nearly
    # exact coefficient (noise-free data) does not make the information singular
    CH = covariance[:, rows]
    S = covariance[np.ix_(rows, rows)] + np.diag(sd[free][rows] ** 2)
    gain = np.linalg.solve(S, CH.T).T
    post = covariance - gain @ CH.T
    return theta + gain @ (mean[free][rows] - theta[rows]), 0.5 * (post + post.T)


def floor_with_holds(information: np.ndarray, spec: CoefficientSpec | None) -> np.ndarray:
    """Return the Cramér-Rao sd of the coefficients given the spec, shape (N,).

    ``information`` (N, N): the data's Fisher information of all coefficients. The free
    ones' floor is ``sqrt(diag(inv(F_ff + diag(1 / sd^2))))`` (prior information added
    where there is a prior); held ones are NaN (known, no floor). ``spec`` None: all free,
    ``sqrt(diag(inv(F)))``.

    Raises
    ------
    numpy.linalg.LinAlgError
        When the free block (with the priors) is singular.
    """
    spec = CoefficientSpec() if spec is None else spec
    info = np.asarray(information, dtype=float)
    free = spec.free_index
    block = info[np.ix_(free, free)] + np.diag(spec.prior_information()[free])
    out = np.full(len(NAMES), np.nan)
    out[free] = np.sqrt(np.diag(np.linalg.inv(block)))
    return out


Swarm = Callable[[np.ndarray], Any]


def free_cost(cost: Swarm, spec: CoefficientSpec, n_samples: float,
              names: Iterable[str] = NAMES) -> tuple[np.ndarray, Swarm, Swarm]:
    """Return a swarm cost over the free coefficients of ``names``, with the priors' penalty.

    ``cost(theta (..., len(names)))`` is a cost ``J = (1/N) sum w r^2`` of the paper's form
    with noise weights (``2 / N`` times a negative log-likelihood); a prior ``N(mu, sd^2)``
    adds ``((theta - mu) / sd)^2 / N`` (``N = n_samples``), its share on the same scale.

    Returns
    -------
    free : ndarray of int
        Positions in ``names`` of the free coefficients.
    reduced : callable
        ``reduced(theta_free (..., k))``: the cost at the full vector plus the penalty.
    expand : callable
        ``expand(theta_free (..., k)) -> (..., len(names))`` with the held values put in.
    """
    names = list(names)
    free = np.array([i for i, n in enumerate(names) if n not in spec.held], dtype=int)
    held = np.array([i for i, n in enumerate(names) if n in spec.held], dtype=int)
    values = np.array([spec.held[names[i]] for i in held], dtype=float)
    mean, sd = spec.prior_mean_sd()
    at = [NAMES.index(names[i]) for i in free]
    rows = np.array([k for k, j in enumerate(at) if np.isfinite(sd[j])], dtype=int)
    mu = np.array([mean[at[k]] for k in rows], dtype=float)
    weight = np.array([sd[at[k]] ** -2.0 for k in rows], dtype=float)

    def expand(theta: np.ndarray) -> np.ndarray:
        theta = np.asarray(theta, dtype=float)
        out = np.empty((*theta.shape[:-1], len(names)))
        out[..., free] = theta
        out[..., held] = values
        return out

    def reduced(theta: np.ndarray) -> Any:
        theta = np.asarray(theta, dtype=float)
        penalty = np.sum(weight * (theta[..., rows] - mu) ** 2, axis=-1) / float(n_samples)
        return cost(expand(theta)) + penalty

    return free, reduced, expand


def holds_of(result: EstimationResult) -> CoefficientSpec | None:
    """Return the spec a result was fitted with (its ``held`` and ``priors``), None when
    every coefficient was free."""
    if not (result.held or result.priors):
        return None
    return CoefficientSpec(held=result.held, priors=result.priors)


def check_free(result: EstimationResult, spec: CoefficientSpec | TableHolds,
               check: Callable[[EstimationResult], EstimationResult]) -> EstimationResult:
    """Run a result check (the fit check) on the free coefficients only.

    ``check`` sees the result restricted to the free coefficients (names, estimates,
    covariance, ``info["information"]``), so a held coefficient, known, is never
    "without information"; its verdict (success, message, warnings, info) is returned
    on the full result.
    """
    if not spec.held:
        return check(result)
    free = spec.free_index
    info = dict(result.info)
    if info.get("information") is not None:
        info["information"] = np.asarray(info["information"], dtype=float)[np.ix_(free, free)]
    cov = result.covariance
    small = dataclasses.replace(
        result, names=tuple(result.names[j] for j in free), theta=result.theta[free],
        stderr=None if result.stderr is None else result.stderr[free],
        covariance=None if cov is None else np.asarray(cov)[np.ix_(free, free)], info=info)
    checked = check(small)
    out_info = dict(checked.info)
    if "information" in result.info:
        out_info["information"] = result.info["information"]
    return dataclasses.replace(result, success=checked.success, message=checked.message,
                               warnings=checked.warnings, info=out_info)


def apply_holds(result: EstimationResult, spec: CoefficientSpec | TableHolds
                ) -> EstimationResult:
    """Return ``result`` with the spec recorded and the held coefficients as held.

    Held coefficients: their value exactly, standard error NaN (none), zero covariance
    rows and columns (known, uncorrelated with the rest); the result's ``held`` and
    ``priors`` fields name them.
    """
    if spec.empty:
        return result
    theta = result.theta.copy()
    held = spec.held_index
    if result.success or np.all(np.isfinite(theta[spec.free_index])):
        theta[held] = spec.held_values()
    stderr = None if result.stderr is None else result.stderr.copy()
    if stderr is not None:
        stderr[held] = np.nan
    cov = None if result.covariance is None else np.array(result.covariance, dtype=float)
    if cov is not None:
        cov[held, :] = 0.0
        cov[:, held] = 0.0
    return dataclasses.replace(result, theta=theta, stderr=stderr, covariance=cov,
                               held=dict(spec.held), priors=dict(spec.priors))
