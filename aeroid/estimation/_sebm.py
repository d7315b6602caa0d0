"""SEBM-PSO: separated EBM, four small modified-PSO problems (section 3.3, eqs. 35-42).

Step 1 and smoothing as EBM-PSO; step 2 splits into F_AX -> Cx (eq. 39),
F_AZ -> Cza, Czd, Czq (eq. 40), M_X -> Cl0, Clp (eq. 41) and M_Y -> Cma, Cmd, Cmq
(eq. 42), with the paper's 50 / 150 / 100 / 150 particles and 200 iterations each.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from aeroid.errors import EstimatorError
from aeroid.estimation._estimator import prior_bounds
from aeroid.estimation._holds import CoefficientSpec
from aeroid.estimation._objectives import SEBM_PROBLEMS, sebm_costs
from aeroid.estimation._polish import polish_info
from aeroid.estimation._pso_air import step_one_air, with_step_one_air
from aeroid.estimation._pso_methods import (
    StepOneOptions,
    check_swarm_size,
    reconstruction_info,
    run_pso,
    step_one,
)
from aeroid.estimation._reconstruct import (
    ebm_regression,
    regression_fit,
)
from aeroid.estimation._registry import register
from aeroid.estimation._result import EstimationResult
from aeroid.flights import Flight
from aeroid.model import NAMES

__all__ = ["SEBMPSO"]

PAPER_PARTICLES: tuple[int, ...] = tuple(p for *_, p in SEBM_PROBLEMS)


@register
@dataclass(frozen=True, kw_only=True)
class SEBMPSO(StepOneOptions):
    """Separated EBM with four modified-PSO problems (SEBM-PSO).

    Options
    -------
    n_particles : ints, one per sub-problem (:data:`SEBM_PROBLEMS`)
        Swarm sizes of the F_AX, F_AZ, M_X, M_Y problems (paper: 50, 150, 100, 150).
    n_iterations : int
        Iterations of each problem, at least 1 (paper: 200).
    weighting : {"noise", "relative"}
        Noise-weighted rows (default) or the paper's relative eqs. 39-42 with the guard.
    smoothing : {"both", "forces", "none"}
        Savitzky-Golay smoothing of targets and regressors ("both", default), of the
        targets only ("forces", the paper's way), or of neither.
    guard_fraction : float
        Guard of the relative weighting, as a fraction of each row's mean square.
    box : 2 N_COEFFICIENTS numbers or None
        Search box ``[low0, high0, ...]``; default the airframe's prior x [0.5, 1.5].
    topology : {"ring", "global"}
        Neighbourhood of each swarm: the paper's singly-linked ring, or global best.
    interpolation : bool
        Apply the paper's quadratic interpolation operator (eqs. 20-22).
    rate_weight : float
        Step 1: weight of the rate-derivative rows against the accelerometer rows
        (:func:`aeroid.estimation.reconstruct`).
    smoothing_window : int
        Step 1: Savitzky-Golay window of the force and moment smoothing (eq. 32) [samples].
    derivative_window : int
        Step 1: Savitzky-Golay window of the pitch and yaw rate derivatives [samples].
    roll_derivative_window : int
        Step 1: Savitzky-Golay window of the roll rate derivative [samples].
    polish : bool
        Finish each problem with the exact minimum of its cost over its box (default
        False, the paper's method): bounded least squares on the quadratic form
        (:mod:`aeroid.estimation._polish`).
    air_data : {"inertial", "auto", "measured", "reconstruction"}
        Step 2: the aerodynamic angles from u, v, w (default inertial: the flight's
        logged air data are said ignored), from the logged alpha, beta and airspeed
        when the flight has them (auto), from those or a one-line refusal (measured),
        or with the reconstruction's steady wind (reconstruction), as equation-error's
        option of that name.
    air_data_window_s : float or None
        Step 2: smoothing of the wind the logged angles imply, in north-east-down axes:
        None (default, as equation-error's) a Kalman smoother whose gust intensity the
        data choose by maximum likelihood, or a Savitzky-Golay window of that many
        seconds (0.1 the former default; 0: none); :mod:`aeroid.estimation._pso_air`.
        No consider term: this method reports no standard errors to carry the smoothed
        wind's uncertainty in.

    Notes
    -----
    ``history`` combines the four runs: at iteration i, ``theta`` holds each problem's
    best coefficients and ``cost`` the sum of the four best costs (a problem that stopped
    earlier keeps its last value). ``info["subproblems"]`` has each run's own history.
    With ``polish``, ``info["subproblems"][label]["polish"]`` records each problem's
    swarm and polished cost, ``info["polish"]`` their sums, and ``cost`` is the sum of
    the polished costs (the history stays the swarms').
    """

    name: ClassVar[str] = "sebm-pso"
    supports_holds: ClassVar[bool] = True  # the search over the free ones: held_search
    uses_air_data: ClassVar[bool] = True  # option air_data (step_one_air)
    description: ClassVar[str] = ("separated EBM: step 1 as ebm-pso, then four PSO problems "
                                  "(eqs. 39-42; 50/150/100/150 particles)")

    n_particles: tuple[int, ...] = PAPER_PARTICLES

    def __post_init__(self) -> None:
        super().__post_init__()
        if len(self.n_particles) != len(SEBM_PROBLEMS):
            raise ValueError(f"n_particles needs {len(SEBM_PROBLEMS)} swarm sizes >= 3, "
                             f"got {self.n_particles}")
        for n in self.n_particles:
            check_swarm_size(n)

    def run(self, flight: Flight, rng: np.random.Generator,
            holds: CoefficientSpec | None = None) -> EstimationResult:
        """Reconstruct, smooth and solve the four problems (see class docstring)."""
        missing = sorted(set(range(len(NAMES))) - {c for _, _, cols, _ in SEBM_PROBLEMS
                                                   for c in cols})
        if missing:  # a coefficient added to the model but to no sub-problem
            raise EstimatorError(f"sebm-pso: no sub-problem estimates "
                                 f"{', '.join(NAMES[c] for c in missing)} (SEBM_PROBLEMS, "
                                 "aeroid/estimation/_objectives.py)")
        rec = step_one(self, flight)
        air = step_one_air(self, flight)
        bounds = prior_bounds(flight.airframe, self.box)
        theta = np.empty(len(NAMES))
        closed = np.empty(len(NAMES))
        subproblems: dict[str, Any] = {}
        runs = []
        warnings: list[str] = []
        problems = sebm_costs(flight, rec, weighting=self.weighting, smoothing=self.smoothing,
                              guard_fraction=self.guard_fraction, wind=air.wind)
        for k, ((label, cols, cost), n_particles) in enumerate(
                zip(problems, self.n_particles, strict=True)):
            res, found, polished = run_pso(self, cost, bounds[list(cols)], rng,
                                           n_particles=n_particles,
                                           names=[NAMES[c] for c in cols],
                                           stage=f"{label} {k + 1}/{len(self.n_particles)}",
                                           holds=holds)
            warnings += [f"{label}: {w}" for w in found]
            theta[list(cols)] = res.x
            closed[list(cols)] = cost.theta_opt
            runs.append((cols, res))
            subproblems[label] = {
                "coefficients": tuple(NAMES[c] for c in cols), "n_particles": n_particles,
                "cost": res.cost, "message": res.message, "n_evaluations": res.n_evaluations,
                "history_cost": res.history_cost, "history_theta": res.history_x,
                "closed_form_theta": cost.theta_opt, "closed_form_cost": cost.cost_min,
            }
            if polished is not None:
                subproblems[label]["polish"] = polish_info(polished)
        n_steps = max(res.history_cost.size for _, res in runs)
        hist_theta = np.empty((n_steps, len(NAMES)))
        hist_cost = np.zeros(n_steps)
        for cols, res in runs:
            idx = np.minimum(np.arange(n_steps), res.history_cost.size - 1)
            hist_theta[:, list(cols)] = res.history_x[idx]
            hist_cost += res.history_cost[idx]
        info = reconstruction_info(rec)
        info.update({"weighting": self.weighting, "smoothing": self.smoothing,
                     "n_particles": self.n_particles, "bounds": bounds,
                     "subproblems": subproblems, "closed_form_theta": closed,
                     "closed_form_cost": float(sum(s["closed_form_cost"]
                                                   for s in subproblems.values()))})
        X, y = ebm_regression(flight, rec, smoothing=self.smoothing, wind=air.wind)
        info.update(regression_fit(rec, X, y, theta, tuple(row for _, row, _, _ in SEBM_PROBLEMS)))
        success = all(res.success for _, res in runs)
        messages = sorted({res.message for _, res in runs})
        total = float(hist_cost[-1])
        polishes = [s["polish"] for s in subproblems.values() if "polish" in s]
        if polishes and len(polishes) == len(runs):
            total = float(sum(res.cost for _, res in runs))
            info["polish"] = {key: float(sum(p[key] for p in polishes))
                              for key in ("swarm_cost", "polished_cost", "reference_cost")}
        return with_step_one_air(EstimationResult(  # air_data's info, lines and refusal
            estimator=self.name, theta=theta, cost=total, success=success,
            message="; ".join(messages), warnings=tuple(warnings),
            n_evaluations=sum(r.n_evaluations for _, r in runs),
            n_iterations=max(r.n_iterations for _, r in runs),
            history={"axis": "iteration", "step": np.arange(n_steps), "cost": hist_cost,
                     "theta": hist_theta},
            info=info), self, flight, air)
