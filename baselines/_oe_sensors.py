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
from aeroid.flights import IMU_ERROR_KINDS, Flight
from baselines._common import reconstruction_sd
from baselines._tables_fit import coefficient_layout

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
            for prefix in IMU_ERROR_KINDS[imu_errors]]


def initial_velocity_sd(flight: Flight) -> np.ndarray:
    """The sd [m/s] of ``u, v, w`` at the first sample from ``metadata['initial_state_sd']``."""
    sd = reconstruction_sd(flight, VELOCITY_NAMES)
    if sd is None:
        raise aeroid.FlightError(
            f"{flight.metadata.get('source', 'flight')}: initial_velocity_prior = flight "
            "needs metadata initial_state_sd with positive u, v, w [m/s] (a reconstruction's "
            f"flight has them); got {flight.metadata.get('initial_state_sd')!r}")
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


def consider_covariance(est: Any, flight: Flight, best: Any, scale: np.ndarray) -> np.ndarray:
    """Output-error's uncertain positions' share of the covariance (Schmidt consider analysis).

    ``S C S^T`` with ``S = -M^-1 M_pc`` the sensitivity of the estimate to the
    considered components (``M_pc = J_p^T R^-1 J_c`` at the optimum) and ``C`` their
    prior covariance; in physical units, shape (n_p, n_p).
    """
    sd = flight.airframe.accel_position_sd.ravel()
    considered = [int(c) for c in np.flatnonzero(sd > 0)]
    if not considered:
        return np.zeros((scale.size, scale.size))
    wide_free = tuple(sorted(set(considered) | {3 * t for t in est.rx_free()}))
    wide = est.problem(flight, position_free=wide_free).model
    first = wide.n_theta + len(est.x0_free())
    p = np.zeros(wide.scale.size)
    p[:first] = best.p[:first]  # the considered offsets at 0: the given positions
    n_rest = best.p.size - first - len(est.position_free(flight))  # delay, IMU errors
    if n_rest:
        p[-n_rest:] = best.p[-n_rest:]
    _, J = wide.outputs_jacobian(p)
    columns = [first + wide_free.index(c) for c in considered]
    w = 1.0 / np.sqrt(np.broadcast_to(best.r_diag, best.e.shape)).T  # (m, n)
    Jc = (J[:, :, columns] * (sd[considered] / wide.scale[columns]) * w[:, :, None])
    Jp = best.J * w[:, :, None]
    Jp_flat, Jc_flat = Jp.reshape(-1, Jp.shape[-1]), Jc.reshape(-1, len(considered))
    S = -np.linalg.solve(Jp_flat.T @ Jp_flat, Jp_flat.T @ Jc_flat)  # per unit sd
    return (S @ S.T) * np.outer(scale, scale)


def position_report(est: Any, model: Any, phys: np.ndarray, stderr: np.ndarray
                    ) -> dict[str, np.ndarray]:
    """Return the fitted accelerometer positions and initial state of an output-error fit.

    ``accel_positions_m`` and ``accel_position_stderr_m`` (2, 3) and ``initial_state`` (the
    record model's start with the estimated components added; used by
    :meth:`aeroid.estimation.EstimationResult.predict`).
    """
    n_c = model.n_theta
    first_pos = n_c + len(est.x0_free())
    positions = model.pos.copy()
    position_sd = np.zeros(6)
    for j, c in enumerate(model.position_free):
        positions[c] += phys[first_pos + j]
        position_sd[c] = stderr[first_pos + j]
    start = model.x0.copy()
    start[list(est.x0_free())] += phys[n_c:first_pos]
    return {"accel_positions_m": positions.reshape(2, 3),
            "accel_position_stderr_m": position_sd.reshape(2, 3), "initial_state": start}


def prior_weights(est: Any, flight: Flight, scale: np.ndarray,
                  position_free: tuple[int, ...]) -> np.ndarray:
    """Return the weights of output-error's Gaussian priors on its scaled parameters.

    Uncertain position components estimated under ``positions="estimate"`` (their sd
    from the airframe) and, with ``initial_velocity_prior="flight"``, the initial
    ``u, v, w`` (their sd from the flight's metadata); zero elsewhere (no prior).
    """
    weight = np.zeros(scale.size)
    n_c = len(coefficient_layout(flight)[0])  # with [tables]: their parameters
    pos_sd = flight.airframe.accel_position_sd.ravel()
    if est.positions == "estimate":
        first = n_c + len(est.x0_free())
        for j, c in enumerate(position_free):
            if pos_sd[c] > 0:
                weight[first + j] = (scale[first + j] / pos_sd[c]) ** 2  # = 1
    if est.initial_velocity_prior == "flight":
        sd = initial_velocity_sd(flight)
        states = [aeroid.model.STATE_NAMES.index(name) for name in VELOCITY_NAMES]
        for j, i in enumerate(est.x0_free()):
            if i in states:
                weight[n_c + j] = (scale[n_c + j] / sd[states.index(i)]) ** 2
    return weight
