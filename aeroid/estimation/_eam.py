"""EAM-PSO: output-error estimation with the paper's modified PSO (section 3.1, eq. 23).

Every particle's coefficients are simulated over the whole record (batched RK4 over the
swarm, :func:`aeroid.model.propagate`) and the predicted triad-1 accelerations and
rates are compared with the measured ones (:class:`aeroid.estimation.OutputErrorCost`).
With ``air_data`` the swarm flies in the wind the logged air data imply
(:mod:`aeroid.estimation._eam_air`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np

from aeroid.errors import EstimatorError
from aeroid.estimation._eam_air import WindOutputErrorCost, check_air_options
from aeroid.estimation._estimator import prior_bounds
from aeroid.estimation._holds import CoefficientSpec
from aeroid.estimation._objectives import EAM_ROLL_WINDOW
from aeroid.estimation._polish import polish_info
from aeroid.estimation._pso_air import step_one_air, with_step_one_air
from aeroid.estimation._pso_methods import (
    MAX_SUBSTEPS,
    PSOMethodOptions,
    check_swarm_size,
    pso_history,
    run_pso,
)
from aeroid.estimation._registry import register
from aeroid.estimation._result import EstimationResult
from aeroid.flights import Flight
from aeroid.model import N_STATE

__all__ = ["EAMPSO", "MAX_SWARM_STATE_BYTES"]

#: Largest simulated swarm EAM-PSO allocates, n_particles x samples x 9 states x 8 bytes
#: (checked before the first simulation): 4 GiB, a third of a small workstation's memory.
#: The paper's swarm on the 501-sample reference flight needs 16 MB; a long log with a
#: large swarm is refused with one line instead of exhausting the machine.
MAX_SWARM_STATE_BYTES = 4 * 2**30


@register
@dataclass(frozen=True, kw_only=True)
class EAMPSO(PSOMethodOptions):
    """Output-error method with the paper's modified PSO (EAM-PSO).

    Options
    -------
    n_particles : int
        Swarm size (paper: 450).
    n_iterations : int
        Iterations of the swarm, at least 1 (paper: 200; section 4.1 says 100).
    weighting : {"noise", "relative"}
        Cost weighting: "noise" (default, maximum likelihood with per-channel noise
        levels estimated from the data) or "relative" (the paper's eq. 23 with the guard).
    guard_fraction : float
        Guard of the relative weighting, as a fraction of each channel's mean square.
    box : 2 N_COEFFICIENTS numbers or None
        Search box ``[low0, high0, ...]``; default the airframe's prior x [0.5, 1.5].
    topology : {"ring", "global"}
        Neighbourhood of the swarm: the paper's singly-linked ring, or global best.
    interpolation : bool
        Apply the paper's quadratic interpolation operator (eqs. 20-22).
    warm_start : bool
        Put one particle at the prior (default False, as the paper: random swarm).
    substeps : int
        RK4 steps per sample interval (1 is accurate to ~1e-5 relative here).
    stall_iterations : int or None
        Stop when the best cost has not improved for this many iterations.
    initial_state : {"smoothed", "kinematic"}
        Initial rates of the simulation: SG-smoothed measured rates (default; p over
        ``roll_window`` samples) or p0 from the measured roll angle
        (:class:`aeroid.estimation.OutputErrorCost`).
    roll_window : int
        Savitzky-Golay window for the initial roll rate [samples] (default 501).
    input : {"auto", "hold", "midpoint", "events", "law"}
        How the fin deflection between samples is modelled: ``auto`` (default) is
        ``law`` when the flight's airframe has a ``[fin_law]``, else ``hold``
        (:data:`aeroid.flights.INPUTS`).
    delay_s : float
        A known actuator delay [s] applied to that deflection (default 0).
    polish : bool
        Finish with a least-squares solve of the same output error from the swarm's best
        point, within the box (default False, the paper's method; see Notes).
    polish_initial_rates : bool
        With ``polish``: also fit the initial body rates p, q, r (default True; see Notes).
    air_data : {"inertial", "auto", "measured", "reconstruction"}
        The air the swarm's simulation flies in: still air (default inertial, the paper's:
        the flight's logged air data are said ignored), the wind the logged alpha, beta
        and airspeed imply when the flight has them (auto), those or a one-line refusal
        (measured), or the reconstruction's steady wind (reconstruction), as EBM-PSO's
        option of that name (:mod:`aeroid.estimation._eam_air`).
    air_data_window_s : float or None
        Smoothing of that wind, as EBM-PSO's: None (default) the Kalman smoother whose
        gust intensity the data choose, or a Savitzky-Golay window of that many seconds.

    Notes
    -----
    ``polish`` (:mod:`aeroid.estimation._polish`): trust-region reflective least squares
    (:func:`scipy.optimize.least_squares`) of the weighted output errors, the Jacobian
    by central differences of the batched model. ``info["polish"]`` holds the swarm's
    and the polished cost. The initial rates are the smoothed measured ones
    (``initial_state``); held there, the objective's optimum itself is off on a
    noise-free flight (Cl0, Clp 0.43 / 0.51 %, Cmq 0.20 %, measured from a 2.7e-3 rad/s
    error of the smoothed p0), so by default the polish fits them too, as nuisance
    parameters: noise-free within 0.015 % on every coefficient; on 8 seeded flights,
    mean |error| from 2.7 % to 1.1 % (Gaussian IMU) and 14.8 % to 4.7 % (paper noise).
    ``info["state0"]`` is then the fitted initial state and ``cost`` the output error
    from it. benchmarks/results/polish.md has the measurements.
    """

    name: ClassVar[str] = "eam-pso"
    supports_holds: ClassVar[bool] = True  # the search over the free ones: held_search
    uses_air_data: ClassVar[bool] = True  # option air_data (_eam_air.py)
    description: ClassVar[str] = ("output error (eq. 23): batched RK4 of the whole swarm, "
                                  "modified PSO (paper, 450 x 200)")

    n_particles: int = 450
    warm_start: bool = False
    substeps: int = 1
    stall_iterations: int | None = None
    initial_state: Literal["smoothed", "kinematic"] = "smoothed"
    roll_window: int = EAM_ROLL_WINDOW
    input: Literal["auto", "hold", "midpoint", "events", "law"] = "auto"
    delay_s: float = 0.0
    polish_initial_rates: bool = True
    air_data: Literal["inertial", "auto", "measured", "reconstruction"] = "inertial"
    air_data_window_s: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        check_swarm_size(self.n_particles)
        check_air_options(self)
        if self.roll_window < 1 or self.roll_window % 2 == 0:
            raise ValueError(f"roll_window must be a positive odd integer, got {self.roll_window}")
        if not 1 <= self.substeps <= MAX_SUBSTEPS:
            raise ValueError(f"substeps must be in [1, {MAX_SUBSTEPS}] (MAX_SUBSTEPS: more only "
                             f"cost time), got {self.substeps}")
        if self.stall_iterations is not None and self.stall_iterations < 1:
            raise ValueError(f"stall_iterations must be >= 1 or none, "
                             f"got {self.stall_iterations}")

    def run(self, flight: Flight, rng: np.random.Generator,
            holds: CoefficientSpec | None = None) -> EstimationResult:
        """Estimate the coefficients by output error (see class docstring).

        Raises
        ------
        EstimatorError
            When the swarm's simulated states would exceed :data:`MAX_SWARM_STATE_BYTES`.
        """
        need = self.n_particles * flight.n_samples * N_STATE * 8  # float64 states
        if need > MAX_SWARM_STATE_BYTES:
            raise EstimatorError(
                f"{self.name}: {self.n_particles} particles x {flight.n_samples} samples need "
                f"{need / 2**30:.1f} GiB of simulated states (limit "
                f"{MAX_SWARM_STATE_BYTES / 2**30:.0f} GiB): use fewer particles or a "
                "shorter window")
        bounds = prior_bounds(flight.airframe, self.box)
        air = step_one_air(self, flight)  # the wind of the logged air data, or still air
        cost = WindOutputErrorCost(flight, air.wind, weighting=self.weighting,
                               guard_fraction=self.guard_fraction, substeps=self.substeps,
                               initial_state=self.initial_state, roll_window=self.roll_window,
                               input=self.input, delay_s=self.delay_s)
        x0 = flight.airframe.prior_vector()[None, :] if self.warm_start else None
        res, warnings, polished = run_pso(self, cost, bounds, rng, n_particles=self.n_particles,
                                          holds=holds,
                                          x0=x0, stall_iterations=self.stall_iterations)
        state0 = cost.state0 if polished is None or polished.state0 is None else polished.state0
        info: dict[str, Any] = {
            "weighting": self.weighting, "n_particles": self.n_particles,
            "bounds": bounds, "t": flight.t, "outputs": ("ax1", "ay1", "az1", "p", "q", "r"),
            "measured": cost.measured, "predicted": cost.predict(res.x, state0)[0],
            "state0": state0, "initial_state": self.initial_state,
        }
        if polished is not None:
            info["polish"] = polish_info(polished)
        info["fit_residuals"] = {name: info["measured"][:, j] - info["predicted"][:, j]
                                 for j, name in enumerate(info["outputs"])}
        return with_step_one_air(EstimationResult(  # air_data's info, lines and refusal
            estimator=self.name, theta=res.x, cost=res.cost, success=res.success,
            message=res.message, warnings=warnings, n_evaluations=res.n_evaluations,
            n_iterations=res.n_iterations, history=pso_history(res), info=info),
            self, flight, air)
