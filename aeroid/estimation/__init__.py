"""Estimation: the Estimator interface and registry, objectives, reconstruction, PSO, floor.

This is the plug-in tier: a third-party estimator subclasses :class:`Estimator` and may
use the objectives, the EBM reconstruction and the PSO defined here.
"""

from aeroid.estimation._floor import cramer_rao_sd
from aeroid.estimation._interface import (
    ENTRY_POINT_GROUP,
    EstimationResult,
    Estimator,
    available,
    failed_result,
    get_estimator,
    load_errors,
    make_estimator,
    prior_bounds,
    register,
)
from aeroid.estimation._objectives import (
    EBM_ROWS,
    SEBM_PROBLEMS,
    OutputErrorCost,
    QuadraticCost,
    channel_weights,
    ebm_cost,
    sebm_costs,
)
from aeroid.estimation._pso import PSOResult, minimize
from aeroid.estimation._reconstruct import (
    SMOOTHING_CHOICES,
    Reconstruction,
    accel_only_matrix,
    ebm_regression,
    reconstruct,
)
from aeroid.estimation._signals import (
    estimate_noise_sd,
    rate_derivatives,
    smooth,
    switch_free_samples,
)

__all__ = [
    "EBM_ROWS",
    "ENTRY_POINT_GROUP",
    "EstimationResult",
    "Estimator",
    "OutputErrorCost",
    "PSOResult",
    "QuadraticCost",
    "Reconstruction",
    "SEBM_PROBLEMS",
    "SMOOTHING_CHOICES",
    "accel_only_matrix",
    "available",
    "channel_weights",
    "cramer_rao_sd",
    "ebm_cost",
    "ebm_regression",
    "estimate_noise_sd",
    "failed_result",
    "get_estimator",
    "load_errors",
    "make_estimator",
    "minimize",
    "prior_bounds",
    "rate_derivatives",
    "reconstruct",
    "register",
    "sebm_costs",
    "smooth",
    "switch_free_samples",
]
