"""Output-error's starts: where Gauss-Newton begins, and how far the starts' ends agree.

Each start is a point in the fit's scaled parameters (``theta / prior`` for the
coefficients, the other parameters at their own start). The default is two starts: the
airframe's prior (or the PSO warm start's best point) and equation-error's closed-form
estimate of the same flight, which does not depend on the prior (:mod:`baselines.
equation_error`, fitted with the positions as given and the white-residual covariance: only
its point is used). The likeliest converged end wins; :func:`start_report` says how many ended
elsewhere and how much worse.

Measured on the paper condition from a prior 10-25 % off (200 runs, seeds 20240605 and
20240606, ``studies/output_error_prior_a.toml`` and ``_b.toml``): once the noise law is
fitted by maximum likelihood (:func:`baselines._gauss_newton.most_likely_law`), every
prior start reached the optimum of a fit started at the truth; the equation-error start
is the check that says so in each result, and the rescue when the prior is far off (a
prior with the wrong sign of Cma, on which the prior start does not converge).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

import aeroid
from aeroid.estimation import minimize
from aeroid.flights import Flight, model_constants
from aeroid.model import ForwardModel

#: Two ends lie at the same optimum when no coefficient differs by more than this many of
#: the best end's standard errors: 50x the fit's convergence tolerance (1e-3 sd); the two
#: starts' ends agreed within 1.7e-3 sd on each of 200 paper-condition runs.
SAME_OPTIMUM_SD = 0.05
#: An end farther than this many standard errors from the best is a warning: the answer
#: depended on the start by more than its own uncertainty.
WARN_SD = 1.0
#: Ends within this relative distance (largest over the coefficients) are the same point
#: whatever their standard errors: on a noise-free flight the residuals are the model's
#: discretisation error and the standard errors shrink with them (1e-10 relative), and
#: the two starts' ends, 4.7e-6 apart, were 1.3e4 "standard errors" apart
#: (continuous_relay, noise-free, input events). The smallest standard error under the
#: paper's noise is 9e-5 relative (Cma), so a genuine second optimum is far beyond.
SAME_POINT_REL = 2e-5
#: Options of the equation-error start: only its point is used, so the cheapest
#: covariance and the positions as given.
EQUATION_ERROR_OPTIONS = {"positions": "known", "covariance": "ols"}


#: A start after a converged one is given up when, at the pace of its cost over its last
#: this many iterations, it cannot come within :func:`give_up`'s margin of the converged
#: end's cost by its iteration limit (ends that converge take fewer on noisy flights: 8 on
#: the reference flight).
PACE_ITERATIONS = 10


@dataclass(frozen=True)
class Start:
    """A start: its label and scaled parameters (``p0``), or why it could not be made."""

    label: str
    p0: np.ndarray | None
    failure: str = ""


def equation_error_start(flight: Flight, first: np.ndarray, scale: np.ndarray,
                         rng: np.random.Generator) -> Start:
    """Return the start at equation-error's estimate (the rest of ``first`` kept)."""
    try:
        est = aeroid.make_estimator("equation-error", EQUATION_ERROR_OPTIONS)
        if getattr(flight.airframe, "tables", None) is not None:  # run dispatches tables
            result = est.run(flight, rng)
            theta = np.asarray(result.theta, dtype=float)
            n = len(result.names)  # the tables' parameters
        else:  # the estimate alone (no fit check, floor or robust covariance)
            theta = np.asarray(est.point(flight), dtype=float)  # type: ignore[attr-defined]
            n = theta.size
    except Exception as exc:  # failure is data: the fit goes on from its other starts
        text = " ".join(str(exc).split())
        return Start("equation-error", None, text)
    if theta.shape != (n,) or not np.all(np.isfinite(theta)):
        return Start("equation-error", None, "no finite estimate")
    p0 = first.copy()
    p0[:n] = theta / scale[:n]
    return Start("equation-error", p0)


def give_up(ends: list[Any], est: Any) -> Callable[[int, list], str | None] | None:
    """Return Gauss-Newton's ``stop`` for the next start: None until a start converged.

    Why: on noise-free sensor-suite flights with ``imu_errors``, equation-error's Cl0 is
    the truth times ``1 + sp`` (it takes the p gyro's reading, scale error ``sp``, as the
    rate: ``Ixx (1 + sp) pdot = qSd (Cl0 (1 + sp) + Clp (1 + sp) p d / 2V)``), so from its
    start the predicted roll angle drifts (sp -0.23 %, 51 rad of roll: 0.12 rad in the
    1 s record) and Gauss-Newton creeps along the roll valley, its step tens of standard
    deviations for dozens of iterations, to the iteration limit (``stop`` unused: 50
    iterations, or 200, then discarded). ``stop`` ends it once, at the pace of its cost
    over the last :data:`PACE_ITERATIONS` iterations, it cannot come within the margin
    (the number of parameters, in negative log-likelihood: twice that as a
    likelihood-ratio statistic is far beyond a tie) of the likeliest converged end's cost
    by ``est.max_iterations``: an end that does not converge is no result
    (:func:`best_end`) and shows no second optimum (:func:`start_report`), so what the fit
    reports is unchanged; ``info['start_stopped']`` says it.
    """
    done = [f.nll for f in ends if f.converged]
    if not done:
        return None
    target = min(done)
    budget = int(est.max_iterations)

    def stop(iteration: int, costs: list) -> str | None:
        if len(costs) <= PACE_ITERATIONS:
            return None
        margin = float(ends[0].p.size)
        pace = (costs[-1 - PACE_ITERATIONS] - costs[-1]) / PACE_ITERATIONS
        reach = costs[-1] - max(pace, 0.0) * (budget - iteration)
        if reach <= target + margin:
            return None
        return (f"stopped after {iteration} iterations: at its pace ({pace:.3g} per "
                f"iteration) its cost {costs[-1]:.6g} would be {reach:.6g} at max_iterations "
                f"({budget}), not within {margin:g} of a converged start's {target:.6g}")

    return stop


def best_end(ends: list[Any]) -> int:
    """Index of the likeliest converged end, or of the likeliest end when none converged.

    An end that stopped on its iteration limit is not an optimum: on a noise-free flight
    one start stopped there at a lower cost (rounding-level residuals) than the other
    start's converged end, at the same coefficients to 2e-8.
    """
    converged = [k for k, f in enumerate(ends) if f.converged] or list(range(len(ends)))
    return min(converged, key=lambda k: ends[k].nll)


def start_report(labels: list[str], ends: list[Any], best: int, stderr: np.ndarray,
                 failures: list[str] = (), n_coefficients: int | None = None
                 ) -> tuple[dict[str, Any], list[str]]:
    """Compare every start's end with the best one; return ``info`` entries and warnings.

    Parameters
    ----------
    labels : list of str
        The starts that ran to an end, in order.
    ends : list of Fit
        Their ends (:class:`baselines._gauss_newton.Fit`, ``p`` scaled, ``nll``).
    best : int
        Index of the result: the likeliest converged end (the likeliest end when none
        converged, :func:`best_end`).
    stderr : ndarray, shape (n_p,)
        Standard errors of the best end's scaled parameters (positive).
    failures : list of str
        The starts that could not be made or fitted, ``"label: why"`` each.

    Returns
    -------
    info : dict
        ``start_labels``, ``start_costs``, ``start_converged``, ``start_cost_excess``
        (each end's cost minus the result's; negative only for an end that did not
        converge), ``start_distance_sd`` (each end's largest coefficient distance from
        the result, in the result's standard errors), ``start_distance_rel`` (the same,
        relative to the result's coefficients) and ``starts_elsewhere`` (how many ends
        lie farther than :data:`SAME_OPTIMUM_SD` and :data:`SAME_POINT_REL`);
        ``start_stopped`` (only when one was): label -> why, for the starts given up
        (:func:`give_up`).
    warnings : list of str
        One line when a converged end lies more than :data:`WARN_SD` standard errors
        away: a second optimum (an unconverged end shows none; ``info`` has it); one per
        failed start.
    """
    n = len(aeroid.NAMES) if n_coefficients is None else n_coefficients  # [tables]: more
    p_best, nll_best = ends[best].p[:n], ends[best].nll
    free = np.asarray(stderr[:n] > 0)  # a held coefficient (sd 0) is the same in every end
    with np.errstate(all="ignore"):
        distance = [float(np.max(np.abs(f.p[:n] - p_best)[free] / stderr[:n][free],
                                 initial=0.0)) for f in ends]
        relative = [float(np.max(np.abs(f.p[:n] / p_best - 1.0)[free & (p_best != 0)],
                                 initial=0.0)) for f in ends]
    excess = [float(f.nll - nll_best) for f in ends]
    elsewhere = [i for i, (d, r) in enumerate(zip(distance, relative, strict=True))
                 if not (d <= SAME_OPTIMUM_SD or r <= SAME_POINT_REL)]
    info = {"start_labels": list(labels), "start_costs": [float(f.nll) for f in ends],
            "start_converged": [bool(f.converged) for f in ends],
            "start_cost_excess": excess, "start_distance_sd": distance,
            "start_distance_rel": relative, "starts_elsewhere": len(elsewhere)}
    said = [getattr(f, "message", "") for f in ends]
    stopped = {label: m for label, m in zip(labels, said, strict=True)
               if m.startswith("stopped after")}
    if stopped:  # given up (give_up): said, no other key changes
        info["start_stopped"] = stopped
    far = [i for i in elsewhere if not distance[i] <= WARN_SD and ends[i].converged]
    warnings = [f"output-error: the {why.replace(': ', ' start failed: ', 1)}"
                for why in failures]
    if far:
        k = max(far, key=lambda i: distance[i])
        warnings.append(
            f"output-error: {len(far)} of {len(ends)} starts converged elsewhere: start "
            f"{labels[k]!r} {distance[k]:.3g} standard errors from the result, its cost "
            f"higher by {excess[k]:.3g}; the result is the likeliest end (start "
            f"{labels[best]!r}), more starts (n_starts) may find a likelier one")
    return info, warnings


def warm_start_point(est: Any, prob: Any, flight: Flight, rng: np.random.Generator
                   ) -> tuple[np.ndarray, int]:
    """Return the best coefficients of output-error's short PSO run and its evaluation count.

    The PSO minimises the concentrated likelihood ``sum_j log mean_k e_kj^2`` within
    :func:`aeroid.prior_bounds` (the option ``pso_warm_start``).
    """
    record_model = prob.model
    model = ForwardModel(model_constants(flight), record_model.record(est.delay_s),
                         flight.airframe.accel_positions, substeps=est.substeps)
    m = len(model.output_names)  # the IMU's outputs (aiding channels after them: not here)

    def cost(thetas: np.ndarray) -> np.ndarray:
        ms = np.mean((prob.z[None, :, :m] - model.outputs(record_model.x0, thetas)) ** 2, axis=1)
        with np.errstate(all="ignore"):
            out = np.sum(np.log(np.maximum(ms, prob.r_floor[:m])), axis=1)
        return np.where(np.isfinite(out), out, np.inf)

    res = minimize(cost, aeroid.prior_bounds(flight.airframe),
                   n_particles=est.pso_particles, n_iterations=est.pso_iterations,
                   rng=rng, x0=flight.airframe.prior_vector()[None, :])
    return np.asarray(res.x), int(res.n_evaluations)
