"""What a result's model says of a flight: :func:`predict`, :func:`coefficient_frame`,
and the JSON form of ``info`` (:func:`json_safe_info`).

The prediction is the output-error model of :mod:`aeroid.model` (RK4 over the record,
eq. 28 for the accelerometers, the rate gyros) at the result's coefficients, with the fit's
own view of the flight wherever the result records it:

* the deflection between samples: the fit's ``input`` option (``hold`` when the method
  has none) and actuator delay (the estimated ``info["delay_s"]``, else the ``delay_s``
  option, else none);
* the accelerometer positions: the estimated ``info["accel_positions_m"]``, else the
  airframe's;
* the air: the wind the fit used (a fitted steady wind, the air data's per-sample wind,
  the reconstruction's), else still air (:mod:`aeroid.estimation._predict_air`);
* RK4 steps per sample: the fit's ``substeps`` option, else :data:`PREDICT_SUBSTEPS`;
* the IMU's errors: a fit that estimated them (``info["imu_errors"]``: biases ``b`` and
  scale factors ``s`` + channel, output-error's and the EKF/UKF's ``imu_errors`` option)
  gets the sensor law ``reading = (1 + s) model + b`` on each channel it names, so the
  prediction is what the fit compared with the raw readings (:func:`sensor_law`);
* the initial state: ``info["initial_state"]`` (the fitted start, shape (9,)), else EAM's
  ``info["state0"]`` (the start its cost used); else (the filters, the equation-error
  and EBM methods, which fit no start) the first measured sample with p, q, r fitted to
  the data at the result's coefficients (:func:`fitted_start`: weighted least squares of
  every output, each channel weighted by its noise level from the data, from a quadratic
  Savitzky-Golay fit of the first :data:`START_WINDOW` samples). A start taken from the
  smoothed sample alone leaves the short-period oscillation of its error in q and r:
  10 times the residual of q and r on the paper-noise reference flight (measured, EKF).

What was used is recorded in the frame's ``attrs``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import pandas as pd

from aeroid.errors import EstimatorError
from aeroid.estimation._predict_air import prediction_air
from aeroid.estimation._signals import estimate_noise_sd, smooth, switch_free_samples
from aeroid.flights import IMU_ERROR_KINDS
from aeroid.model import NAMES, STATE_NAMES

if TYPE_CHECKING:
    from aeroid.flights import Flight
    from aeroid.model import ForwardModel


class FitResult(Protocol):
    """What this module reads of a fit: :class:`aeroid.estimation.EstimationResult` is one.

    Named here, not imported, so that this module does not import the one whose methods
    call it (``EstimationResult.predict``, ``to_frame`` and ``to_json_dict``).
    """

    @property
    def estimator(self) -> str: ...
    @property
    def input(self) -> str | None: ...
    @property
    def names(self) -> tuple[str, ...]: ...
    @property
    def theta(self) -> np.ndarray: ...
    @property
    def stderr(self) -> np.ndarray | None: ...
    @property
    def covariance(self) -> np.ndarray | None: ...
    @property
    def info(self) -> dict[str, Any]: ...

    def relative_error_pct(self, truth: np.ndarray) -> np.ndarray: ...


__all__ = ["JSON_ARRAY_LIMIT", "FitResult", "PREDICT_SUBSTEPS", "START_WINDOW", "coefficient_frame",
           "correlation", "fitted_start", "json_safe", "json_safe_info", "predict", "sensor_law",
           "start_state"]

#: RK4 steps per sample interval for a method that has no ``substeps`` option (the
#: equation-error and EBM methods): output-error's default; on the noise-free reference
#: flight its outputs differ from the simulator's (8 steps) by at most 5.1e-6 of a
#: channel's RMS (r; 8.2e-5 with 1 step), far below any sensor's noise.
PREDICT_SUBSTEPS = 2
#: Samples of the quadratic Savitzky-Golay fit that gives the initial rates (the 7-point
#: smoother of eq. 32, as output-error and the Cramér-Rao floor take them).
START_WINDOW = 7
#: Largest array kept in the JSON form of ``info`` [elements]: per-sample series
#: (states, measurements, forces) are left out and named in ``info["omitted"]``; the
#: 16 x 16 information matrix of output-error with its positions is kept.
JSON_ARRAY_LIMIT = 1024
#: Model evaluations of the start's least squares at most: the outputs are nearly linear
#: in the initial rates, and 3-6 evaluations converge on the reference flight (measured).
START_EVALUATIONS = 50
#: Floor of a channel's noise level in the start's weights, as a fraction of its RMS (the
#: fit check's resolution): on noise-free data every channel counts alike.
START_WEIGHT_FLOOR = 1e-3
#: The initial-state components :func:`fitted_start` fits.
RATE_NAMES = ("p", "q", "r")
#: Prefixes of the IMU-error names in ``info["imu_errors"]``: bias, scale factor.
SENSOR_PREFIXES = IMU_ERROR_KINDS["bias+scale"]


def sensor_law(result: FitResult, channels: tuple[str, ...]
               ) -> tuple[np.ndarray, np.ndarray, dict[str, float]]:
    """The fit's IMU errors as the sensor law's ``b`` and ``s`` per channel, shape (m,) each.

    ``info["imu_errors"]`` names each error ``b`` or ``s`` + channel (``bax1``, ``sr``); a
    channel it does not name has ``b = 0`` and ``s = 0``. Also returns the errors applied
    (``{}`` for a fit without them).

    Raises
    ------
    EstimatorError
        One line: a name that is not ``b`` or ``s`` + one of ``channels``, or a value that
        is not a finite number (nothing is dropped unsaid).
    """
    m = len(channels)
    bias, scale = np.zeros(m), np.zeros(m)
    given = result.info.get("imu_errors") or {}
    if not isinstance(given, dict):
        raise EstimatorError(f"{result.estimator}: info['imu_errors'] must map names to "
                             f"numbers, got {type(given).__name__}")
    applied: dict[str, float] = {}
    for name, value in given.items():
        prefix, channel = str(name)[:1], str(name)[1:]
        if prefix not in SENSOR_PREFIXES or channel not in channels:
            raise EstimatorError(
                f"{result.estimator}: info['imu_errors'] names {name!r}, not a bias (b) or "
                f"scale factor (s) of an output channel ({', '.join(channels)})")
        try:
            number = float(value)
        except (TypeError, ValueError):
            number = math.nan
        if not math.isfinite(number):
            raise EstimatorError(f"{result.estimator}: info['imu_errors'][{name!r}] must be "
                                 f"a finite number, got {value!r}")
        (bias if prefix == "b" else scale)[channels.index(channel)] = number
        applied[str(name)] = number
    return bias, scale, applied


def start_state(flight: Flight) -> np.ndarray:
    """The first measured state with p, q, r from a quadratic SG fit (shape (9,))."""
    states = flight.states()
    x0 = states[0].copy()
    window = min(START_WINDOW, states.shape[0] - 1 + states.shape[0] % 2)
    x0[3:6] = smooth(states[:, 3:6], window, min(2, window - 1))[0]
    return x0


def fitted_start(flight: Flight, theta: np.ndarray, model: ForwardModel, *,
                 bias: np.ndarray | None = None, scale: np.ndarray | None = None
                 ) -> np.ndarray:
    """The first measured state with p, q, r fitted to every output at ``theta``.

    Least squares (``scipy.optimize.least_squares``, Levenberg-Marquardt) of the outputs
    of ``model`` weighted by each channel's noise level from the data (the fit check's:
    the RMS of the 7-point smoother's residual away from relay switches, floored at
    :data:`START_WEIGHT_FLOOR` of the channel's RMS), from :func:`start_state`; that
    start when the fit does not lower the cost (a diverging trajectory). ``bias`` and
    ``scale`` (shape (m,), default 0): the sensor law ``(1 + scale) y + bias`` on the
    model's outputs (a fit's IMU errors, :func:`sensor_law`).
    """
    from scipy.optimize import least_squares

    x0 = start_state(flight)
    measured = flight._columns(model.output_names)
    rms = np.sqrt(np.mean(measured * measured, axis=0))
    levels = estimate_noise_sd(measured, statistic="rms",
                               use=switch_free_samples(flight["delta"]))
    sd = np.maximum(np.maximum(levels, START_WEIGHT_FLOOR * rms), np.finfo(float).tiny)
    theta = np.asarray(theta, dtype=float)
    m = len(model.output_names)
    bias = np.zeros(m) if bias is None else np.asarray(bias, dtype=float)
    gain = 1.0 + (np.zeros(m) if scale is None else np.asarray(scale, dtype=float))
    rates = list(RATE_NAMES)
    index = [STATE_NAMES.index(name) for name in rates]

    def state(x: np.ndarray) -> np.ndarray:
        out = x0.copy()
        out[index] = x
        return out

    def residuals(x: np.ndarray) -> np.ndarray:
        with np.errstate(all="ignore"):
            y = gain * model.outputs(state(x), theta)[0] + bias
        r = ((measured - y) / sd).ravel()
        return np.where(np.isfinite(r), r, 1e150)

    def jacobian(x: np.ndarray) -> np.ndarray:
        with np.errstate(all="ignore"):
            sens = model.sensitivities(state(x), theta, free_states=rates)[..., -len(rates):]
            weighted = sens / sd[None, :, None] * gain[None, :, None]
        return np.nan_to_num(-weighted.reshape(-1, len(rates)))

    try:
        found = least_squares(residuals, x0[index], jac=jacobian, method="lm",
                              x_scale="jac", max_nfev=START_EVALUATIONS)
    except (ValueError, np.linalg.LinAlgError):
        return x0
    start = state(found.x)
    return start if np.isfinite(found.cost) and found.cost <= 0.5 * np.sum(
        residuals(x0[index]) ** 2) else x0


def _options(result: FitResult) -> dict[str, Any]:
    options = result.info.get("options")
    return dict(options) if isinstance(options, dict) else {}


def _initial_state(result: FitResult, flight: Flight, model: ForwardModel,
                   bias: np.ndarray, scale: np.ndarray) -> tuple[np.ndarray, str]:
    for key in ("initial_state", "state0"):
        value = result.info.get(key)
        if value is not None and not isinstance(value, str):
            x0 = np.asarray(value, dtype=float).reshape(-1)
            if x0.size == len(STATE_NAMES):
                return x0, f"the fit's (info[{key!r}])"
    if not np.all(np.isfinite(result.theta)):
        return start_state(flight), f"first sample, rates from a {START_WINDOW}-point SG fit"
    return (fitted_start(flight, result.theta, model, bias=bias, scale=scale),
            "first sample, p q r fitted to the outputs at the estimate")


def predict(result: FitResult, flight: Flight, *, substeps: int | None = None,
            initial_state: np.ndarray | None = None, imu_errors: bool = True,
            air: str = "fit") -> pd.DataFrame:
    """Return the model's outputs at the flight's samples (module docstring).

    Parameters
    ----------
    result : FitResult
    flight : Flight
        The log the result was fitted to (or another one of the same airframe).
    substeps : int, optional
        RK4 steps per sample interval (default: the fit's, else :data:`PREDICT_SUBSTEPS`).
    initial_state : ndarray, shape (9,), optional
        The state at the first sample [m/s, rad/s, rad] (default: the fit's).
    imu_errors : bool
        Apply the fit's IMU errors, ``(1 + s) model + b`` (default; :func:`sensor_law`);
        ``False``: the model's own accelerations and rates.
    air : {"fit", "still"}
        The wind the fit used (default; :mod:`aeroid.estimation._predict_air`) or still air.

    Returns
    -------
    pandas.DataFrame
        Index ``t`` [s]; columns :data:`aeroid.model.OUTPUT_CHANNELS` (both triads'
        accelerations [m/s^2], then p, q, r [rad/s]); ``attrs``: ``input``, ``delay_s``,
        ``substeps``, ``accel_positions_m``, ``initial_state``, ``initial_state_from``,
        ``estimator``, ``imu_errors`` (the biases and scale factors applied, ``{}`` for
        none), ``imu_errors_note`` (one line saying what was done), ``air`` (``still``,
        ``steady``, ``measured``, ``reconstruction``), ``air_label`` and ``wind_ned_mps``
        (the wind per sample, n x 3 NED [m/s], as lists).
        NaN where the simulation diverged (or every value, for NaN coefficients).

    Raises
    ------
    EstimatorError
        For a result of coefficient tables in Mach (names other than the nine): the
        model here has constant coefficients.
    """
    if tuple(result.names) != NAMES:
        raise EstimatorError(f"{result.estimator}: predict integrates the nine constant "
                             f"coefficients; this result has {len(result.names)} parameters "
                             "(coefficient tables in Mach: aeroid.report.fitted_tables)")
    from aeroid.flights import flight_record, model_constants
    from aeroid.model import ForwardModel

    options = _options(result)
    input_mode = str(result.input or result.info.get("input", options.get("input", "hold")))
    delay = result.info.get("delay_s", options.get("delay_s", 0.0))
    delay = float(delay) if delay is not None and math.isfinite(float(delay)) else 0.0
    steps = int(substeps if substeps is not None else options.get("substeps",
                                                                  PREDICT_SUBSTEPS))
    positions = result.info.get("accel_positions_m")
    positions = (flight.airframe.accel_positions if positions is None
                 else np.asarray(positions, dtype=float).reshape(-1, 3))
    record = flight_record(flight, input_mode, delay)
    const = model_constants(flight)
    drawn = prediction_air(result, flight, air)  # the fit's wind: _predict_air.py
    const, record = drawn.apply(const, record)
    model = ForwardModel(const, record, positions, substeps=steps)
    bias, scale, applied = sensor_law(result, tuple(model.output_names))
    if not imu_errors:
        bias, scale = np.zeros_like(bias), np.zeros_like(scale)
    if initial_state is None:
        x0, source = _initial_state(result, flight, model, bias, scale)
    else:
        x0, source = np.asarray(initial_state, dtype=float).reshape(-1), "given"
    with np.errstate(all="ignore"):
        outputs = (1.0 + scale) * model.outputs(x0, result.theta)[0] + bias
    note = (f"IMU errors of the fit applied: reading = (1 + s) model + b "
            f"({len(applied)} values)" if applied and imu_errors else
            "IMU errors of the fit not applied: the model's own outputs" if applied else
            "no IMU errors in the fit: the model's own outputs")
    frame = pd.DataFrame(outputs, columns=list(model.output_names),
                         index=pd.Index(flight.t, name="t"))
    frame.attrs.update(input=input_mode, delay_s=delay, substeps=steps,
                       accel_positions_m=positions.tolist(), initial_state=x0.tolist(),
                       initial_state_from=source, estimator=result.estimator,
                       imu_errors=applied if imu_errors else {}, imu_errors_note=note,
                       air=drawn.source, air_label=drawn.label,
                       wind_ned_mps=drawn.series(flight.n_samples).tolist())
    return frame


def correlation(covariance: np.ndarray | None) -> np.ndarray | None:
    """The correlation matrix of a covariance (NaN where a variance is not positive)."""
    if covariance is None:
        return None
    cov = np.asarray(covariance, dtype=float)
    sd = np.sqrt(np.where(np.diag(cov) > 0, np.diag(cov), np.nan))
    with np.errstate(all="ignore"):
        return cov / np.outer(sd, sd)


def coefficient_frame(result: FitResult, flight: Flight | None = None,
                      *, floor: np.ndarray | None = None) -> pd.DataFrame:
    """Return one row per coefficient: estimate, stderr, and what else is known.

    Columns ``estimate``, ``stderr`` (NaN for a method without standard errors); with a
    flight, ``prior`` (the airframe's prior: the start and the PSO box's centre) and, for
    a simulated flight, ``truth`` and ``error_pct``; ``floor`` (the Cramér-Rao floor)
    when given (:func:`aeroid.estimation.data_floor` computes it from the data) or when
    the result carries ``info["floor"]``.
    """
    names = list(result.names)
    nan = np.full(len(names), np.nan)
    frame = pd.DataFrame({"estimate": result.theta,
                          "stderr": nan if result.stderr is None else result.stderr},
                         index=pd.Index(names, name="coefficient"))
    if flight is not None:
        frame["prior"] = flight.airframe.prior_vector()
    if floor is None and result.info.get("floor") is not None:
        floor = result.info["floor"]
    if floor is not None:
        frame["floor"] = np.asarray(floor, dtype=float).reshape(-1)
    truth = None if flight is None else flight.true_coefficients
    if truth is not None:
        frame["truth"] = truth
        frame["error_pct"] = result.relative_error_pct(truth)
    return frame


def json_safe(value: Any) -> Any:
    """Return ``value`` as JSON types: arrays -> lists, non-finite -> None, tuples -> lists."""
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        return json_safe(value.tolist())
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else None
    if value is None or isinstance(value, str):
        return value
    return str(value)


def _drop_series(value: Any, path: str, omitted: list[str]) -> Any:
    if isinstance(value, dict):
        return {k: v for k, v in ((k, _drop_series(v, f"{path}.{k}" if path else str(k),
                                                   omitted)) for k, v in value.items())
                if v is not _OMIT}
    if isinstance(value, np.ndarray) and value.size > JSON_ARRAY_LIMIT:
        omitted.append(f"{path} {tuple(value.shape)}")
        return _OMIT
    return value


_OMIT = object()


def json_safe_info(result: FitResult) -> dict[str, Any]:
    """Return ``result.info`` as JSON types, per-sample series left out and named.

    Arrays of more than :data:`JSON_ARRAY_LIMIT` elements (states, measurements,
    reconstructed forces) are replaced by their name and shape in ``omitted``; a method
    with a covariance and no ``correlation`` of its own gets its ``correlation`` here.
    """
    omitted: list[str] = []
    info = _drop_series(dict(result.info), "", omitted)
    if "correlation" not in info:
        corr = correlation(result.covariance)
        if corr is not None:
            info["correlation"] = corr
    if omitted:
        info["omitted"] = omitted
    return json_safe(info)
