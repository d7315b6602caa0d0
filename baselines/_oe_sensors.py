"""Output-error's IMU-error parameters and initial-velocity prior: scales, sd, report (private).

The sensor law itself is applied in the record model (:mod:`baselines._oe_record`); this
module holds what the estimator needs around it: the parameters' scaling, the initial
velocity's sd from a reconstruction's flight, and the ``info`` entries and warnings of a
fit that estimated them.
"""

from __future__ import annotations

from typing import Any

import numpy as np

import aeroid
from aeroid.estimation import nuisance_findings
from aeroid.flights import Flight
from baselines._oe_record import IMU_ERRORS

#: Scaling of the IMU-error parameters (conditioning only, no prior): a bias over this
#: fraction of its channel's RMS (1 for a channel that is all zeros), a scale factor over
#: this.
IMU_ERROR_SCALE = 1e-3
#: Names of the initial velocity components in ``metadata['initial_state_sd']``.
VELOCITY_NAMES = ("u", "v", "w")
#: The warning of a fit that holds a velocity whose sd the flight states.
HELD_VELOCITY_WARNING = (
    "output-error: the initial u v w are taken as the flight's, which carries their sd (a "
    "reconstruction's): an error of that size biases the coefficients beyond their "
    "standard errors (up to 39 sd on the reference suite, "
    "benchmarks/bench_suite_estimation.py); estimate them: estimate_initial_velocity = "
    "true, initial_velocity_prior = flight")


def imu_error_scales(z: np.ndarray, imu_errors: str) -> list[np.ndarray]:
    """The scales of the IMU-error parameters for measurements ``z`` (n, m), in order."""
    rms = np.sqrt(np.mean(z * z, axis=0))
    rms = np.where(rms > 0, rms, 1.0)
    return [IMU_ERROR_SCALE * (rms if prefix == "b" else np.ones_like(rms))
            for prefix in IMU_ERRORS[imu_errors]]


def initial_velocity_sd(flight: Flight) -> np.ndarray:
    """The sd [m/s] of ``u, v, w`` at the first sample from ``metadata['initial_state_sd']``."""
    given = flight.metadata.get("initial_state_sd")
    try:
        sd = np.array([float(given[n]) for n in VELOCITY_NAMES])  # type: ignore[index]
    except (TypeError, KeyError, ValueError):
        sd = np.array([np.nan])
    if not np.all(np.isfinite(sd) & (sd > 0)):
        raise aeroid.FlightError(
            f"{flight.metadata.get('source', 'flight')}: initial_velocity_prior = flight "
            "needs metadata initial_state_sd with positive u, v, w [m/s] (a reconstruction's "
            f"flight has them); got {given!r}")
    return sd


def imu_error_report(names: tuple[str, ...], imu_names: tuple[str, ...], phys: np.ndarray,
                     stderr: np.ndarray, cov: np.ndarray) -> tuple[dict[str, Any], tuple]:
    """``info`` entries (``imu_errors``, ``imu_error_stderr``) and the confounding warnings.

    ``names``, ``phys``, ``stderr``, ``cov``: all the fit's parameters, the IMU errors last.
    """
    k = len(imu_names)
    info = {"imu_errors": dict(zip(imu_names, phys[-k:].tolist(), strict=True)),
            "imu_error_stderr": dict(zip(imu_names, stderr[-k:].tolist(), strict=True))}
    return info, nuisance_findings(names, phys, cov, imu_names)
