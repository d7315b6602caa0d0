"""The fit check: does the estimated model explain the data down to the noise?

A method that ends with its model missing the data by many times the noise has found the
optimum of the wrong model (a deflection held when the relay switched between samples, a
density held while it changed, a sensor position off); its estimates and their standard
errors mean little. Every result whose method reports its residuals carries, per
channel (``info["fit_check"]``):

- **size**: the residual RMS, the noise level of that channel estimated from the data
  alone (:func:`data_noise_sd`: the RMS of 4th differences over windows clear of relay
  switches, :func:`aeroid.estimation.difference_noise_sd`; no model involved) and their
  ratio; above :data:`RATIO_LIMIT` the result is ``success=False`` with a one-line
  message naming the worst channel.
- **whiteness**: a residual of a flight channel that is raw measurement minus model
  (not a smoothed one), on data that carry noise (:func:`noisy_channels`), is tested
  for autocorrelation and for correlation with the relay's switches
  (:mod:`aeroid.estimation._whiteness`); when any test's p-value is below
  :data:`WHITENESS_ALPHA` divided by the number of tests (Bonferroni over the
  channels), the result is ``success=False``: the model leaves structure the noise does
  not have, even when its size is near the noise level.
- **the method's noise model**: a method that weights its residuals by its own noise
  variances (``info["R"]``: output-error) must find them that size: a mean squared
  standardized residual above :data:`NOISE_MODEL_LIMIT` fails the result.
- **identifiability** (:mod:`aeroid.estimation._identifiability`), from the result's
  covariance or ``info["information"]``: a coefficient without information fails the
  result; pairs correlated above 0.98 are a warning.

Methods report ``info["fit_residuals"]``: channel name -> residual series (measured minus
model); for channels that are not flight channels (e.g. reconstructed forces),
``info["fit_signals"]``: channel name -> the series (its RMS sets the resolution floor)
and, where the data's differences are not the right yardstick, ``info["fit_noise_sd"]``:
channel name -> the noise level (e.g. the sensors' noise propagated into a load).

Reading the ratio: about 1 when the model fits (the residual is the noise); a few when
the model leaves structure of the size of the noise; tens or more when the model misses
the physics. On noise-free data the noise level is floored at :data:`RESOLUTION` of the
channel's RMS (:data:`DERIVED_RESOLUTION` for reconstructed channels).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np

from aeroid.estimation._holds_fit import floor_with_holds, holds_of
from aeroid.estimation._identifiability import identifiability_findings
from aeroid.estimation._information import coefficient_information, fisher_information
from aeroid.estimation._result import EstimationResult
from aeroid.estimation._signals import (
    DIFFERENCE_ORDER,
    MIN_CLEAN_WINDOWS,
    difference_noise_sd,
    switch_free_windows,
)
from aeroid.estimation._whiteness import autocorrelation_test, family_limit, switch_test
from aeroid.flights import STATE_CHANNELS, Flight
from aeroid.model import NAMES, OUTPUT_CHANNELS

#: A residual RMS above this many times the data's noise level fails the fit. Measured
#: with the 4th-difference yardstick on the shipped studies' right-model fits (runs 0-9,
#: benchmarks/fitcheck_rates.py), worst channel per fit: 1.0-1.4 for output-error and
#: the EKF/UKF innovations (tactical, MEMS and paper noise), up to 2.8 for
#: equation-error (paper noise); with a held deflection on a relay switching between
#: samples 4-113.
RATIO_LIMIT = 3.0
#: Floor of the noise level as a fraction of the channel's RMS (noise-free data). A
#: tactical IMU's roll-rate noise is 1e-4 of the reference flight's roll rate (0.005 of
#: 51 rad/s), so the floor stays a tenth of the smallest real noise in the shipped
#: scenarios; noise-free fits of the right model leave at most 3e-6 of the RMS
#: (output-error 1e-7, the EKF 3e-6; measured on the reference flight).
RESOLUTION = 1e-5
#: The same floor for channels that are not flight channels (``fit_signals``: loads
#: reconstructed from the sensors): the reconstruction itself is approximate (SG
#: derivatives of the rates), so a noise-free EBM fit of the right model leaves 9e-5 of
#: the roll moment's RMS (measured on the reference flight).
DERIVED_RESOLUTION = 1e-3
#: Data whose every channel's noise level is below this fraction of its RMS are treated
#: as noise-free by :func:`data_floor` (the 4th differences of the reference flight's
#: noise-free log are below 2e-5 of every channel's RMS).
NOISE_FREE_FRACTION = 1e-3
#: Family error rate of the whiteness tests of one result (Bonferroni over its tests).
#: Measured on the shipped studies' right-model fits (benchmarks/fitcheck_rates.py, runs
#: 0-9 of every condition; output-error, EKF, UKF): 1 of 290 tested results below it
#: (0.34 %), 3 below 1e-2, 11 below 0.1 (the residuals of a fit are not exactly white:
#: its parameters absorb some noise); every wrong-input fit had p < 1e-13.
WHITENESS_ALPHA = 1e-3
#: A method that weights its residuals by its own noise model (``info["R"]``) must find
#: them that size: a mean squared standardized residual ``e^2 / R`` above this fails the
#: fit. Right fits: 0.97-1.0 (output-error, paper noise); output-error stopped in a poorer
#: optimum of its likelihood (run 51 of paper_table5_prior, cost 15 400 above the fit from
#: the truth, residuals the same to 3 digits, whiteness p >= 0.09) leaves r at 65.
NOISE_MODEL_LIMIT = 2.0
#: Channels whose residual RMS is below this fraction of the data's noise level are not
#: tested for whiteness: such a residual is not the noise (noise-free data, where the
#: level is the resolution floor and a right model leaves its integration error).
WHITENESS_MIN_RATIO = 0.5
#: A channel is tested for whiteness only when its data carry noise: its level from 5th
#: differences at least this fraction of that from 4th (:func:`noisy_channels`; measured
#: on the reference flight, seeds 0-2: 0.95-1.03 under Gaussian and paper noise, 0.045-0.082
#: on its noise-free log).
NOISE_ORDER_AGREEMENT = 0.5
NOISE_LEVEL_GROUP = 3  #: fewest channels per pass of :func:`data_noise_levels`


def data_noise_sd(flight: Flight, signal: np.ndarray) -> float | np.ndarray:
    """A channel's noise level from the data alone: the RMS of its 4th differences over
    windows clear of relay switches (:func:`aeroid.estimation.difference_noise_sd`).

    ``signal`` of shape (n,) gives a float; (n, m) (m channels at once) an array of
    shape (m,).
    """
    signal = np.asarray(signal, dtype=float)
    delta = flight["delta"] if signal.shape[0] == flight.n_samples else None
    sd, _ = difference_noise_sd(signal, delta)
    return float(sd) if signal.ndim == 1 else sd


def data_noise_levels(flight: Flight, names: tuple[str, ...] = OUTPUT_CHANNELS,
                      ) -> dict[str, float]:
    """Return :func:`data_noise_sd` of every channel of ``names`` present, in groups of
    :data:`NOISE_LEVEL_GROUP` or more (memory of a few channels; never one alone: numpy
    sums one column pairwise, a 2-D block's row by row, so the levels are the bits of
    all channels at once)."""
    present = tuple(name for name in names if name in flight.channels)
    if not present:
        return {}
    groups = np.array_split(np.arange(len(present)), max(len(present) // NOISE_LEVEL_GROUP, 1))
    sd = np.concatenate([
        np.atleast_1d(data_noise_sd(flight, flight._columns(tuple(present[j] for j in group))))
        for group in groups])
    return dict(zip(present, (float(v) for v in sd), strict=True))


def noisy_channels(columns: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """Return which channels carry noise, not only a smooth signal, (m,) bool.

    White noise gives the same level from differences of any order; a smooth signal's
    leakage falls by ``w dt`` (about 0.06 on the reference flight) with each order. A
    channel is noisy when its level from 5th differences is at least
    :data:`NOISE_ORDER_AGREEMENT` of its level from 4th differences.

    Parameters
    ----------
    columns : ndarray, shape (n, m)
        Flight channels.
    delta : ndarray, shape (n,)
        The logged deflection.
    """
    fourth, _ = difference_noise_sd(columns, delta, order=DIFFERENCE_ORDER)
    fifth, _ = difference_noise_sd(columns, delta, order=DIFFERENCE_ORDER + 1)
    return (fifth >= NOISE_ORDER_AGREEMENT * fourth) & (fourth > 0.0)


def fit_check(flight: Flight, residuals: Mapping[str, np.ndarray],
              signals: Mapping[str, np.ndarray] | None = None,
              noise_sd: Mapping[str, float] | None = None,
              levels: Mapping[str, float] | None = None, *,
              white: bool = True, variance: Any = None) -> dict[str, Any]:
    """Return the fit check of residuals against the data's noise levels and whiteness.

    ``noise_sd`` are the method's own levels for its channels; ``levels`` the data's
    levels of flight channels already computed (:func:`data_noise_levels`); any other
    channel's level is computed here. ``white``: whether the method's residuals of flight
    channels should be white when its model is right (False for residuals of smoothed
    targets). ``variance``: the method's own noise variances of its residuals
    (``info["R"]``, see :func:`_standardized`).

    Returns
    -------
    dict
        ``residual_rms``, ``noise_sd``, ``ratio`` (each channel -> float), ``worst``
        (the channel of the largest ratio), ``limit`` (:data:`RATIO_LIMIT`);
        ``whiteness`` (each tested channel -> ``{"autocorrelation": p, "switches": p}``),
        ``white_limit`` (the per-test p-value limit) and ``not_white`` (the channels
        with a p-value below it, most significant first).
    """
    signals = dict(signals or {})
    given = dict(noise_sd or {})
    known = dict(levels or {})
    own = tuple(name for name in residuals if name not in signals and name in flight.channels)
    data = dict(zip(own, flight._columns(own).T, strict=True)) if own else {}
    rms, sd, ratio, candidates = {}, {}, {}, []
    for name, res in residuals.items():
        res = np.asarray(res, dtype=float)
        signal = np.asarray(signals[name] if name in signals else data.get(name, flight[name]),
                            dtype=float)
        level = float(np.sqrt(np.mean(signal * signal)))
        if name in given:
            estimate = given[name]
        elif name in known and name not in signals:
            estimate = known[name]
        else:
            estimate = float(np.max(data_noise_sd(flight, signal)))  # one channel: a float
        floor = DERIVED_RESOLUTION if name in signals else RESOLUTION
        noise = max(estimate, floor * level, np.finfo(float).tiny)
        rms[name] = float(np.sqrt(np.mean(res * res)))
        sd[name] = noise
        ratio[name] = rms[name] / noise
        if (white and name in data and ratio[name] >= WHITENESS_MIN_RATIO
                and np.all(np.isfinite(res))):
            candidates.append(name)
    tests = {}
    if candidates:
        delta = flight["delta"]
        noisy = noisy_channels(np.column_stack([data[n] for n in candidates]), delta)
        for name in (n for n, keep in zip(candidates, noisy, strict=True) if keep):
            res = np.asarray(residuals[name], dtype=float)
            tests[name] = {"autocorrelation": autocorrelation_test(res).p_value,
                           "switches": switch_test(res, delta).p_value}
    worst = max(ratio, key=lambda k: ratio[k] if np.isfinite(ratio[k]) else np.inf)
    windows = switch_free_windows(flight["delta"], DIFFERENCE_ORDER + 1).size
    yardstick = (f"4th differences over {windows} windows clear of a switch"
                 if windows >= MIN_CLEAN_WINDOWS else
                 f"4th differences, robust spread of all windows (only {windows} clear of "
                 "a switch)")
    standardized = _standardized(residuals, variance)
    limit = family_limit(WHITENESS_ALPHA, sum(len(t) for t in tests.values()))
    low = {name: min(t.values()) for name, t in tests.items() if min(t.values()) < limit}
    return {"residual_rms": rms, "noise_sd": sd, "ratio": ratio, "worst": worst,
            "limit": RATIO_LIMIT, "whiteness": tests, "white_limit": limit,
            "not_white": sorted(low, key=low.__getitem__), "standardized": standardized,
            "yardstick": yardstick}


def _standardized(residuals: Mapping[str, np.ndarray], variance: Any) -> dict[str, float]:
    """Return each channel's mean ``e^2 / R`` under the method's own noise model.

    ``variance``: ``info["R"]`` of the method, shape (n, m) (one variance per sample) or
    (m,), columns in the order of ``residuals``; anything else, or a channel not at R's
    rows (output-error's aiding channels, at their own samples), gives no figures.
    """
    if variance is None:
        return {}
    R = np.asarray(variance, dtype=float)
    names = tuple(residuals)
    if R.ndim == 1:
        R = R[None, :]
    if R.ndim != 2 or R.shape[1] != len(names):
        return {}
    with np.errstate(divide="ignore", invalid="ignore"):
        return {name: float(np.mean(np.asarray(residuals[name], float) ** 2 / R[:, j]))
                for j, name in enumerate(names)
                if R.shape[0] in (1, np.asarray(residuals[name]).shape[0])}


def _smoothed_residuals(info: Mapping[str, Any], options: Mapping[str, Any] | None) -> bool:
    options = dict(options or info.get("options") or {})
    return options.get("smoothing", "none") in ("forces", "both")


def apply_fit_check(result: EstimationResult, flight: Flight,
                    levels: Mapping[str, float] | None = None,
                    options: Mapping[str, Any] | None = None) -> EstimationResult:
    """Return ``result`` with ``info["fit_check"]``, failed when the model does not fit.

    ``levels``: the data's noise levels already computed (:func:`data_noise_levels`);
    ``options``: the method's options (a ``smoothing`` of ``"forces"`` or ``"both"``
    smooths the targets, so its residuals are not tested for whiteness).
    A successful result also gets the identifiability findings
    (:mod:`aeroid.estimation._identifiability`).
    """
    residuals = result.info.get("fit_residuals")
    info = {k: v for k, v in result.info.items()
            if k not in ("fit_residuals", "fit_signals", "fit_noise_sd")}
    failure = None
    if residuals:
        check = fit_check(flight, residuals, result.info.get("fit_signals"),
                          result.info.get("fit_noise_sd"), levels,
                          white=not _smoothed_residuals(result.info, options),
                          variance=result.info.get("R"))
        info["fit_check"] = check
        worst = check["worst"]
        ratio = check["ratio"][worst]
        if not ratio <= RATIO_LIMIT:
            failure = (f"the model does not fit the data: {worst} residual RMS is {ratio:.3g}x "
                       f"its noise level estimated from the data (limit {RATIO_LIMIT:g}); "
                       "check the input between samples, per-sample inputs, sensor positions")
        elif any(not v <= NOISE_MODEL_LIMIT for v in check["standardized"].values()):
            name, value = max(check["standardized"].items(), key=lambda kv: -np.inf
                              if np.isnan(kv[1]) else kv[1])
            failure = (f"the method's noise model does not explain its residuals: {name} "
                       f"mean squared standardized residual {value:.3g} (limit "
                       f"{NOISE_MODEL_LIMIT:g}; a poorer optimum of the likelihood): try "
                       "more starts (n_starts) or noise_model = channel")
        elif check["not_white"]:
            failure = _not_white_message(check)
    warnings = tuple(result.warnings)
    if result.success and failure is None:
        failure, extra = identifiability_findings(
            result.names, result.theta, result.covariance, result.info.get("information"))
        warnings += extra
    if result.success and failure is not None:
        return dataclasses.replace(result, success=False, message=failure, info=info,
                                   warnings=warnings)
    return dataclasses.replace(result, info=info, warnings=warnings)


def _not_white_message(check: Mapping[str, Any]) -> str:
    name = check["not_white"][0]
    kind, p = min(check["whiteness"][name].items(), key=lambda kv: kv[1])
    what = ("autocorrelated" if kind == "autocorrelation"
            else "correlated with the relay's switches")
    others = check["not_white"][1:]
    more = f" (also {', '.join(others)})" if others else ""
    return (f"the model leaves structure in the residuals: {name} is {what}{more}, "
            f"p = {p:.2g} below {check['white_limit']:.2g} (whiteness at family error "
            f"{WHITENESS_ALPHA:g}, residual RMS {check['ratio'][name]:.3g}x noise); check the "
            "input between samples (input = law), the actuator delay, a poorer optimum "
            "(n_starts)")


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
               levels: Mapping[str, float] | None = None, holds: Any = None) -> np.ndarray | None:
    """Return the Cramér-Rao floor of the nine coefficients at ``theta`` from the data.

    The output-error information of the flight's record (both triads and the rates,
    initial rates estimated as nuisance) with each channel's noise level estimated from
    the data (:func:`aeroid.estimation.estimate_noise_sd`); None when the data are
    noise-free (every channel below :data:`NOISE_FREE_FRACTION` of its RMS: no floor to
    compare with)
    or the model diverges. ``levels``: the data's noise levels already computed
    (:func:`data_noise_levels`); ``holds``: that of the free ones (:func:`floor_with_holds`).
    """
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
        level = float(np.sqrt(np.mean(signal * signal)))
        estimate = known[name]
        noisy |= estimate > NOISE_FREE_FRACTION * level
        sd[j] = max(estimate, RESOLUTION * level)  # a clean channel: much, not infinitely
    if not noisy:
        return None
    window = min(7, flight.n_samples - 1 + flight.n_samples % 2)
    # the first state with its rates smoothed: only the first window is read
    states = flight.data.iloc[:window][list(STATE_CHANNELS)].to_numpy(dtype=float)
    x0 = states[0].copy()
    x0[3:6] = smooth(states[:, 3:6], window, min(2, window - 1))[0]
    with np.errstate(all="ignore"):  # summed block by block: the n x 9 x 12 sensitivities
        info = fisher_information(model, x0, np.asarray(theta, dtype=float), sd,  # never held
                                  free_states=("p", "q", "r"))
    if not np.all(np.isfinite(info)):
        return None
    try:
        return floor_with_holds(coefficient_information(info), holds)  # None: all free
    except np.linalg.LinAlgError:
        return None


def floor_warnings(result: EstimationResult, flight: Flight,
                   levels: Mapping[str, float] | None = None) -> tuple[str, ...]:
    """Warnings for standard errors below :data:`FLOOR_FRACTION` of :func:`data_floor`.

    Only for methods with one noise level per channel (the result's ``noise_model`` None
    or ``"channel"``): the floor here is the per-channel one. The floor's record takes
    the result's ``input`` (``hold`` for a method that integrates no model).
    """
    if result.stderr is None or not result.success or tuple(result.names) != NAMES:
        return ()  # other names: tables in Mach (baselines._tables_fit.table_floor)
    if (result.noise_model or "channel") != "channel":
        # A method that weights each sample (a_c + b_c yhat^2) has a per-sample floor,
        # far below this per-channel one under signal-proportional noise; the same floor
        # from the data alone (the law fitted to smoother residuals) put output-error's
        # standard errors at 0.4-23x it on two paper-noise flights (measured): no
        # yardstick for a warning.
        return ()
    floor = data_floor(flight, result.theta, result.input or "hold", levels, holds_of(result))
    if floor is None:
        return ()
    low = [f"{name} ({se:.3g} < {f:.3g})"
           for name, se, f in zip(result.names, result.stderr, floor, strict=True)
           if np.isfinite(se) and se < FLOOR_FRACTION * f]
    if not low:
        return ()
    return (f"standard errors claim more than the data allow: below half the Cramér-Rao "
            f"floor for {', '.join(low)}",)
