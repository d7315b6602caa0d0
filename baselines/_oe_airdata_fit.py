"""Output-error's air-data outputs in the fit: the problem, and what the result says.

:func:`airdata_problem` appends the flight's air-data channels (:mod:`baselines.
_oe_airdata`) to output-error's problem: measured values at every sample, one noise
variance per air-data channel re-estimated from the residuals (a probe's noise is
white and of one size; the IMU channels keep the estimator's ``noise_model``), the
calibration parameters without a prior. :func:`airdata_report` puts the calibration
(with standard errors), the probe's noise sd (with its standard error ``sd / sqrt(2 n)``,
the Cramér-Rao bound of a Gaussian sd from ``n`` residuals) and the residuals for the fit
check in ``info``, and returns the one-line notice of what was used.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

import aeroid
from aeroid.estimation import air_data_verdict, ignored_air_data_warning, verdict_of
from aeroid.flights import Flight
from aeroid.model import OUTPUT_CHANNELS
from baselines._gauss_newton import Problem
from baselines._oe_airdata import (
    AirDataModel,
    calibration_names,
    probe_position,
    used_channels,
)
from baselines._oe_constants import R_FLOOR_REL

#: Units of the air-data channels in the notice.
UNITS = {"alpha": "rad", "beta": "rad", "airspeed": "m/s"}


@dataclass(frozen=True)
class AirDataProblem(Problem):
    """A :class:`~baselines._gauss_newton.Problem` whose last ``n_air`` channels (the air
    data) each have one variance, the mean squared residual (floored)."""

    n_air: int = 0

    def noise(self, e: np.ndarray) -> np.ndarray:
        """:meth:`Problem.noise` for the IMU channels, one variance per air-data channel."""
        var = np.array(np.broadcast_to(super().noise(e), e.shape))
        for c in range(e.shape[1] - self.n_air, e.shape[1]):
            var[:, c] = max(float(np.mean(e[:, c] ** 2)), float(self.r_floor[c]))
        return var


def airdata_problem(est: Any, flight: Flight, prob: Problem) -> Problem:
    """``prob`` with the air-data outputs ``est`` uses on ``flight`` (none: ``prob``).

    Raises
    ------
    EstimatorError
        Air data with aiding, coefficient tables or an estimated delay (not built).
    FlightError
        ``air_data = "measured"`` without air data; a bad probe position.
    """
    channels = used_channels(est, flight)
    if not channels:
        return prob
    base = prob.model
    for on, what in ((getattr(est, "aiding", "none") != "none", f"aiding = {est.aiding}"),
                     (getattr(base, "tables", None) is not None, "coefficient tables"),
                     (est.estimate_delay, "estimate_delay")):
        if on:
            raise aeroid.EstimatorError(f"output-error: air_data = {est.air_data} with {what} "
                                        "is not built; set air_data = inertial")
    names = calibration_names(est, channels)
    probe, _ = probe_position(flight)
    model = AirDataModel(base, channels, names, probe)
    z = np.column_stack([flight[c] for c in channels])
    n_cal = len(names)

    def extend(a: np.ndarray | None) -> np.ndarray | None:  # no prior on the calibration
        return None if a is None else np.concatenate([a, np.zeros(n_cal)])
    return AirDataProblem(z=np.hstack([prob.z, z]), model=model,
                          r_floor=np.concatenate([prob.r_floor, R_FLOOR_REL * np.mean(
                              z * z, axis=0) + 1e-300]),
                          noise_model=prob.noise_model, prior_mean=extend(prob.prior_mean),
                          prior_weight=extend(prob.prior_weight), n_air=len(channels))


def airdata_report(est: Any, flight: Flight, prob: Problem, e: np.ndarray, phys: np.ndarray,
                   stderr: np.ndarray, info: dict[str, Any]) -> list[str]:
    """Put the air-data fit in ``info`` and return its one-line notice (or the warning
    that the flight's air data were ignored, or nothing).

    ``info["air_data"]``: the channels, the calibration (``{name: value}``, with
    ``calibration_stderr``), the probe's noise sd per channel and its standard error, the
    probe position and how it was found; the residuals go to ``info["fit_residuals"]``.
    """
    if not isinstance(prob, AirDataProblem):
        ignored = ignored_air_data_warning(flight, est.name)
        return [ignored] if ignored else []
    model: AirDataModel = prob.model  # type: ignore[assignment]
    m, n = len(OUTPUT_CHANNELS), e.shape[0]
    air = e[:, m:]
    sd = np.sqrt(np.mean(air * air, axis=0))
    noise = dict(zip(model.channels, sd.tolist(), strict=True))
    noise_se = {c: s / np.sqrt(2.0 * n) for c, s in noise.items()}
    cal = dict(zip(model.calibration, phys[model.n_base:].tolist(), strict=True))
    cal_se = dict(zip(model.calibration, stderr[model.n_base:].tolist(), strict=True))
    _, where = probe_position(flight)
    info["fit_residuals"] = {**info.get("fit_residuals", {}),
                             **{c: air[:, j] for j, c in enumerate(model.channels)}}
    info["air_data"] = {"channels": model.channels, "calibration": cal,
                        "calibration_stderr": cal_se, "noise_sd": noise,
                        "noise_sd_stderr": noise_se, "probe_position_m": model.probe.tolist(),
                        "probe": where}
    shown = ", ".join(f"{c} {noise[c]:.3g} +- {noise_se[c]:.2g} {UNITS[c]}"
                      for c in model.channels)
    calib = "; ".join(f"{k} {v:+.4g} +- {cal_se[k]:.2g}" for k, v in cal.items()) or "none"
    lines = [f"output-error: air data as measured outputs ({', '.join(model.channels)}; "
             f"{where}); probe noise sd {shown}; calibration {calib}"]
    if est.estimate_wind:  # what the steady wind and the calibration leave, in m/s
        speed = np.mean(flight["airspeed"] if "airspeed" in model.channels else
                        np.sqrt(sum(flight[c] ** 2 for c in ("u", "v", "w"))))
        rest = air * np.array([1.0 if c == "airspeed" else speed for c in model.channels])
        verdict = verdict_of(flight, est.name, rest, np.array(info["wind_ned_mps"]),
                             np.array(info["wind_stderr_mps"]),
                             source=" after the fitted steady wind and calibration")
    else:  # wind or turbulence, from the log alone
        verdict = air_data_verdict(flight, est.name)
    if verdict is not None:
        info["air_data_verdict"] = verdict.as_info()
        lines.append(verdict.line)
    return lines


__all__ = ["AirDataProblem", "airdata_problem", "airdata_report"]
