"""The Cramér-Rao floor of the output-error problem: no unbiased estimator beats it.

Model (the output-error problem of EAM, section 3.1, with both triads): the state is
integrated from the true state at the window start with the recorded fin deflection
held over each sample interval (:func:`aeroid.model.propagate`); the outputs at
every sample ``t_k`` are the six accelerometer readings (eq. 28, both triads, with the
recorded ``delta_k``) and the body rates p, q, r::

    y_k(theta) = [ax1, ay1, az1, ax2, ay2, az2, p, q, r]_k,     k = 0..n-1.

With independent zero-mean measurement errors of standard deviation ``sd_kc`` (sample
k, channel c), the Fisher information of the nine coefficients is::

    F = sum_k sum_c  J_kc^T J_kc / sd_kc^2,      J_kc = d y_kc / d theta   (1 x 9),

and the Cramér-Rao standard deviations are ``sqrt(diag(F^-1))``.

Decisions (the notes leave these open):

* Sensitivities ``J``: central differences, relative step 1e-5 (:mod:`aeroid.model._sensitivity`).
* The model integrates with ``substeps = 8`` RK4 steps per sample (0.25 ms, the truth's
  step), so with the true coefficients the model outputs equal the simulated clean flight.
* Paper noise (eq. 43) is multiplicative uniform: ``s_m = s (1 + xi (2U - 1))`` has
  standard deviation ``|s| xi / sqrt(3)``. Default (``noise_form="heteroscedastic"``):
  that per-sample value, with ``s`` the noise-free model output. Alternative
  (``noise_form="homoscedastic"``): one value per channel, ``xi RMS(s) / sqrt(3)``.
  Samples whose heteroscedastic standard deviation is exactly zero (a zero signal is
  measured exactly under eq. 43) carry no usable Gaussian-equivalent weight and are left
  out (they do not occur in a rolling flight). Gaussian noise: the constant per-channel
  standard deviation.
* Uniform noise has a support that depends on the parameters, so its exact Fisher
  information is not finite (the regularity conditions of the Cramér-Rao theorem fail).
  What this module returns for paper noise is the bound for Gaussian errors of the same
  variance, which is also the asymptotic covariance of the (weighted) least-squares
  output-error estimator: the floor the study compares least-squares-type estimators with.
* The estimator's position error (``accel_position_xi``) is not a measurement noise: the
  floor uses the true positions (``positions="true"``), or the estimator's perturbed
  copy (``positions="estimator"``) when asked; either way the positions are taken as known.
* The initial state is known by default (the brief: "the true state at the window
  start"); ``estimate_initial`` names components estimated jointly as nuisance parameters
  (an output-error fit that starts from measured, noisy rates has to).

Comparison with the reference README (percent of nominal, reference scenario, paper
noise, true positions; measured with this module)::

                                      Cx    Cza   Czd   Czq   Cl0   Clp   Cma   Cmd   Cmq
    README (independent prototype)   0.02  0.11  0.34  6.0   11.5  14.4  0.07  0.13  0.86
    default (heteroscedastic, both)  0.012 0.054 0.106 0.44  0.54  0.69  0.003 0.009 0.070
    homoscedastic, both, x0 known    0.012 0.104 0.308 5.88  6.06  7.63  0.052 0.115 0.579
    PROTOTYPE_FLOOR                  0.017 0.112 0.343 5.96  11.5  14.4  0.073 0.132 0.862

The README's figures are reproduced (to their rounding) by :data:`PROTOTYPE_FLOOR`:
homoscedastic ``xi RMS / sqrt(3)``, triad 1 and the rates, initial p, q, r estimated.
The heteroscedastic default is 10-20x lower on Czq, Cl0, Clp, Cma: under eq. 43 a
signal crossing zero (q, r, the lateral accelerations) is measured almost exactly there,
and those samples pin the roll phase. That is what eq. 43 implies, but not what a real
sensor does; studies must say which floor they draw. The heteroscedastic floor also
depends on where the zero crossings fall between samples: linearised about the paper-
noise flight's (noisy) first state instead, it gives Czq 0.30 % and Cmd 0.005 % (the
homoscedastic floor moves by < 10 %). A Monte Carlo check (tests/unit/test_fisher.py,
slow) finds the spread of a weighted least-squares fit with weights ``1 / sd^2`` from the
true outputs at 0.90-1.05 times both floors; an estimator weighting by the measured
values cannot exploit the exact zero crossings in the same way.
"""

from __future__ import annotations

import warnings
from typing import NamedTuple

import numpy as np
import pandas as pd

from aeroid.errors import AeroidError, AeroidWarning, EstimatorError
from aeroid.estimation._holds_fit import CoefficientSpec, floor_with_holds
from aeroid.estimation._information import (
    CHANNEL_SETS,
    channel_indices,
    check_sd,
    coefficient_information,
    fisher_information,
    information_from_sensitivities,
    model_noise_sd,
)
from aeroid.flights import (
    Flight,
    NoiseModel,
    NoNoise,
    Scenario,
    check_input,
    flight_record,
    simulate,
)
from aeroid.model import (
    DEFAULT_REL_STEP,
    N_STATE,
    NAMES,
    OUTPUT_CHANNELS,
    Airframe,
    ForwardModel,
    Record,
    as_vector,
    constants,
)

__all__ = [  # the information and its weights live in _information, written once
    "CHANNEL_SETS", "DEFAULT_SUBSTEPS", "PROTOTYPE_FLOOR", "OutputErrorInputs",
    "coefficient_information", "cramer_rao_sd", "information_from_sensitivities",
    "inputs_from_flight", "model_noise_sd", "model_outputs", "output_error_information",
    "output_sensitivities",
]
#: Options of :func:`cramer_rao_sd` that reproduce the reference README's floor (an
#: independent prototype): one standard deviation per channel, triad 1 and the rates
#: only, initial rates estimated. Not the default (see the module docstring).
PROTOTYPE_FLOOR: dict[str, object] = {
    "noise_form": "homoscedastic", "channels": "triad1", "estimate_initial": ("p", "q", "r"),
}
#: RK4 steps per sample interval of the model (0.25 ms at 500 Hz: the truth's step).
DEFAULT_SUBSTEPS = 8


class OutputErrorInputs(NamedTuple):
    """What the output-error model needs besides the coefficients.

    Attributes
    ----------
    state0 : ndarray, shape (9,)
        State at the first sample [m/s, rad/s, rad].
    delta : ndarray, shape (n,)
        Recorded fin deflection at every sample [rad], held over ``[t_k, t_k + dt)``.
    dt : float
        Sample interval [s].
    record : Record or None
        The inputs in time (deflection between samples, per-sample quantities); None:
        ``delta`` held over each interval, the airframe's constants.
    """

    state0: np.ndarray
    delta: np.ndarray
    dt: float
    record: Record | None = None


def inputs_from_flight(flight: Flight, input: str = "auto") -> OutputErrorInputs:  # noqa: A002
    """Return the model inputs of ``flight``: its first state, the deflection and dt.

    ``input`` is how the deflection between samples is modelled
    (:data:`aeroid.flights.INPUTS`; ``auto``: the fin law when the airframe has one, else
    the held log, as the estimators); per-sample channels of the flight are used. For a
    noisy flight the first sample's measured p, q, r are used as they are; for the floor
    pass the noise-free flight (``cramer_rao_sd`` does).
    """
    record = flight_record(flight, input)
    return OutputErrorInputs(flight.states()[0], record.delta, flight.dt, record)


def _as_inputs(flight_or_inputs: Flight | OutputErrorInputs) -> OutputErrorInputs:
    if isinstance(flight_or_inputs, Flight):
        return inputs_from_flight(flight_or_inputs)
    if isinstance(flight_or_inputs, OutputErrorInputs):
        state0 = np.asarray(flight_or_inputs.state0, dtype=float)
        delta = np.asarray(flight_or_inputs.delta, dtype=float).reshape(-1)
        if state0.shape != (N_STATE,) or delta.size < 2:
            raise ValueError(f"fisher: inputs need state0 of shape ({N_STATE},) and at least "
                             "2 samples")
        return OutputErrorInputs(state0, delta, float(flight_or_inputs.dt),
                                 flight_or_inputs.record)
    raise TypeError(
        f"fisher: expected a Flight or OutputErrorInputs, got {type(flight_or_inputs).__name__}"
    )


def _positions(airframe: Airframe, positions: np.ndarray | None) -> np.ndarray:
    pos = airframe.accel_positions if positions is None else np.asarray(positions, dtype=float)
    if pos.shape != (2, 3) or not np.all(np.isfinite(pos)):
        raise ValueError(f"fisher: positions must be 2 x 3 finite values [m], got {pos.shape}")
    return pos


def _forward_model(airframe: Airframe, inputs: OutputErrorInputs, positions: np.ndarray | None,
                   substeps: int) -> ForwardModel:
    record = inputs.record or Record.held(inputs.delta, inputs.dt)
    return ForwardModel(constants(airframe), record, _positions(airframe, positions),
                        substeps=substeps)


def model_outputs(
    airframe: Airframe,
    coefficients: np.ndarray,
    flight_or_inputs: Flight | OutputErrorInputs,
    *,
    positions: np.ndarray | None = None,
    substeps: int = DEFAULT_SUBSTEPS,
) -> np.ndarray:
    """Return the output-error model's outputs for one or many coefficient sets.

    Parameters
    ----------
    airframe : Airframe
        Mass properties, geometry and (unless ``positions`` is given) triad positions.
    coefficients : array_like, shape (9,) or (n_sets, 9)
    flight_or_inputs : Flight or OutputErrorInputs
        Initial state, recorded delta and sample interval.
    positions : ndarray, shape (2, 3), optional
        Triad positions from the c.g. [m]; default ``airframe.accel_positions``.
    substeps : int
        RK4 steps per sample interval.

    Returns
    -------
    ndarray, shape (n, 9) or (n_sets, n, 9)
        Columns :data:`OUTPUT_CHANNELS` [m/s^2, rad/s].
    """
    inputs = _as_inputs(flight_or_inputs)
    theta = np.asarray(coefficients, dtype=float)
    single = theta.ndim == 1
    model = _forward_model(airframe, inputs, positions, substeps)
    out = model.outputs(inputs.state0, as_vector(np.atleast_2d(theta)))
    return out[0] if single else out


def output_sensitivities(
    airframe: Airframe,
    coefficients: np.ndarray,
    flight_or_inputs: Flight | OutputErrorInputs,
    *,
    positions: np.ndarray | None = None,
    estimate_initial: tuple[str, ...] = (),
    rel_step: float = DEFAULT_REL_STEP,
    substeps: int = DEFAULT_SUBSTEPS,
) -> np.ndarray:
    """Return ``d y_kc / d (theta, x0)`` by central differences, shape (n, 9, 9 + m).

    Axes: sample k, output channel c (:data:`OUTPUT_CHANNELS`), parameter: the nine
    coefficients, then the ``m`` initial-state components named in ``estimate_initial``
    (:data:`aeroid.model.STATE_NAMES`, e.g. ``("p", "q", "r")``). The step of
    coefficient j is ``rel_step * |theta_j|`` (``rel_step`` when theta_j = 0), that of
    state component i ``rel_step * max(|x0_i|, 1)``; all perturbed trajectories are
    integrated in one batched call.
    """
    inputs = _as_inputs(flight_or_inputs)
    model = _forward_model(airframe, inputs, positions, substeps)
    return model.sensitivities(inputs.state0, coefficients, free_states=estimate_initial,
                               rel_step=rel_step)


def output_error_information(
    airframe: Airframe,
    coefficients: np.ndarray,
    flight_or_inputs: Flight | OutputErrorInputs,
    noise_sd: np.ndarray | float,
    *,
    positions: np.ndarray | None = None,
    channels: str = "both",
    estimate_initial: tuple[str, ...] = (),
    rel_step: float = DEFAULT_REL_STEP,
    substeps: int = DEFAULT_SUBSTEPS,
) -> np.ndarray:
    """Return the Fisher information of the nine coefficients, shape (9, 9).

    Parameters
    ----------
    airframe : Airframe
    coefficients : array_like, shape (9,)
        The coefficients at which the information is evaluated (the truth).
    flight_or_inputs : Flight or OutputErrorInputs
        Initial state, recorded delta, sample interval (:func:`inputs_from_flight`).
    noise_sd : float or ndarray, broadcastable to (n, 9)
        Error standard deviation per sample and output channel
        (:data:`OUTPUT_CHANNELS`) [m/s^2, rad/s] (:func:`model_noise_sd` builds it).
    positions : ndarray, shape (2, 3), optional
        Triad positions [m]; default ``airframe.accel_positions``.
    channels : {"both", "triad1"}
        Outputs used: both triads and the rates, or triad 1 and the rates.
    estimate_initial : tuple of str
        Initial-state components (:data:`aeroid.model.STATE_NAMES`) estimated jointly
        with the coefficients as nuisance parameters; default none (the initial state
        is known). Their effect is removed with :func:`coefficient_information`.
    rel_step, substeps
        See :func:`output_sensitivities`.

    Returns
    -------
    ndarray, shape (9, 9)
        In units of 1 / (coefficient units)^2 (all coefficients are dimensionless).
    """
    inputs = _as_inputs(flight_or_inputs)
    cols = channel_indices(channels)
    model = _forward_model(airframe, inputs, positions, substeps)
    sd = np.asarray(noise_sd, dtype=float)
    check_sd(sd)
    if sd.ndim == 2:  # per sample and channel: the used channels
        sd = np.broadcast_to(sd, (model.n_samples, len(OUTPUT_CHANNELS)))[:, cols]
    elif sd.ndim == 1:  # per channel
        sd = np.broadcast_to(sd, (len(OUTPUT_CHANNELS),))[cols]
    info = fisher_information(model,
                              inputs.state0, coefficients, sd, channels=cols,
                              free_states=estimate_initial, rel_step=rel_step)
    if not np.all(np.isfinite(info)):
        raise ValueError("fisher: non-finite sensitivities (the model diverged)")
    return coefficient_information(info)


def cramer_rao_sd(
    scenario_or_flight: Scenario | Flight,
    noise_model: NoiseModel,
    *,
    positions: str = "true",
    noise_form: str = "heteroscedastic",
    channels: str = "both",
    estimate_initial: tuple[str, ...] = (),
    input: str = "auto",  # noqa: A002 - the estimators' option name
    holds: CoefficientSpec | None = None,
) -> np.ndarray:
    """Return the Cramér-Rao standard deviations of the nine coefficients, shape (9,).

    Parameters
    ----------
    scenario_or_flight : Scenario or Flight
        A scenario is simulated without noise; a flight must carry
        ``metadata["true_coefficients"]`` (a simulated flight) and is linearised about
        its recorded initial state and delta (use a noise-free flight for the exact floor).
    noise_model : PaperNoise or GaussianNoise
        The measurement errors (see :func:`model_noise_sd`; position errors are not noise).
    positions : {"true", "estimator"}
        Triad positions of the model: the true ones (default) or the estimator's copy.
    noise_form : {"heteroscedastic", "homoscedastic"}
        Paper noise only, see :func:`model_noise_sd`.
    channels : {"both", "triad1"}
        Outputs: both triads and p, q, r (default), or triad 1 and p, q, r.
    estimate_initial : tuple of str
        Initial-state components estimated jointly as nuisance parameters (default
        none). ``**PROTOTYPE_FLOOR`` (homoscedastic, triad 1, initial p, q, r estimated)
        reproduces the reference README's figures.
    input : {"auto", "hold", "midpoint", "events", "law"}
        How the model's deflection between samples is taken: ``auto`` (default) is
        ``law`` when the flight's airframe has a ``[fin_law]``, else ``hold``
        (:data:`aeroid.flights.INPUTS`); ``law`` and ``events`` are checked against the
        logged deflection first (:func:`aeroid.flights.check_input`: an error when they
        contradict it, an :class:`~aeroid.errors.AeroidWarning` when they agree in part).
        Per-sample channels of the flight are used.
    holds : CoefficientSpec or None
        Held ones known (floor NaN), priors added (:func:`floor_with_holds`).

    Returns
    -------
    pandas.Series, 9 values
        ``sqrt(diag(F^-1))`` by coefficient name (``.to_numpy()``: :data:`NAMES` order).

    Raises
    ------
    EstimatorError
        One line for a bad option or a flight without its truth.
    """
    try:
        sd = _cramer_rao_sd(scenario_or_flight, noise_model, positions, noise_form, channels,
                            estimate_initial, input, holds)
    except AeroidError:
        raise
    except (TypeError, ValueError, np.linalg.LinAlgError) as exc:
        text = " ".join(str(exc).split())
        raise EstimatorError(text if text.startswith("cramer_rao_sd") else
                             f"cramer_rao_sd: {text}") from None
    return pd.Series(sd, index=list(NAMES), name="cramer_rao_sd")


def _cramer_rao_sd(scenario_or_flight: Scenario | Flight, noise_model: NoiseModel,
                   positions: str, noise_form: str, channels: str, estimate_initial: tuple,
                   input: str, holds: CoefficientSpec | None) -> np.ndarray:  # noqa: A002
    if isinstance(scenario_or_flight, Scenario):
        flight = simulate(scenario_or_flight.airframe, scenario_or_flight.coefficient_vector,
                          scenario_or_flight.manoeuvre, NoNoise(), rng=0)
    elif isinstance(scenario_or_flight, Flight):
        flight = scenario_or_flight
    else:
        raise TypeError("cramer_rao_sd: expected a Scenario or a Flight, "
                        f"got {type(scenario_or_flight).__name__}")
    theta = flight.true_coefficients
    if theta is None:
        raise ValueError("cramer_rao_sd: the flight has no metadata['true_coefficients']")
    if positions == "true":
        truth = flight.metadata.get("true_accel_positions_m")
        if truth is None:
            raise ValueError("cramer_rao_sd: the flight has no metadata['true_accel_positions_m']")
        pos = np.asarray(truth, dtype=float)
    elif positions == "estimator":
        pos = flight.airframe.accel_positions
    else:
        raise ValueError(
            f"cramer_rao_sd: positions must be 'true' or 'estimator', got {positions!r}")
    choice = check_input(flight, input, owner="cramer_rao_sd")
    for doubt in choice.warnings:
        warnings.warn(doubt, AeroidWarning, stacklevel=3)
    inputs = inputs_from_flight(flight, choice.input)
    outputs = model_outputs(flight.airframe, theta, inputs, positions=pos)
    sd = model_noise_sd(noise_model, outputs, noise_form=noise_form)
    info = output_error_information(flight.airframe, theta, inputs, sd, positions=pos,
                                    channels=channels, estimate_initial=estimate_initial)
    return floor_with_holds(info, holds)  # None: all free, sqrt(diag(inv(info)))

