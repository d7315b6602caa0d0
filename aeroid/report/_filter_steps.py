"""Filter-error's one-step predictions, from the states its filter kept (issue 26).

Filter-error's residuals are the innovations of its gust filter, ``z_k - h(x_k^-,
w_k^-)``; the fit check reads them and then drops them from ``info`` (per-sample series),
but ``info`` keeps the filtered state ``x_{k|k}`` (``state_filtered``) and wind ``w_{k|k}``
(``wind_filtered_ned_mps``). The prediction before each update is made again from them
by the one model (:func:`aeroid.model.propagate`, the outputs of
:mod:`aeroid.model.equations` as :class:`aeroid.model.ForwardModel` takes them), as the
filter makes it (:mod:`baselines._fem_model`): the state over one interval (RK4, the
fit's ``substeps``) with the filtered wind held over it, the wind decaying towards the steady wind
(``info["wind_ned_mps"]`` when estimated, else still air) by ``exp(-dt / tau)``, ``tau =
info["gust_time_constant_s"]``; the outputs at the next sample in that wind. The first
sample's prediction is the fit's start, which ``info`` does not keep: it is left out.

The EKF with gust states keeps the same (``state``, ``gust_ned_mps``, its coefficients per
sample in ``history["theta"]``: they are states) and predicts the same way, the gusts
decaying towards zero (:mod:`baselines._kalman_gust`), unless it carries states it does
not keep per sample (a steady wind, IMU errors, accelerometer positions). The UKF's
prediction is the mean of its sigma points, not kept either. With ``gust_stderr =
one-step`` (the EKF/UKF's default) the reported estimate is judged by filter-error's
filter run there, whose states, gusts and time constant ``info["one_step"]`` keeps: that
filter is drawn. Those are drawn open-loop,
and :func:`filter_prediction` says why in one line.
``tests/unit/test_report_filter.py`` checks these against the filter's own innovations.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from aeroid.flights import Flight, flight_record, model_constants
from aeroid.model import (
    EXOGENOUS,
    N_STATE,
    Pieces,
    as_coefficients,
    as_state,
    equations,
    exogenous_table,
    propagate,
    with_exogenous,
)

__all__ = ["filter_one_step", "filter_prediction", "has_filter_states", "one_step_states"]

#: The model's exogenous wind columns.
_WIND = [EXOGENOUS.index(name) for name in EXOGENOUS if name.startswith("wind_")]


def has_filter_states(info: Mapping[str, Any], n: int) -> bool:
    """Whether ``info`` keeps a gust filter's filtered states and wind for ``n`` samples."""
    return (np.shape(info.get("state_filtered", ())) == (n, N_STATE)
            and np.shape(info.get("wind_filtered_ned_mps", ())) == (n, len(_WIND))
            and isinstance(info.get("gust_time_constant_s"), float | int))


def one_step_states(info: Mapping[str, Any], n: int
                    ) -> tuple[np.ndarray, np.ndarray, float] | None:
    """The EKF/UKF's ``gust_stderr = one-step``: the states, gusts and time constant of
    filter-error's filter run at the reported estimate (``info["one_step"]``, what its fit
    check judged), or None."""
    one = info.get("one_step")
    if not isinstance(one, Mapping) or not isinstance(one.get("time_constant_s"),
                                                       float | int):
        return None
    states, gusts = (np.asarray(one.get(k, ()), dtype=float) for k in ("state",
                                                                       "gust_ned_mps"))
    if states.shape != (n, N_STATE) or gusts.shape != (n, len(_WIND)):
        return None
    return states, gusts, float(one["time_constant_s"])


def filter_one_step(result: Any, flight: Flight, input_mode: str, delay_s: float, *,
                    states: np.ndarray | None = None, wind: np.ndarray | None = None,
                    theta: np.ndarray | None = None, tau_s: float | None = None
                    ) -> np.ndarray:
    """The filter's predicted outputs before each update, shape (n, m) (module docstring).

    Columns :data:`aeroid.model.OUTPUT_CHANNELS`; row 0 NaN (the start is not kept).
    ``input_mode``, ``delay_s``: the deflection between samples the fit used. ``states``
    (n, 9), ``wind`` (n, 3) NED [m/s] and ``theta`` (9,) or (n, 9): the filtered ones
    (default filter-error's ``state_filtered``, ``wind_filtered_ned_mps`` and the
    estimate; the EKF's coefficients are states, filtered per sample).
    """
    info = result.info
    n = flight.n_samples
    states = np.asarray(info["state_filtered"] if states is None else states, dtype=float)
    wind = np.asarray(info["wind_filtered_ned_mps"] if wind is None else wind, dtype=float)
    theta = np.asarray(result.theta if theta is None else theta, dtype=float)
    theta = np.broadcast_to(theta, (n, theta.shape[-1]))
    given = info.get("wind_ned_mps")
    steady = np.zeros(len(_WIND)) if given is None else np.asarray(given, dtype=float)
    tau = float(info["gust_time_constant_s"] if tau_s is None else tau_s)
    decay = math.exp(-flight.dt / tau)
    options = info.get("options") if isinstance(info.get("options"), Mapping) else {}
    substeps = int(options.get("substeps", 1))
    record = flight_record(flight, input_mode, delay_s)
    const = model_constants(flight)
    base = exogenous_table(const, n) if record.exogenous is None else record.exogenous
    predicted = np.full((n, N_STATE), np.nan)
    with np.errstate(all="ignore"):
        for k in range(1, n):  # the interval k-1 -> k in the filtered wind of k-1, held
            table = base[k - 1:k + 1].copy()
            table[:, _WIND] += wind[k - 1]
            pieces = Pieces(*(a[k - 1:k] for a in record.pieces))
            predicted[k] = propagate(states[k - 1], theta[k - 1:k], pieces, flight.dt, const,
                                     substeps=substeps, exogenous=table, parallel=False)[0, -1]
    table = base.copy()
    table[1:, _WIND] += steady + decay * (wind[:-1] - steady)  # the wind's prediction
    positions = flight.airframe.accel_positions
    outputs = np.full((n, len(equations.output_names(positions.shape[0]))), np.nan)
    with np.errstate(all="ignore"):  # as ForwardModel.outputs_of, per-sample coefficients
        sample = with_exogenous(const, table.T)
        x = as_state(predicted)
        prior = np.vstack([theta[:1], theta[:-1]])  # sample k's: those filtered at k - 1
        loads = equations.aerodynamic_loads(x, as_coefficients(prior), record.delta, sample)
        equations.outputs(np.moveaxis(outputs, -1, 0), x, loads, sample, positions)
    outputs[0] = np.nan
    return outputs


def _ekf_states(result: Any, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray] | str:
    """The EKF's filtered states, gusts and coefficients per sample, or why not."""
    info, history = result.info, result.history or {}
    if result.estimator != "ekf":
        return (f"{result.estimator}'s one-step prediction is the mean of its sigma points, "
                "which the result does not keep")
    kept = [name for name, there in (
        ("a steady wind", info.get("wind_ned_mps") is not None),
        ("IMU errors", bool(info.get("imu_errors"))),
        ("accelerometer positions", np.any(np.asarray(info.get("accel_position_stderr_m",
                                                               0.0)) > 0))) if there]
    if kept:
        return (f"the EKF's states of {' and '.join(kept)} are not kept per sample, so its "
                "one-step prediction cannot be made again")
    arrays = (info.get("state", ()), info.get("gust_ned_mps", ()), history.get("theta", ()))
    if [np.shape(a) for a in arrays] != [(n, N_STATE), (n, len(_WIND)),
                                         (n, np.size(result.theta))]:
        return "the EKF's filtered states per sample are not in the result"
    return tuple(np.asarray(a, dtype=float) for a in arrays)  # type: ignore[return-value]


def filter_prediction(result: Any, flight: Flight, input_mode: str, delay_s: float
                      ) -> tuple[np.ndarray | None, str]:
    """A gust filter's one-step predicted outputs (n, m) (:func:`filter_one_step`), or None
    and the one line saying why they are not drawn (module docstring)."""
    n = flight.n_samples
    if result.info.get("gust_model", "first-order") != "first-order":
        return None, (f"{result.estimator}'s {result.info['gust_model']} gust states are not "
                      "kept per sample, so its one-step prediction cannot be made again")
    moved = one_step_states(result.info, n)
    if moved is not None:  # the EKF/UKF's one-step estimate: filter-error's filter there
        states, gusts, tau = moved
        return filter_one_step(result, flight, input_mode, delay_s, states=states,
                               wind=gusts, tau_s=tau), ""
    if has_filter_states(result.info, n):
        return filter_one_step(result, flight, input_mode, delay_s), ""
    found = _ekf_states(result, n)
    if isinstance(found, str):
        return None, found
    states, gusts, theta = found
    return filter_one_step(result, flight, input_mode, delay_s, states=states, wind=gusts,
                           theta=theta), ""
