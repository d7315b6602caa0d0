"""Transitional alias of the estimator interface's old single module (import nothing new here).

The interface now lives in one module per job: the result type
(:mod:`aeroid.estimation._result`), option parsing (``_options``), the
:class:`~aeroid.estimation.Estimator` class (``_estimator``) and the registry
(``_registry``). Import the names from :mod:`aeroid.estimation` instead; this module
only re-exports them so that code written against the old path keeps working, and goes
once nothing imports it.
"""

from aeroid.estimation._estimator import Estimator, prior_bounds
from aeroid.estimation._registry import (
    ENTRY_POINT_GROUP,
    available,
    get_estimator,
    load_errors,
    make_estimator,
    register,
)
from aeroid.estimation._result import EstimationResult, failed_result

__all__ = ["ENTRY_POINT_GROUP", "EstimationResult", "Estimator", "available", "failed_result",
           "get_estimator", "load_errors", "make_estimator", "prior_bounds", "register"]
