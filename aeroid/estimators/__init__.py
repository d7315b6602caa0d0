"""Estimators: the common interface, the registry and the paper's three methods."""

from aeroid.estimators.base import (
    EstimationResult,
    Estimator,
    EstimatorError,
    available,
    failed_result,
    get_estimator,
    make_estimator,
    prior_bounds,
    register,
)

__all__ = [
    "EstimationResult",
    "Estimator",
    "EstimatorError",
    "available",
    "failed_result",
    "get_estimator",
    "make_estimator",
    "prior_bounds",
    "register",
]
