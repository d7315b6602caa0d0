"""What the paper's three PSO methods share: option checks, limits, step 1, the PSO run.

The PSO run ends, with the option ``polish``, in a local least-squares solve of the same
objective from the swarm's best point (:mod:`aeroid.estimation._polish`).

EAM-PSO, EBM-PSO and SEBM-PSO (:mod:`aeroid.estimation._eam`, ``_ebm``, ``_sebm``) each
use these helpers and none of the others: the methods do not import one another.

Limits: option values are bounded when the estimator is built, before anything is
allocated, so a typo (``n_particles = 100000000``) is a one-line error instead of a
machine out of memory; each bound below says why it is where it is.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from aeroid.estimation import _pso as pso
from aeroid.estimation._air_data import check_air_options
from aeroid.estimation._estimator import Estimator
from aeroid.estimation._holds import CoefficientSpec
from aeroid.estimation._holds_fit import free_cost
from aeroid.estimation._objectives import GUARD_FRACTION, WEIGHTINGS
from aeroid.estimation._polish import Polished, polish
from aeroid.estimation._progress import pso_callback
from aeroid.estimation._reconstruct import (
    DERIVATIVE_POLYORDER,
    DERIVATIVE_WINDOW,
    RATE_WEIGHT,
    ROLL_DERIVATIVE_WINDOW,
    SMOOTHING_WINDOW,
    Reconstruction,
    reconstruct,
)
from aeroid.estimation._result import box_edge_warnings
from aeroid.flights import Flight
from aeroid.model import NAMES

__all__ = [
    "MAX_ITERATIONS", "MAX_PARTICLES", "MAX_SUBSTEPS", "PSOMethodOptions", "StepOneOptions",
    "check_common_options",
    "check_step_one_options", "check_swarm_size", "held_search", "polish_result",
    "prior_information", "pso_history", "reconstruction_info", "run_pso", "step_one",
]

#: Largest swarm. EAM-PSO simulates the whole swarm at once and holds its states,
#: n_particles x samples x 9 float64: 10,000 particles on the 501-sample reference flight
#: are 360 MB (22x the paper's 450 particles); beyond that memory, not the search, binds.
MAX_PARTICLES = 10_000
#: Most iterations. The history keeps the best point of every iteration and the run time
#: grows linearly: 100,000 iterations (500x the paper's 200) of the paper's EAM-PSO swarm
#: would take about three hours here.
MAX_ITERATIONS = 100_000
#: Most RK4 steps per sample interval (EAM-PSO). One step per 2 ms sample is accurate to
#: ~1e-5 relative on the reference flight; 100 put the truncation error below round-off,
#: so more only multiply the run time.
MAX_SUBSTEPS = 100


def check_swarm_size(n_particles: int, *, minimum: int = 3) -> None:
    """Raise ValueError (one line) unless ``minimum <= n_particles <= MAX_PARTICLES``.

    ``minimum`` is 3 with the quadratic interpolation, which needs two other particles.
    """
    if not minimum <= n_particles <= MAX_PARTICLES:
        raise ValueError(f"n_particles must be in [{minimum}, {MAX_PARTICLES}] "
                         f"(MAX_PARTICLES: memory), got {n_particles}")


def check_common_options(est: Any) -> None:
    """Raise ValueError (one line) on bad PSO/cost options shared by the paper's methods.

    ``n_iterations`` must be at least 1: with 0 the answer would be the best point of the
    random initial swarm, a guess that looks like an estimate.
    """
    if est.weighting not in WEIGHTINGS:
        raise ValueError(f"weighting must be one of {', '.join(WEIGHTINGS)}")
    if est.topology not in ("ring", "global"):
        raise ValueError("topology must be 'ring' or 'global'")
    if not (0.0 <= est.guard_fraction < 1.0):
        raise ValueError(f"guard_fraction must be in [0, 1), got {est.guard_fraction}")
    if not 1 <= est.n_iterations <= MAX_ITERATIONS:
        raise ValueError(f"n_iterations must be in [1, {MAX_ITERATIONS}] (0 would return the "
                         f"best point of the random initial swarm), got {est.n_iterations}")
    if est.box is not None:
        n = len(NAMES)
        if len(est.box) != 2 * n:
            raise ValueError(f"box needs {2 * n} numbers [low, high] per coefficient "
                             f"({', '.join(NAMES)}), got {len(est.box)}")
        box = np.asarray(est.box, dtype=float).reshape(n, 2)
        if not (np.all(np.isfinite(box)) and np.all(box[:, 0] < box[:, 1])):
            raise ValueError(f"box needs {n} finite [low, high] pairs with low < high")


@dataclass(frozen=True, kw_only=True)
class PSOMethodOptions(Estimator):
    """The options every paper PSO method has, written once (not registered itself).

    Each method's class docstring documents them in its ``Options`` (the swarm size is
    the method's own: one int, or one per SEBM sub-problem). Checked when the estimator
    is built (:func:`check_common_options`).
    """

    n_iterations: int = 200
    weighting: Literal["noise", "relative"] = "noise"
    guard_fraction: float = GUARD_FRACTION
    box: tuple[float, ...] | None = None
    topology: Literal["ring", "global"] = "ring"
    interpolation: bool = True
    polish: bool = False

    def __post_init__(self) -> None:
        check_common_options(self)


@dataclass(frozen=True, kw_only=True)
class StepOneOptions(PSOMethodOptions):
    """The options of the methods that start with EBM step 1 (EBM-PSO, SEBM-PSO).

    Checked when the estimator is built (:func:`check_step_one_options`).
    """

    smoothing: Literal["both", "forces", "none"] = "both"
    rate_weight: float = RATE_WEIGHT
    smoothing_window: int = SMOOTHING_WINDOW
    derivative_window: int = DERIVATIVE_WINDOW
    roll_derivative_window: int = ROLL_DERIVATIVE_WINDOW
    air_data: Literal["inertial", "auto", "measured", "reconstruction"] = "inertial"
    air_data_window_s: float | None = None  # the Kalman smoother, as equation-error's

    def __post_init__(self) -> None:
        super().__post_init__()
        check_step_one_options(self)


def check_step_one_options(est: Any) -> None:
    """Raise ValueError (one line) on bad step-1 options (checked at construction)."""
    if not (np.isfinite(est.rate_weight) and est.rate_weight > 0):
        raise ValueError(f"rate_weight must be > 0, got {est.rate_weight}")
    for name, low in (("smoothing_window", 1), ("derivative_window", DERIVATIVE_POLYORDER + 1),
                      ("roll_derivative_window", 3)):
        value = getattr(est, name)
        if value < low or value % 2 == 0:
            raise ValueError(f"{name} must be an odd integer >= {low}, got {value}")
    check_air_options(est)


def step_one(est: Any, flight: Flight) -> Reconstruction:
    """Run EBM step 1 with the estimator's reconstruction options."""
    return reconstruct(flight, rate_weight=est.rate_weight,
                       smoothing_window=est.smoothing_window,
                       derivative_window=est.derivative_window,
                       roll_derivative_window=est.roll_derivative_window)


def reconstruction_info(rec: Reconstruction) -> dict[str, Any]:
    """Return the step-1 arrays stored in ``info`` (the paper's Figs. 9-12)."""
    return {"t": rec.t, "fm_raw": rec.fm, "fm_smooth": rec.fm_smooth,
            "fm_names": ("FAX", "FAY", "FAZ", "MX", "MY", "MZ"), "row_sd": rec.row_sd}


def pso_history(res: pso.PSOResult) -> dict[str, Any]:
    """Return the result history (axis 'iteration') of one PSO run over all nine coefficients."""
    return {"axis": "iteration", "step": np.arange(res.history_cost.size),
            "cost": np.asarray(res.history_cost, dtype=float),
            "theta": np.asarray(res.history_x, dtype=float)}


def run_pso(est: Any, cost: Any, bounds: np.ndarray, rng: np.random.Generator, *,
            n_particles: int, names: Sequence[str] = NAMES, stage: str = "PSO",
            holds: CoefficientSpec | None = None,
            **kwargs: Any) -> tuple[pso.PSOResult, tuple[str, ...], Polished | None]:
    """Run the modified PSO with the estimator's options, polish, check the edges.

    Parameters
    ----------
    est : estimator
        Provides ``n_iterations``, ``topology``, ``interpolation`` and ``polish`` (and,
        for output error, ``polish_initial_rates``).
    cost : callable
        ``cost(theta (P, d)) -> (P,)``; a :class:`aeroid.estimation.QuadraticCost` or
        :class:`aeroid.estimation.OutputErrorCost` when ``est.polish``.
    bounds : ndarray, shape (d, 2)
    rng : numpy.random.Generator
    n_particles : int
    names : sequence of str, length d
        Names of the searched coefficients (for the warnings).
    stage : str
        Name of this run in the progress reports.
    holds : CoefficientSpec or None
        Held coefficients leave the search (the box shrinks to the free ones); priors
        add their penalty to the cost (:func:`held_search`). The result is over ``names``.
    **kwargs
        Passed to :func:`aeroid.estimation.minimize` (``x0``, ``stall_iterations``).

    Returns
    -------
    PSOResult
        The swarm's result; with ``polish``, ``x``, ``cost``, ``n_evaluations`` and
        ``message`` are the polished ones (the history stays the swarm's).
    tuple of str
        The run's warnings: :func:`aeroid.estimation.box_edge_warnings` of its answer
        and a polish that did not converge (none when the run failed: its message says
        why).
    Polished or None
        The polish (:func:`polish_result`), None without ``polish`` or when the swarm
        found no finite cost.
    """
    if holds is not None and not holds.empty:
        return held_search(est, cost, bounds, rng, n_particles=n_particles, names=names,
                           stage=stage, holds=holds, **kwargs)
    res = pso.minimize(cost, bounds, n_particles=n_particles, n_iterations=est.n_iterations,
                       rng=rng, topology=est.topology, interpolation=est.interpolation,
                       callback=pso_callback(est.n_iterations, stage), **kwargs)
    polished = None
    if getattr(est, "polish", False) and res.success:
        res, polished = polish_result(res, cost, bounds,
                                      initial_rates=getattr(est, "polish_initial_rates", False))
    warnings = box_edge_warnings(res.x, bounds, names) if res.success else ()
    if polished is not None and not polished.converged:
        warnings += (f"polish did not converge ({polished.message}): the answer may not "
                     "be the optimum of the objective",)
    return res, warnings, polished


def polish_result(res: pso.PSOResult, cost: Any, bounds: np.ndarray, *,
                  initial_rates: bool = False) -> tuple[pso.PSOResult, Polished]:
    """Polish a swarm's answer (:func:`aeroid.estimation._polish.polish`).

    Returns the result with the polished ``x`` and ``cost``, the polish's evaluations
    added and its outcome appended to the message, and the :class:`Polished` record.
    """
    polished = polish(cost, bounds, res.x, initial_rates=initial_rates)
    res = dataclasses.replace(
        res, x=polished.theta, cost=polished.cost,
        n_evaluations=res.n_evaluations + polished.n_evaluations,
        message=f"{res.message}; polished: {polished.message}")
    return res, polished


def held_search(est: Any, cost: Any, bounds: np.ndarray, rng: np.random.Generator, *,
                n_particles: int, names: Sequence[str], stage: str, holds: CoefficientSpec,
                **kwargs: Any) -> tuple[pso.PSOResult, tuple[str, ...], None]:
    """:func:`run_pso` over the free coefficients of ``names`` (the others held).

    The swarm searches the free coefficients' box; the cost sees the held values. A
    prior ``N(mu, sd^2)`` adds ``((theta - mu) / sd)^2 / N`` (``N`` the cost's samples):
    with ``weighting = "noise"`` the cost is ``2 / N`` times the negative log-likelihood,
    so this is the prior's share of the same scale (MAP). The result's ``x``, history and
    cost are over all of ``names`` (the cost with the penalty).

    Raises
    ------
    EstimatorError
        Priors with ``weighting = "relative"`` (no likelihood to add them to), or
        ``polish`` with held or prior coefficients (the polish solves the full problem).
    """
    from aeroid.errors import EstimatorError

    if getattr(est, "polish", False):
        raise EstimatorError(f"{est.name}: polish with held or prior coefficients is not "
                             "supported; set polish = false")
    if holds.priors and est.weighting != "noise":
        raise EstimatorError(f"{est.name}: priors need weighting = noise (the relative cost "
                             "is no log-likelihood to add them to)")
    names = list(names)
    n = float(getattr(cost, "n_samples", None) or cost.model.n_samples)
    free, reduced, full = free_cost(cost, holds, n, names)

    if free.size == 0:  # every coefficient of this (sub-)problem held
        x = full(np.empty(0))
        c = float(cost(x))
        res = pso.PSOResult(x=x, cost=c, success=True, message="every coefficient held",
                            n_evaluations=1, n_iterations=0, history_cost=np.array([c]),
                            history_x=x[None, :])
        return res, (), None
    if kwargs.get("x0") is not None:
        kwargs["x0"] = np.asarray(kwargs["x0"], dtype=float)[:, free]
    res = pso.minimize(reduced, bounds[free], n_particles=n_particles,
                       n_iterations=est.n_iterations, rng=rng, topology=est.topology,
                       interpolation=est.interpolation,
                       callback=pso_callback(est.n_iterations, stage), **kwargs)
    res = dataclasses.replace(res, x=full(res.x), history_x=full(res.history_x))
    warnings = box_edge_warnings(res.x[free], bounds[free], [names[i] for i in free]) \
        if res.success else ()
    return res, warnings, None


def prior_information(cost: Any, holds: CoefficientSpec | None) -> np.ndarray:
    """Return a quadratic cost's curvature ``H`` (N, N) with the priors' ``diag(1 / sd^2) / N``
    added (the penalty of :func:`held_search` in the cost's units)."""
    hessian = np.asarray(cost.hessian, dtype=float)
    if holds is None or not holds.priors:
        return hessian
    return hessian + np.diag(holds.prior_information()) / float(cost.n_samples)
