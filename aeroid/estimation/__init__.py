"""Estimation: the Estimator interface and registry, objectives, reconstruction, PSO, floor.

This is the plug-in tier: a third-party estimator subclasses :class:`Estimator` and may
use the objectives, the EBM reconstruction, the PSO and its :func:`polish`,
:func:`report_progress` and :func:`box_edge_warnings` defined here.

Modules, one job each (imports point down the list, never up): ``_result`` (the result
type), ``_holds`` (held, free and prior coefficients), ``_predict`` (what a result's
model says of a flight, its table and JSON info),
``_options`` (option values from text, option descriptions), ``_progress``
(progress reports of a running fit), ``_estimator`` (the interface), ``_registry``
(names -> classes, entry points), ``_pso_kernels`` and ``_pso`` (the paper's optimiser),
``_reconstruct``, ``_regression`` (its regressors in time blocks), ``_objectives``,
``_floor``, ``_gyro_floor`` (what the p gyro alone tells of Cl0, Clp), ``_whiteness``
and ``_identifiability`` (what the fit check tests beyond the residuals' size),
``_consider`` (an uncertain mass's share of the covariance, by re-fits),
``_polish`` (from a swarm's best point to the optimum of its objective),
``_pso_methods`` (what the paper's methods share; ``_pso_air`` their air data,
``_air_refusal`` the turbulence refusal they share with equation-error), and the
methods ``_eam``, ``_ebm``,
``_sebm``, which import none of one another. ``_windows``: what :meth:`Estimator.fit`
does with several windows (:class:`aeroid.flights.Windows`).
``_benchmark_functions`` holds the optimiser test functions (tests and benchmarks).
"""

from aeroid.estimation._air_data import (
    AIR_DATA_CHOICES,
    WIND_WINDOW_S,
    AirData,
    air_data_wind,
    has_air_angles,
    has_air_data,
    has_airspeed,
    ignored_air_data_warning,
    resolve_air_data,
)
from aeroid.estimation._air_reconstruction import reconstruction_wind
from aeroid.estimation._air_refusal import refuse_unseen_gusts
from aeroid.estimation._air_smoother import SMOOTHER_MODELS, SmoothedWind, smooth_air_wind
from aeroid.estimation._air_verdict import (
    AirVerdict,
    air_data_verdict,
    verdict_of,
    with_air_verdict,
)
from aeroid.estimation._consider import (
    ConsiderCovariance,
    add_consider,
    consider_covariance,
    exact_mass_note,
)
from aeroid.estimation._estimator import Estimator, prior_bounds
from aeroid.estimation._fitcheck import data_floor, data_noise_levels
from aeroid.estimation._floor import (
    coefficient_information,
    cramer_rao_sd,
    information_from_sensitivities,
    inputs_from_flight,
    model_noise_sd,
    model_outputs,
    output_sensitivities,
)
from aeroid.estimation._gyro_floor import GYRO_FLOOR_NAMES, gyro_only_floor
from aeroid.estimation._holds import FIN_TERMS, CoefficientSpec, airframe_holds
from aeroid.estimation._holds_fit import (
    apply_holds,
    combine_with_prior,
    floor_with_holds,
    free_cost,
    holds_of,
)
from aeroid.estimation._identifiability import (
    RecordFinding,
    identifiability,
    nuisance_findings,
    record_findings,
    record_verdict,
)
from aeroid.estimation._objectives import (
    EAM_OUTPUTS,
    EBM_ROWS,
    SEBM_PROBLEMS,
    OutputErrorCost,
    QuadraticCost,
    SebmProblem,
    channel_weights,
    ebm_cost,
    sebm_costs,
)
from aeroid.estimation._options import NOT_AN_OPTION, OptionInfo
from aeroid.estimation._polish import Polished, polish, polish_info
from aeroid.estimation._predict import (
    coefficient_frame,
    correlation,
    fitted_start,
    json_safe,
    json_safe_info,
    predict,
)
from aeroid.estimation._progress import ProgressEvent, report_progress
from aeroid.estimation._pso import PSOResult, minimize
from aeroid.estimation._pso_methods import MAX_ITERATIONS, MAX_PARTICLES
from aeroid.estimation._reconstruct import (
    SMOOTHING_CHOICES,
    Reconstruction,
    accel_only_matrix,
    ebm_regression,
    reconstruct,
    regression_fit,
)
from aeroid.estimation._registry import (
    ENTRY_POINT_GROUP,
    available,
    get_estimator,
    load_errors,
    make_estimator,
    register,
)
from aeroid.estimation._regression import REGRESSION_BLOCK, regression_target, regressor_blocks
from aeroid.estimation._result import (
    EDGE_FRACTION,
    EstimationResult,
    box_edge_warnings,
    failed_result,
)
from aeroid.estimation._signals import (
    ROLL_DERIVATIVE_WINDOW,
    ROLL_POLYORDER,
    difference_noise_sd,
    estimate_noise_law,
    estimate_noise_sd,
    fit_noise_law,
    rate_derivatives,
    roll_window_samples,
    smooth,
    switch_free_samples,
    switch_free_windows,
)
from aeroid.estimation._still_air import LogAir, log_air
from aeroid.estimation._table_holds import (
    TableHolds,
    fit_tables,
    table_holds,
    windows_table_spec,
)
from aeroid.estimation._whiteness import WhitenessTest, autocorrelation_test, switch_test

# The paper's methods register themselves on import (after the registry exists).
from aeroid.estimation import _eam, _ebm, _sebm  # noqa: E402, F401, I001  isort: skip

__all__ = [
    "AIR_DATA_CHOICES",
    "WIND_WINDOW_S",
    "AirData",
    "air_data_wind",
    "AirVerdict",
    "air_data_verdict",
    "verdict_of",
    "with_air_verdict",
    "refuse_unseen_gusts",
    "SmoothedWind",
    "smooth_air_wind",
    "SMOOTHER_MODELS",
    "ROLL_DERIVATIVE_WINDOW",
    "roll_window_samples",
    "ROLL_POLYORDER",
    "has_air_angles",
    "has_air_data",
    "has_airspeed",
    "reconstruction_wind",
    "ignored_air_data_warning",
    "resolve_air_data",
    "CoefficientSpec",
    "TableHolds",
    "FIN_TERMS",
    "airframe_holds",
    "apply_holds",
    "combine_with_prior",
    "floor_with_holds",
    "free_cost",
    "holds_of",
    "ConsiderCovariance",
    "add_consider",
    "consider_covariance",
    "exact_mass_note",
    "table_holds",
    "fit_tables",
    "windows_table_spec",
    "estimate_noise_law",
    "fit_noise_law",
    "EAM_OUTPUTS",
    "EBM_ROWS",
    "EDGE_FRACTION",
    "ENTRY_POINT_GROUP",
    "GYRO_FLOOR_NAMES",
    "EstimationResult",
    "Estimator",
    "MAX_ITERATIONS",
    "MAX_PARTICLES",
    "NOT_AN_OPTION",
    "OptionInfo",
    "OutputErrorCost",
    "PSOResult",
    "Polished",
    "ProgressEvent",
    "QuadraticCost",
    "Reconstruction",
    "SEBM_PROBLEMS",
    "SebmProblem",
    "REGRESSION_BLOCK",
    "SMOOTHING_CHOICES",
    "accel_only_matrix",
    "available",
    "box_edge_warnings",
    "channel_weights",
    "coefficient_frame",
    "correlation",
    "fitted_start",
    "json_safe",
    "json_safe_info",
    "predict",
    "cramer_rao_sd",
    "coefficient_information",
    "information_from_sensitivities",
    "inputs_from_flight",
    "model_noise_sd",
    "model_outputs",
    "output_sensitivities",
    "data_floor",
    "data_noise_levels",
    "ebm_cost",
    "ebm_regression",
    "difference_noise_sd",
    "estimate_noise_sd",
    "failed_result",
    "get_estimator",
    "identifiability",
    "RecordFinding",
    "record_findings",
    "record_verdict",
    "nuisance_findings",
    "gyro_only_floor",
    "load_errors",
    "make_estimator",
    "minimize",
    "polish",
    "polish_info",
    "prior_bounds",
    "rate_derivatives",
    "reconstruct",
    "register",
    "regression_fit",
    "regression_target",
    "regressor_blocks",
    "report_progress",
    "sebm_costs",
    "smooth",
    "switch_free_samples",
    "switch_free_windows",
    "switch_test",
    "autocorrelation_test",
    "WhitenessTest",
    "LogAir",
    "log_air",
]
