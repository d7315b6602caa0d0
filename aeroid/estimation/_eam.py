"""EAM-PSO: output-error estimation with the paper's modified PSO (section 3.1, eq. 23).

Every particle's coefficients are simulated over the whole record (batched RK4 over the
swarm, :func:`aeroid.model.propagate`) and the predicted triad-1 accelerations and
rates are compared with the measured ones (:class:`aeroid.estimation.OutputErrorCost`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np

from aeroid.estimation import _pso as pso
from aeroid.estimation._interface import EstimationResult, Estimator, prior_bounds, register
from aeroid.estimation._objectives import (
    EAM_ROLL_WINDOW,
    GUARD_FRACTION,
    WEIGHTINGS,
    OutputErrorCost,
)
from aeroid.flights._flight import Flight

__all__ = ["EAMPSO", "check_common_options", "pso_history"]


def check_common_options(est: Any) -> None:
    """Raise ValueError (one line) on bad PSO/cost options shared by the paper's methods."""
    if est.weighting not in WEIGHTINGS:
        raise ValueError(f"weighting must be one of {', '.join(WEIGHTINGS)}")
    if est.topology not in ("ring", "global"):
        raise ValueError("topology must be 'ring' or 'global'")
    if not (0.0 <= est.guard_fraction < 1.0):
        raise ValueError(f"guard_fraction must be in [0, 1), got {est.guard_fraction}")
    if est.n_iterations < 0:
        raise ValueError(f"n_iterations must be >= 0, got {est.n_iterations}")
    if est.box is not None and len(est.box) != 18:
        raise ValueError(f"box needs 18 numbers [low0, high0, ..., low8, high8], "
                         f"got {len(est.box)}")


def pso_history(res: pso.PSOResult) -> dict[str, Any]:
    """Return the result history (axis 'iteration') of one PSO run over all nine coefficients."""
    return {"axis": "iteration", "step": np.arange(res.history_cost.size),
            "cost": np.asarray(res.history_cost, dtype=float),
            "theta": np.asarray(res.history_x, dtype=float)}


@register
@dataclass(frozen=True, kw_only=True)
class EAMPSO(Estimator):
    """Output-error method with the paper's modified PSO (EAM-PSO).

    Options
    -------
    n_particles, n_iterations : int
        Swarm size and iterations (paper: 450 x 200; section 4.1 says 100, Table 5 200).
    weighting : {"noise", "relative"}
        Cost weighting (:mod:`aeroid.estimation`): "noise" (default, maximum likelihood)
        or "relative" (eq. 23 with the guard).
    guard_fraction : float
        Guard of the relative weighting.
    box : 18 numbers or None
        Search box ``[low0, high0, ...]``; default the airframe's prior x [0.5, 1.5].
    topology : {"ring", "global"}
    interpolation : bool
        The quadratic interpolation operator (eqs. 20-22).
    warm_start : bool
        Put one particle at the prior (default False, as the paper: random swarm).
    substeps : int
        RK4 steps per 2 ms sample interval (1 is accurate to ~1e-5 relative here).
    stall_iterations : int or None
        Stop when the best cost has not improved for this many iterations.
    initial_state : {"smoothed", "kinematic"}
        Initial rates of the simulation: SG-smoothed measured rates (default, notes
        "EAM"; p over ``roll_window`` samples) or p0 from the measured roll angle
        (:class:`aeroid.estimation.OutputErrorCost`).
    roll_window : int
        SG window for the initial roll rate [samples] (default 501).
    """

    name: ClassVar[str] = "eam-pso"
    description: ClassVar[str] = ("output error (eq. 23): batched RK4 of the whole swarm, "
                                  "modified PSO (paper, 450 x 200)")

    n_particles: int = 450
    n_iterations: int = 200
    weighting: Literal["noise", "relative"] = "noise"
    guard_fraction: float = GUARD_FRACTION
    box: tuple[float, ...] | None = None
    topology: Literal["ring", "global"] = "ring"
    interpolation: bool = True
    warm_start: bool = False
    substeps: int = 1
    stall_iterations: int | None = None
    initial_state: Literal["smoothed", "kinematic"] = "smoothed"
    roll_window: int = EAM_ROLL_WINDOW

    def __post_init__(self) -> None:
        check_common_options(self)
        if self.n_particles < 3:
            raise ValueError(f"n_particles must be >= 3, got {self.n_particles}")
        if self.roll_window < 1 or self.roll_window % 2 == 0:
            raise ValueError(f"roll_window must be a positive odd integer, got {self.roll_window}")
        if self.substeps < 1:
            raise ValueError(f"substeps must be >= 1, got {self.substeps}")

    def run(self, flight: Flight, rng: np.random.Generator) -> EstimationResult:
        """Estimate the nine coefficients by output error (see class docstring)."""
        bounds = prior_bounds(flight.airframe, self.box)
        cost = OutputErrorCost(flight, weighting=self.weighting,
                               guard_fraction=self.guard_fraction, substeps=self.substeps,
                               initial_state=self.initial_state, roll_window=self.roll_window)
        x0 = flight.airframe.prior_vector()[None, :] if self.warm_start else None
        res = pso.minimize(cost, bounds, n_particles=self.n_particles,
                           n_iterations=self.n_iterations, rng=rng, topology=self.topology,
                           interpolation=self.interpolation, x0=x0,
                           stall_iterations=self.stall_iterations)
        info: dict[str, Any] = {
            "weighting": self.weighting, "n_particles": self.n_particles,
            "bounds": bounds, "t": flight.t, "outputs": ("ax1", "ay1", "az1", "p", "q", "r"),
            "measured": cost.measured, "predicted": cost.predict(res.x)[0],
            "state0": cost.state0, "initial_state": self.initial_state,
        }
        return EstimationResult(
            estimator=self.name, theta=res.x, cost=res.cost, success=res.success,
            message=res.message, n_evaluations=res.n_evaluations,
            n_iterations=res.n_iterations, history=pso_history(res), info=info)
