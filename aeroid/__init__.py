"""aeroid: aerodynamic coefficient estimation for rolling airframes.

The data flow, one layer per folder: :class:`Airframe` + coefficients +
:class:`Manoeuvre` -> :func:`simulate` -> :class:`Flight` -> ``Estimator.fit`` ->
:class:`EstimationResult` -> study -> report.

This package holds the user-level names. The layers below it, each importing only the
ones under it (``[tool.importlinter]`` in ``pyproject.toml``, checked by
``tests/contract/test_layers.py``):

* :mod:`aeroid.cli`: ``aeroid simulate | estimate | methods | study``;
* :mod:`aeroid.study` (study files, the runner and its store, reports) and
  :mod:`aeroid.report` (one fit's report, methods side by side), which do not import
  each other;
* :mod:`aeroid.estimation` (plug-in level): the Estimator interface and registry,
  objectives, reconstruction from the outputs, the PSO, the fit check, the Cramér-Rao
  floor;
* :mod:`aeroid.reconstruction`: a sensor-suite log to states and a flight;
* :mod:`aeroid.flights`: flights, their files and checks, noise models, scenarios, the
  simulator;
* :mod:`aeroid.model` (kernel level): the equations written once, the batched RK4, the
  forward model, the model's inputs in time, CasADi evaluation;
* :mod:`aeroid.errors`: the error types.

The ``baselines`` plug-ins use these public faces; aeroid never imports them (they
register through the ``aeroid.estimators`` entry-point group).

Modules with a leading underscore are implementation, imported only from inside their
package; their names may change.
"""

from aeroid._version import __version__ as __version__
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
