"""EBM-PSO: the paper's two-step estimation-before-modelling method (section 3.2).

Step 1 reconstructs the aerodynamic forces and moments of every sample
(:func:`aeroid.estimation.reconstruct`); they are smoothed (eq. 32) and step 2 fits the
nine coefficients with one 9-D modified-PSO problem on eq. 34 (or its noise-weighted
form). The step-2 cost is quadratic in the coefficients and is evaluated exactly from
its quadratic form (:class:`aeroid.estimation.QuadraticCost`); its closed-form optimum
is reported in ``info["closed_form_theta"]`` as the yardstick of the PSO.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np

from aeroid.estimation import _pso as pso
from aeroid.estimation._eam import check_common_options, pso_history
from aeroid.estimation._interface import EstimationResult, Estimator, prior_bounds, register
from aeroid.estimation._objectives import EBM_ROWS, GUARD_FRACTION, ebm_cost
from aeroid.estimation._reconstruct import (
    DERIVATIVE_POLYORDER,
    DERIVATIVE_WINDOW,
    RATE_WEIGHT,
    ROLL_DERIVATIVE_WINDOW,
    SMOOTHING_WINDOW,
    Reconstruction,
    reconstruct,
)
from aeroid.flights._flight import Flight

__all__ = ["EBMPSO", "check_step_one_options", "reconstruction_info", "step_one"]


def reconstruction_info(rec: Reconstruction) -> dict[str, Any]:
    """Return the step-1 arrays stored in ``info`` (the paper's Figs. 9-12)."""
    return {"t": rec.t, "fm_raw": rec.fm, "fm_smooth": rec.fm_smooth,
            "fm_names": ("FAX", "FAY", "FAZ", "MX", "MY", "MZ"), "row_sd": rec.row_sd}


def check_step_one_options(est: Any) -> None:
    """Raise ValueError (one line) on bad step-1 options (checked at construction)."""
    if not (np.isfinite(est.rate_weight) and est.rate_weight > 0):
        raise ValueError(f"rate_weight must be > 0, got {est.rate_weight}")
    for name, low in (("smoothing_window", 1), ("derivative_window", DERIVATIVE_POLYORDER + 1),
                      ("roll_derivative_window", 3)):
        value = getattr(est, name)
        if value < low or value % 2 == 0:
            raise ValueError(f"{name} must be an odd integer >= {low}, got {value}")


def step_one(est: Any, flight: Flight) -> Reconstruction:
    """Run EBM step 1 with the estimator's reconstruction options."""
    return reconstruct(flight, rate_weight=est.rate_weight,
                       smoothing_window=est.smoothing_window,
                       derivative_window=est.derivative_window,
                       roll_derivative_window=est.roll_derivative_window)


@register
@dataclass(frozen=True, kw_only=True)
class EBMPSO(Estimator):
    """Two-step EBM with one 9-D modified-PSO problem (EBM-PSO).

    Options
    -------
    n_particles, n_iterations : int
        Paper: 450 x 200.
    weighting : {"noise", "relative"}
        Noise-weighted (default) or the paper's relative eq. 34 with the guard.
    smoothing : {"both", "forces", "none"}
        "both" (default) smooths targets and regressors, "forces" only the targets (the
        paper's way), "none" neither (notes, "Smoothing").
    lateral : bool
        Also fit F_AY and M_Z (default False: the paper's four rows F_AX, F_AZ, M_X, M_Y).
    guard_fraction, box, topology, interpolation
        As for EAM-PSO.
    rate_weight, smoothing_window, derivative_window, roll_derivative_window
        Step-1 options (:func:`aeroid.estimation.reconstruct`).
    """

    name: ClassVar[str] = "ebm-pso"
    description: ClassVar[str] = ("two-step EBM: forces/moments from accelerometers and rates, "
                                  "SG smoothing, one 9-D modified PSO (eq. 34)")

    n_particles: int = 450
    n_iterations: int = 200
    weighting: Literal["noise", "relative"] = "noise"
    smoothing: Literal["both", "forces", "none"] = "both"
    lateral: bool = False
    guard_fraction: float = GUARD_FRACTION
    box: tuple[float, ...] | None = None
    topology: Literal["ring", "global"] = "ring"
    interpolation: bool = True
    rate_weight: float = RATE_WEIGHT
    smoothing_window: int = SMOOTHING_WINDOW
    derivative_window: int = DERIVATIVE_WINDOW
    roll_derivative_window: int = ROLL_DERIVATIVE_WINDOW

    def __post_init__(self) -> None:
        check_common_options(self)
        check_step_one_options(self)
        if self.n_particles < 3:
            raise ValueError(f"n_particles must be >= 3, got {self.n_particles}")

    def run(self, flight: Flight, rng: np.random.Generator) -> EstimationResult:
        """Reconstruct, smooth and fit (see class docstring)."""
        rec = step_one(self, flight)
        rows = (0, 1, 2, 3, 4, 5) if self.lateral else EBM_ROWS
        cost = ebm_cost(flight, rec, weighting=self.weighting, smoothing=self.smoothing,
                        rows=rows, guard_fraction=self.guard_fraction)
        bounds = prior_bounds(flight.airframe, self.box)
        res = pso.minimize(cost, bounds, n_particles=self.n_particles,
                           n_iterations=self.n_iterations, rng=rng, topology=self.topology,
                           interpolation=self.interpolation)
        info = reconstruction_info(rec)
        info.update({"weighting": self.weighting, "smoothing": self.smoothing,
                     "rows": rows, "n_particles": self.n_particles, "bounds": bounds,
                     "closed_form_theta": cost.theta_opt, "closed_form_cost": cost.cost_min})
        return EstimationResult(
            estimator=self.name, theta=res.x, cost=res.cost, success=res.success,
            message=res.message, n_evaluations=res.n_evaluations,
            n_iterations=res.n_iterations, history=pso_history(res), info=info)
