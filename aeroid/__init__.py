"""aeroid: aerodynamic coefficient estimation for rolling airframes.

The data flow, one module per arrow: :class:`Airframe` + coefficients +
:class:`Manoeuvre` -> :func:`simulate` -> :class:`Flight` -> ``Estimator.fit`` ->
:class:`EstimationResult` -> study -> report.
"""

__version__ = "0.1.0"

from aeroid.airframe import (
    Airframe,
    AirframeError,
    load_airframe,
    reference_airframe,
    save_airframe,
)
from aeroid.coefficients import NAMES, NOMINAL, nominal
from aeroid.dynamics import (
    Constants,
    aero_forces_moments,
    air_data,
    constants,
    regressors,
    state_derivative,
)
from aeroid.errors import StudyError
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
from aeroid.fisher import cramer_rao_sd
from aeroid.flight import Flight, FlightError, make_flight, read_flight
from aeroid.integrate import propagate, rk4
from aeroid.pso import PSOResult, minimize
from aeroid.scenario import Manoeuvre, Scenario, load_scenario, reference_scenario
from aeroid.sensors import GaussianNoise, NoNoise, PaperNoise, accelerometers, make_noise
from aeroid.simulate import simulate, simulate_scenario

__all__ = [
    "Airframe",
    "AirframeError",
    "Constants",
    "EstimationResult",
    "Estimator",
    "EstimatorError",
    "Flight",
    "FlightError",
    "GaussianNoise",
    "Manoeuvre",
    "NAMES",
    "NOMINAL",
    "NoNoise",
    "PSOResult",
    "PaperNoise",
    "Scenario",
    "StudyError",
    "accelerometers",
    "aero_forces_moments",
    "air_data",
    "available",
    "constants",
    "cramer_rao_sd",
    "failed_result",
    "get_estimator",
    "load_airframe",
    "load_scenario",
    "make_estimator",
    "make_flight",
    "make_noise",
    "minimize",
    "nominal",
    "prior_bounds",
    "propagate",
    "read_flight",
    "reference_airframe",
    "reference_scenario",
    "register",
    "regressors",
    "rk4",
    "save_airframe",
    "simulate",
    "simulate_scenario",
    "state_derivative",
]
