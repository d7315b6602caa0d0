"""aeroid: aerodynamic coefficient estimation for rolling airframes.

The data flow, one layer per folder: :class:`Airframe` + coefficients +
:class:`Manoeuvre` -> :func:`simulate` -> :class:`Flight` -> ``Estimator.fit`` ->
:class:`EstimationResult` -> study -> report.

This package holds the user-level names. The tiers below it:

* :mod:`aeroid.model` (kernel level): the equations written once, the batched RK4, the
  forward model, the model's inputs in time, CasADi evaluation;
* :mod:`aeroid.flights`: flights, their files and checks, noise models, scenarios, the
  simulator;
* :mod:`aeroid.estimation` (plug-in level): the Estimator interface and registry,
  objectives, reconstruction, the PSO, the fit check, the Cramér-Rao floor;
* :mod:`aeroid.study`: study files, the runner and its store, reports;
* :mod:`aeroid.errors`: the error types.

Modules with a leading underscore are implementation; their names may change.
"""

__version__ = "0.1.0"

from aeroid.errors import AirframeError, EstimatorError, FlightError, StudyError
from aeroid.estimation import (
    EstimationResult,
    Estimator,
    PSOResult,
    available,
    cramer_rao_sd,
    failed_result,
    get_estimator,
    make_estimator,
    minimize,
    prior_bounds,
    register,
)
from aeroid.flights import (
    Flight,
    GaussianNoise,
    Manoeuvre,
    NoNoise,
    PaperNoise,
    Scenario,
    load_scenario,
    make_flight,
    make_noise,
    read_flight,
    reference_scenario,
    simulate,
    simulate_scenario,
)
from aeroid.model import (
    NAMES,
    NOMINAL,
    Airframe,
    FinLaw,
    load_airframe,
    nominal,
    reference_airframe,
    save_airframe,
)
from aeroid.study import load_study, run_study

__all__ = [
    "Airframe",
    "FinLaw",
    "AirframeError",
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
    "available",
    "cramer_rao_sd",
    "failed_result",
    "get_estimator",
    "load_airframe",
    "load_scenario",
    "load_study",
    "make_estimator",
    "make_flight",
    "make_noise",
    "minimize",
    "nominal",
    "prior_bounds",
    "read_flight",
    "reference_airframe",
    "reference_scenario",
    "register",
    "run_study",
    "save_airframe",
    "simulate",
    "simulate_scenario",
]
