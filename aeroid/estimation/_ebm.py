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
from typing import ClassVar

import numpy as np

from aeroid.estimation._estimator import prior_bounds
from aeroid.estimation._holds import CoefficientSpec
from aeroid.estimation._objectives import EBM_ROWS, ebm_cost
from aeroid.estimation._polish import polish_info
from aeroid.estimation._pso_air import step_one_air, with_step_one_air
from aeroid.estimation._pso_methods import (
    StepOneOptions,
    check_swarm_size,
    prior_information,
    pso_history,
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

__all__ = ["EBMPSO"]


@register
@dataclass(frozen=True, kw_only=True)
class EBMPSO(StepOneOptions):
    """Two-step EBM with one 9-D modified-PSO problem (EBM-PSO).

    Options
    -------
    n_particles : int
        Swarm size (paper: 450).
    n_iterations : int
        Iterations of the swarm, at least 1 (paper: 200).
    weighting : {"noise", "relative"}
        Noise-weighted rows (default) or the paper's relative eq. 34 with the guard.
    smoothing : {"both", "forces", "none"}
        Savitzky-Golay smoothing of targets and regressors ("both", default), of the
        targets only ("forces", the paper's way), or of neither.
    lateral : bool
        Also fit F_AY and M_Z (default False: the paper's four rows F_AX, F_AZ, M_X, M_Y).
    guard_fraction : float
        Guard of the relative weighting, as a fraction of each row's mean square.
    box : 2 N_COEFFICIENTS numbers or None
        Search box ``[low0, high0, ...]``; default the airframe's prior x [0.5, 1.5].
    topology : {"ring", "global"}
        Neighbourhood of the swarm: the paper's singly-linked ring, or global best.
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
        Finish with the exact minimum of the same cost over the box (default False, the
        paper's method): bounded least squares on the quadratic form
        (:mod:`aeroid.estimation._polish`); ``info["polish"]`` holds both costs.
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
    """

    name: ClassVar[str] = "ebm-pso"
    supports_holds: ClassVar[bool] = True  # the search over the free ones: held_search
    uses_air_data: ClassVar[bool] = True  # option air_data (step_one_air)
    description: ClassVar[str] = ("two-step EBM: forces/moments from accelerometers and rates, "
                                  "SG smoothing, one 9-D modified PSO (eq. 34)")

    n_particles: int = 450
    lateral: bool = False

    def __post_init__(self) -> None:
        super().__post_init__()
        check_swarm_size(self.n_particles)

    def run(self, flight: Flight, rng: np.random.Generator,
            holds: CoefficientSpec | None = None) -> EstimationResult:
        """Reconstruct, smooth and fit (see class docstring)."""
        rec = step_one(self, flight)
        air = step_one_air(self, flight)
        rows = (0, 1, 2, 3, 4, 5) if self.lateral else EBM_ROWS
        cost = ebm_cost(flight, rec, weighting=self.weighting, smoothing=self.smoothing,
                        rows=rows, guard_fraction=self.guard_fraction, wind=air.wind)
        bounds = prior_bounds(flight.airframe, self.box)
        res, warnings, polished = run_pso(self, cost, bounds, rng, n_particles=self.n_particles,
                                          holds=holds)
        info = reconstruction_info(rec)
        info.update({"weighting": self.weighting, "smoothing": self.smoothing,
                     "rows": rows, "n_particles": self.n_particles, "bounds": bounds,
                     "closed_form_theta": cost.theta_opt, "closed_form_cost": cost.cost_min,
                     "information": prior_information(cost, holds)})  # identifiability
        if polished is not None:
            info["polish"] = polish_info(polished)
        X, y = ebm_regression(flight, rec, smoothing=self.smoothing, wind=air.wind)
        info.update(regression_fit(rec, X, y, res.x, tuple(rows)))
        return with_step_one_air(EstimationResult(  # air_data's info, lines and refusal
            estimator=self.name, theta=res.x, cost=res.cost, success=res.success,
            message=res.message, warnings=warnings, n_evaluations=res.n_evaluations,
            n_iterations=res.n_iterations, history=pso_history(res), info=info),
            self, flight, air)
