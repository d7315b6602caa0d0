"""Filter-error with air data (alpha, beta, airspeed) as measured outputs (issue 26).

``air_data = "measured"`` (or ``"auto"`` on a flight that has air data) appends the log's
air-data channels to the filter's measurements at every sample, as output-error's and the
EKF/UKF's ``air_data`` do (:mod:`baselines._oe_airdata`, :mod:`baselines._kalman_air`;
the same option names, values and refusals):

- **Prediction**: their probe outputs, not written again
  (:func:`baselines._oe_airdata._probe_outputs`: the model's air-relative velocity with
  the wind the loads see, the filter's steady plus gust states, by
  :func:`aeroid.model.with_wind_symbols`, plus ``omega x r`` at the probe, then
  :func:`aeroid.model.equations.air_data`), as rows of the compiled filter's measurement
  after the IMU's (:func:`baselines._fem_model.gust_functions`); exact Jacobians.
- **Calibration** (``air_data_calibration``, default ``factor+offset``):
  ``logged = (1 + k) angle + b`` per angle, ``k`` and ``b`` parameters of the likelihood
  with the coefficients (output-error's scales, start 0, no prior), with standard errors
  from the innovations' information.
- **Probe position**: ``metadata["air_data_probe"]["position_m"]``
  (:func:`baselines._oe_airdata.probe_position`; the c.g. without it, said).
- **Noise** (``air_data_noise``): ``data`` (default) one variance per channel started at
  the channel's smoother-residual level and re-estimated from the innovations after every
  iteration (the relaxation of the IMU's channels, whichever source those have); or
  ``metadata``: the log's ``metadata["air_data_probe"]["noise_sd"]``, held.

What was used is said in one line and in ``info["air_data"]``; the log's air against the
inertial angles is reported as still air, wind or turbulence
(:func:`aeroid.estimation.air_data_verdict`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from aeroid import estimation
from aeroid.flights import Flight
from baselines._kalman_air import UNITS, AirOutputOptions, measured_air
from baselines._oe_airdata import (
    calibration_scales,
)


@dataclass(frozen=True, kw_only=True)
class FemAirOption(AirOutputOptions):
    """Filter-error's air-data options (a base of :class:`baselines.filter_error.
    FilterErrorEstimator`).

    Attributes
    ----------
    air_data : {"inertial", "auto", "measured"}
        ``"measured"``: the flight's air data (logged ``alpha``, ``beta`` that differ from
        the inertial ones; a logged ``airspeed``) as measured outputs of the filter at every
        sample, or a one-line refusal of a flight without them; ``"auto"``: those outputs
        when the flight has air data; ``"inertial"`` (default: the option adds outputs and
        parameters): left out, and said ignored (:mod:`baselines._fem_air`).
    air_data_calibration : {"none", "offset", "factor", "factor+offset"}
        Flow-angle calibration estimated with the coefficients (default
        ``"factor+offset"``): ``logged = (1 + k) angle + b`` per angle.
    air_data_noise : {"data", "metadata"}
        The probe's noise variance per channel: from the data, re-estimated from the
        innovations (default), or the log's ``metadata["air_data_probe"]["noise_sd"]``,
        held.
    """



@dataclass(frozen=True)
class FemAirPlan:
    """The air data a fit uses (:func:`air_plan`).

    ``z`` (n, k) the logged values; ``var`` (k,) the initial noise variances; ``held``:
    the variances are the log's (not re-estimated); ``floor`` (k,) their floor.
    """

    channels: tuple[str, ...]
    calibration: tuple[str, ...]
    probe: np.ndarray
    probe_where: str
    z: np.ndarray
    var: np.ndarray
    held: bool
    floor: np.ndarray


def air_plan(est: Any, flight: Flight) -> FemAirPlan | None:
    """The air data ``est`` uses on ``flight`` (None: none).

    Raises
    ------
    FlightError
        ``air_data = "measured"`` on a flight without air data; a bad probe position or
        noise table.
    """
    parts = measured_air(est, flight)
    return None if parts is None else FemAirPlan(**parts)


def calibration_start(plan: FemAirPlan | None) -> np.ndarray:
    """The calibration's scaled start (zeros; none without air data)."""
    return np.zeros(0 if plan is None else len(plan.calibration))


def air_report(plan: FemAirPlan, cal: np.ndarray, cal_se: np.ndarray, noise_var: np.ndarray,
               who: str, flight: Flight) -> tuple[dict[str, Any], tuple[str, ...]]:
    """``info["air_data"]`` and the one-line notices.

    ``cal``, ``cal_se`` (n_cal,): the fitted calibration, physical; ``noise_var`` (k,): the
    probe's noise variances at the end.
    """
    k = len(plan.channels)
    calib = dict(zip(plan.calibration, np.asarray(cal, float).tolist(), strict=True))
    calib_se = dict(zip(plan.calibration, np.asarray(cal_se, float).tolist(), strict=True))
    noise = dict(zip(plan.channels, np.sqrt(noise_var[:k]).tolist(), strict=True))
    info: dict[str, Any] = {
        "channels": plan.channels, "calibration": calib, "calibration_stderr": calib_se,
        "noise_sd": noise, "noise": "the log's (held)" if plan.held else
        "from the data, re-estimated from the innovations",
        "probe_position_m": plan.probe.tolist(), "probe": plan.probe_where}
    shown = ", ".join(f"{c} {noise[c]:.3g} {UNITS[c]}" for c in plan.channels)
    text = "; ".join(f"{c} {v:+.4g} +- {calib_se[c]:.2g}" for c, v in calib.items()) or "none"
    verdict = estimation.air_data_verdict(flight, who)
    if verdict is not None:
        info["air_data_verdict"] = verdict.as_info()
    lines = (f"{who}: air data as measured outputs ({', '.join(plan.channels)}; "
             f"{plan.probe_where}); noise sd {shown} ({info['noise']}); calibration {text}",
             *(() if verdict is None else (verdict.line,)))
    return info, lines


__all__ = ["FemAirOption", "FemAirPlan", "air_plan", "air_report", "calibration_scales",
           "calibration_start"]
