"""Polish: from a swarm's best point to the optimum of the same objective.

A particle swarm with a fixed budget stops near its cost's optimum, not at it. The
``polish`` option of the PSO estimators (EAM-PSO, EBM-PSO, SEBM-PSO, pyswarms) finishes
the job with a local least-squares solve of the same objective over the same search box:

Quadratic costs (EBM, SEBM: :class:`aeroid.estimation.QuadraticCost`)
    ``J(theta) = J* + (theta - theta*)^T H (theta - theta*)``. With ``H = R^T R`` the
    minimum over the box is the bounded linear least-squares problem
    ``min ||R theta - R theta*||`` over the box, solved exactly by bounded-variable least
    squares (:func:`scipy.optimize.lsq_linear`, ``method="bvls"``) after scaling each
    coefficient by ``sqrt(H_jj)``. The problem is convex: the answer does not depend on
    the swarm's point.
Output error (EAM: :class:`aeroid.estimation.OutputErrorCost`)
    ``J(theta) = ||r(theta)||^2`` with ``r`` the weighted output errors
    (:meth:`~aeroid.estimation.OutputErrorCost.residuals`).
    :func:`scipy.optimize.least_squares` (trust-region reflective) within the box from
    the swarm's best point, each coefficient scaled by the box's width; the Jacobian is
    the central difference of the forward model, its 18 perturbed sets simulated in one
    batched call (:meth:`~aeroid.estimation.OutputErrorCost.jacobian`).

Bounds (a decision): the polish stays in the search box. The PSO solves a box-constrained
problem and the polish finishes that problem, not another one; an answer on a wall is
reported by :func:`aeroid.estimation.box_edge_warnings` like the swarm's. The unbounded
optimum of the quadratic costs is the closed form (``info["closed_form_theta"]``, and the
``equation-error`` baseline). benchmarks/results/polish.md counts how often the unbounded
optimum leaves the box.

Initial rates (output error; ``initial_rates``): the swarm simulates from the measured
first state with smoothed rates (:class:`aeroid.estimation.OutputErrorCost`). Held
there, the objective's own optimum is off on a noise-free flight (Cl0, Clp 0.43 / 0.51 %,
Cmq 0.20 % with the relative weighting, from a 2.7e-3 rad/s error of the smoothed p0);
fitting p0, q0, r0 with the coefficients (nuisance parameters, unbounded) brings every
coefficient within 0.015 %. The estimators fit them by default.

The polished point replaces the swarm's only when its cost is lower (it always is,
except at round-off when the swarm had already converged). :class:`Polished` records
both costs for ``info["polish"]``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.optimize

from aeroid.estimation._objectives import OutputErrorCost, QuadraticCost
from aeroid.model import STATE_NAMES

__all__ = ["MAX_POLISH_EVALUATIONS", "POLISH_TOL", "Polished", "polish", "polish_info"]

#: ``ftol``, ``xtol`` and ``gtol`` of the output-error solve. The reference flight's
#: Gauss-Newton steps shrink ~100-fold per iteration near the optimum, so 1e-10 costs
#: one or two iterations more than scipy's 1e-8 and puts the answer well inside the
#: 1e-3 relative cost target of issue 11.
POLISH_TOL = 1e-10
#: Scale of the initial rates in the trust region [rad/s] (the coefficients' scale is the
#: box's width): the rates are known to about the rate noise, 0.005-1 rad/s.
RATE_SCALE = 1.0
#: The initial-state components fitted with ``initial_rates``.
RATE_NAMES: tuple[str, ...] = ("p", "q", "r")
#: Most residual evaluations of the output-error solve (each also needs a Jacobian, 18
#: simulated sets). Measured from the paper's swarm and from reduced swarms: 4-15.
MAX_POLISH_EVALUATIONS = 100


@dataclass(frozen=True, kw_only=True)
class Polished:
    """Outcome of :func:`polish`.

    Attributes
    ----------
    theta : ndarray, shape (d,)
        The polished point (the swarm's point when polishing did not lower the cost).
    cost : float
        The objective at ``theta``.
    swarm_theta : ndarray, shape (d,)
        The swarm's best point.
    swarm_cost : float
        The objective there.
    reference_cost : float or None
        The objective's known optimum (the quadratic costs' unconstrained closed form);
        None where there is none (output error).
    state0 : ndarray, shape (9,), or None
        Output error: the initial state of the polished simulation (the fitted initial
        rates with ``initial_rates``); None otherwise.
    solver : str
    converged : bool
        The solver met its tolerance (False: stopped on its evaluation limit, or the
        model diverged next to the swarm's point).
    message : str
        One line.
    n_evaluations : int
        Simulations (output error: one per residual, two per fitted parameter per
        Jacobian); 0 for the quadratic costs (the solve uses the quadratic form).
    """

    theta: np.ndarray
    cost: float
    swarm_theta: np.ndarray
    swarm_cost: float
    reference_cost: float | None
    state0: np.ndarray | None
    solver: str
    converged: bool
    message: str
    n_evaluations: int


def polish(cost: Any, bounds: np.ndarray, theta0: np.ndarray, *,
           initial_rates: bool = False) -> Polished:
    """Minimise ``cost`` over the box from ``theta0`` by local least squares.

    Parameters
    ----------
    cost : QuadraticCost or OutputErrorCost
        The objective the swarm minimised.
    bounds : ndarray, shape (d, 2)
        The search box, ``[low, high]`` per coefficient.
    theta0 : ndarray, shape (d,)
        The swarm's best point (inside the box).
    initial_rates : bool
        Output error only: fit the initial body rates p, q, r with the coefficients
        (nuisance parameters, unbounded, starting from ``cost.state0``), instead of
        holding them at the cost's smoothed estimate (module docstring).

    Returns
    -------
    Polished
    """
    bounds = np.asarray(bounds, dtype=float).reshape(-1, 2)
    theta0 = np.asarray(theta0, dtype=float).reshape(-1)
    swarm_cost = float(cost(theta0))
    state0 = None
    if isinstance(cost, QuadraticCost):
        theta, converged, message, n_eval = _bounded_quadratic(cost, bounds)
        new_cost = float(cost(theta))
        solver, reference = "lsq_linear (bvls) on the quadratic form", cost.cost_min
    elif isinstance(cost, OutputErrorCost):
        theta, state0, converged, message, n_eval = _bounded_output_error(
            cost, bounds, theta0, free_states=RATE_NAMES if initial_rates else ())
        r = cost.residuals(theta, state0)
        new_cost = float(r @ r) if np.all(np.isfinite(r)) else np.inf
        solver = "least_squares (trf), batched central-difference Jacobian"
        solver += ", initial p, q, r fitted" if initial_rates else ""
        reference = None
    else:
        raise TypeError(f"polish: no least-squares form for {type(cost).__name__}")
    if not new_cost < swarm_cost:  # never worse than the swarm
        theta, new_cost, state0 = theta0.copy(), swarm_cost, None
    return Polished(theta=theta, cost=new_cost, swarm_theta=theta0.copy(),
                    swarm_cost=swarm_cost, reference_cost=reference, state0=state0,
                    solver=solver, converged=converged, message=message,
                    n_evaluations=n_eval)


def _bounded_quadratic(cost: QuadraticCost, bounds: np.ndarray
                       ) -> tuple[np.ndarray, bool, str, int]:
    """Exact minimiser of the quadratic form over the box (module docstring)."""
    hessian = cost.hessian
    scale = np.sqrt(np.maximum(np.diag(hessian), 0.0))
    scale[scale == 0] = 1.0
    values, vectors = np.linalg.eigh(hessian / np.outer(scale, scale))
    factor = np.sqrt(np.maximum(values, 0.0))[:, None] * vectors.T  # R^T R = H scaled
    target = factor @ (cost.theta_opt * scale)
    res = scipy.optimize.lsq_linear(factor, target, bounds=(bounds[:, 0] * scale,
                                                            bounds[:, 1] * scale),
                                    method="bvls")
    theta = np.clip(res.x / scale, bounds[:, 0], bounds[:, 1])
    return theta, bool(res.success), _one_line(res.message), 0


def _bounded_output_error(cost: OutputErrorCost, bounds: np.ndarray, theta0: np.ndarray,
                          free_states: tuple[str, ...]
                          ) -> tuple[np.ndarray, np.ndarray | None, bool, str, int]:
    """Trust-region reflective least squares of the output errors within the box."""
    n_coef = theta0.size
    free = [STATE_NAMES.index(name) for name in free_states]
    base = cost.state0.copy()
    sets = {"n": 0}

    def state_of(x: np.ndarray) -> np.ndarray:
        state = base.copy()
        state[free] = x[n_coef:]
        return state

    def fun(x: np.ndarray) -> np.ndarray:
        sets["n"] += 1
        return cost.residuals(x[:n_coef], state_of(x))

    def jac(x: np.ndarray) -> np.ndarray:
        sets["n"] += 2 * x.size
        j = cost.jacobian(x[:n_coef], state_of(x), free_states=free_states)
        if not np.all(np.isfinite(j)):
            raise FloatingPointError("the model diverged next to a polish iterate")
        return j

    low = np.concatenate([bounds[:, 0], np.full(len(free), -np.inf)])
    high = np.concatenate([bounds[:, 1], np.full(len(free), np.inf)])
    x0 = np.concatenate([np.clip(theta0, bounds[:, 0], bounds[:, 1]), base[free]])
    scale = np.concatenate([bounds[:, 1] - bounds[:, 0], np.full(len(free), RATE_SCALE)])
    if not np.all(np.isfinite(fun(x0))):
        return theta0.copy(), None, False, "the model diverged at the swarm's best point", 1
    try:
        res = scipy.optimize.least_squares(
            fun, x0, jac=jac, bounds=(low, high), method="trf", x_scale=scale,
            ftol=POLISH_TOL, xtol=POLISH_TOL, gtol=POLISH_TOL,
            max_nfev=MAX_POLISH_EVALUATIONS)
    except FloatingPointError as exc:
        return theta0.copy(), None, False, str(exc), sets["n"]
    message = _one_line(res.message) + f" ({res.nfev} residual, {res.njev} Jacobian evaluations)"
    x = np.clip(res.x, low, high)
    return x[:n_coef], state_of(x), res.status > 0, message, sets["n"]


def polish_info(polished: Polished) -> dict[str, Any]:
    """Return ``info["polish"]``: the swarm's and the polished cost, the reference optimum."""
    return {"solver": polished.solver, "swarm_theta": polished.swarm_theta,
            "swarm_cost": polished.swarm_cost, "polished_cost": polished.cost,
            "reference_cost": polished.reference_cost, "state0": polished.state0,
            "converged": polished.converged,
            "message": polished.message, "n_evaluations": polished.n_evaluations}


def _one_line(text: Any) -> str:
    return " ".join(str(text).split())
