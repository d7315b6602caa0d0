"""The fit check: does the estimated model explain the data to the noise level?

A method that ends with its model missing the data by many times the noise has found the
optimum of the wrong model (a deflection held when the relay switched between samples, a
density held while it changed, a sensor position off); its estimates and their standard
errors mean little. Every result whose method reports its residuals carries, per
channel, the residual RMS, the noise level of that channel estimated from the data
alone (:func:`aeroid.estimation.estimate_noise_sd`: the RMS of the 7-point
Savitzky-Golay residual away from relay switches; no model involved) and their ratio
(``info["fit_check"]``); above :data:`RATIO_LIMIT` the result is ``success=False`` with a
one-line message naming the worst channel.

Methods report ``info["fit_residuals"]``: channel name -> residual series (measured minus
model); for channels that are not flight channels (e.g. reconstructed forces),
``info["fit_signals"]``: channel name -> the series (its RMS sets the resolution floor)
and, where the smoother's residual is not the right yardstick, ``info["fit_noise_sd"]``:
channel name -> the noise level (e.g. the sensors' noise propagated into a load).

Reading the ratio: about 1 when the model fits (the residual is the noise); a few when
the model leaves structure of the size of the noise; tens or more when the model misses
the physics. On noise-free data the noise level is floored at :data:`RESOLUTION` of the
channel's RMS (a model reproducing the data to 0.1 % fits).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np

from aeroid.estimation._result import EstimationResult
from aeroid.estimation._signals import estimate_noise_sd, switch_free_samples
from aeroid.flights import Flight
from aeroid.model import OUTPUT_CHANNELS

#: A residual RMS above this many times the data's noise level fails the fit. Measured on
#: fits whose model is right (reference flight, Gaussian noise): 0.9-1.2 for output-error,
#: the EKF/UKF innovations, EAM-PSO; up to 2.1 (az2) under the paper's noise with its 10 %
#: sensor-position error, which the model does not know; with a held deflection on a
#: relay switching between samples (JSBSim, Gaussian noise) 4-37.
RATIO_LIMIT = 3.0
#: Floor of the noise level as a fraction of the channel's RMS: on noise-free data a
#: model that reproduces every channel to 0.1 % of its size fits.
RESOLUTION = 1e-3


def data_noise_sd(flight: Flight, signal: np.ndarray) -> float | np.ndarray:
    """A channel's noise level from the data alone: the RMS of its 7-point smoother
    residual away from relay switches (the accelerations jump there).

    ``signal`` of shape (n,) gives a float; (n, m) (m channels at once, one smoother
    pass) an array of shape (m,).
    """
    signal = np.asarray(signal, dtype=float)
    use = switch_free_samples(flight["delta"]) if signal.shape[0] == flight.n_samples \
        else None
    sd = estimate_noise_sd(signal, statistic="rms", use=use)
    return float(sd) if signal.ndim == 1 else sd


def data_noise_levels(flight: Flight, names: tuple[str, ...] = OUTPUT_CHANNELS,
                      ) -> dict[str, float]:
    """Return :func:`data_noise_sd` of every channel of ``names`` present (one pass)."""
    present = tuple(name for name in names if name in flight.channels)
    if not present:
        return {}
    sd = data_noise_sd(flight, flight._columns(present))
    return dict(zip(present, (float(v) for v in sd), strict=True))


def fit_check(flight: Flight, residuals: Mapping[str, np.ndarray],
              signals: Mapping[str, np.ndarray] | None = None,
              noise_sd: Mapping[str, float] | None = None,
              levels: Mapping[str, float] | None = None) -> dict[str, Any]:
    """Return the fit check of residuals against the data's noise levels.

    ``noise_sd`` are the method's own levels for its channels; ``levels`` the data's
    levels of flight channels already computed (:func:`data_noise_levels`); any other
    channel's level is computed here.

    Returns
    -------
    dict
        ``residual_rms``, ``noise_sd``, ``ratio`` (each channel -> float), ``worst``
        (the channel of the largest ratio), ``limit`` (:data:`RATIO_LIMIT`).
    """
    signals = dict(signals or {})
    given = dict(noise_sd or {})
    known = dict(levels or {})
    rms, sd, ratio = {}, {}, {}
    for name, res in residuals.items():
        res = np.asarray(res, dtype=float)
        signal = np.asarray(signals[name] if name in signals else flight[name], dtype=float)
        level = float(np.sqrt(np.mean(signal * signal)))
        if name in given:
            estimate = given[name]
        elif name in known and name not in signals:
            estimate = known[name]
        else:
            estimate = data_noise_sd(flight, signal)
        noise = max(estimate, RESOLUTION * level, np.finfo(float).tiny)
        rms[name] = float(np.sqrt(np.mean(res * res)))
        sd[name] = noise
        ratio[name] = rms[name] / noise
    worst = max(ratio, key=lambda k: ratio[k] if np.isfinite(ratio[k]) else np.inf)
    return {"residual_rms": rms, "noise_sd": sd, "ratio": ratio, "worst": worst,
            "limit": RATIO_LIMIT}


def apply_fit_check(result: EstimationResult, flight: Flight,
                    levels: Mapping[str, float] | None = None) -> EstimationResult:
    """Return ``result`` with ``info["fit_check"]``, failed when the model does not fit.

    ``levels``: the data's noise levels already computed (:func:`data_noise_levels`).
    """
    residuals = result.info.get("fit_residuals")
    if not residuals:
        return result
    check = fit_check(flight, residuals, result.info.get("fit_signals"),
                      result.info.get("fit_noise_sd"), levels)
    info = {k: v for k, v in result.info.items()
            if k not in ("fit_residuals", "fit_signals", "fit_noise_sd")}
    info["fit_check"] = check
    worst = check["worst"]
    ratio = check["ratio"][worst]
    if result.success and not ratio <= RATIO_LIMIT:
        message = (f"the model does not fit the data: {worst} residual RMS is {ratio:.3g}x "
                   f"its noise level estimated from the data (limit {RATIO_LIMIT:g}); "
                   "check the input between samples, per-sample inputs, sensor positions")
        return dataclasses.replace(result, success=False, message=message, info=info)
    return dataclasses.replace(result, info=info)


#: Standard errors below this fraction of the data's Cramér-Rao floor claim more than
#: the data allow (a warning): measured ratios of standard error to this floor on the
#: reference flights (paper and Gaussian noise, two seeds) are 0.95-1.1 for output-error,
#: 1.1-18 for the EKF/UKF and 0.6-214 for equation-error (less efficient methods).
FLOOR_FRACTION = 0.5
#: RK4 steps per sample of the floor's model: the floor changes by 1.3e-5 relative
#: between 1 and 2 steps on the reference flight (paper noise, measured), far below what
#: a factor-2 check can see, at half the cost of 2.
FLOOR_SUBSTEPS = 1


def data_floor(flight: Flight, theta: np.ndarray, input: str = "hold",  # noqa: A002
               levels: Mapping[str, float] | None = None) -> np.ndarray | None:
    """Return the Cramér-Rao floor of the nine coefficients at ``theta`` from the data.

    The output-error information of the flight's record (both triads and the rates,
    initial rates estimated as nuisance) with each channel's noise level estimated from
    the data (:func:`aeroid.estimation.estimate_noise_sd`); None when the data are
    noise-free (every channel at the :data:`RESOLUTION` floor: no floor to compare with)
    or the model diverges. ``levels``: the data's noise levels already computed
    (:func:`data_noise_levels`).
    """
    from aeroid.estimation._floor import coefficient_information, information_from_sensitivities
    from aeroid.estimation._signals import smooth
    from aeroid.flights import flight_record, model_constants
    from aeroid.model import ForwardModel

    record = flight_record(flight, input)
    model = ForwardModel(model_constants(flight), record, flight.airframe.accel_positions,
                         substeps=FLOOR_SUBSTEPS)
    sd = np.empty(len(model.output_names))
    noisy = False
    known = dict(levels or {})
    missing = tuple(name for name in model.output_names if name not in known)
    known.update(data_noise_levels(flight, missing) if missing else {})
    for j, name in enumerate(model.output_names):
        signal = flight[name]
        level = RESOLUTION * float(np.sqrt(np.mean(signal * signal)))
        estimate = known[name]
        noisy |= estimate > level
        sd[j] = max(estimate, 1e-3 * level)  # a clean channel is worth much, not infinitely
    if not noisy:
        return None
    states = flight.states()
    x0 = states[0].copy()
    window = min(7, states.shape[0] - 1 + states.shape[0] % 2)
    x0[3:6] = smooth(states[:, 3:6], window, min(2, window - 1))[0]
    with np.errstate(all="ignore"):
        jac = model.sensitivities(x0, np.asarray(theta, dtype=float),
                                  free_states=("p", "q", "r"))
    if not np.all(np.isfinite(jac)):
        return None
    info = coefficient_information(information_from_sensitivities(jac, sd))
    try:
        return np.sqrt(np.diag(np.linalg.inv(info)))
    except np.linalg.LinAlgError:
        return None


def floor_warnings(result: EstimationResult, flight: Flight,
                   levels: Mapping[str, float] | None = None) -> tuple[str, ...]:
    """Warnings for standard errors below :data:`FLOOR_FRACTION` of :func:`data_floor`.

    Only for methods with one noise level per channel (no ``noise_model`` option, or
    ``noise_model = "channel"``): the floor here is the per-channel one.
    """
    if result.stderr is None or not result.success:
        return ()
    options = result.info.get("options", {})
    if options.get("noise_model", "channel") != "channel":
        # A method that weights each sample (a_c + b_c yhat^2) has a per-sample floor,
        # far below this per-channel one under signal-proportional noise; the same floor
        # from the data alone (the law fitted to smoother residuals) put output-error's
        # standard errors at 0.4-23x it on two paper-noise flights (measured): no
        # yardstick for a warning.
        return ()
    floor = data_floor(flight, result.theta, options.get("input", "hold"), levels)
    if floor is None:
        return ()
    low = [f"{name} ({se:.3g} < {f:.3g})"
           for name, se, f in zip(result.names, result.stderr, floor, strict=True)
           if np.isfinite(se) and se < FLOOR_FRACTION * f]
    if not low:
        return ()
    return (f"standard errors claim more than the data allow: below half the Cramér-Rao "
            f"floor for {', '.join(low)}",)
