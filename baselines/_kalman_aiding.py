"""GNSS velocity as sparse measurements of the augmented-state EKF and UKF (private).

``aiding = "gnss-velocity"`` (:class:`baselines._imu_states.ImuFilterOptions`): the filter's
measurement gains three rows ``vn ve vd = C_nb(phi, theta, psi) [u v w]`` of its own state
(:func:`baselines._oe_aiding.ned_velocity`, exact Jacobian), measured only at the GNSS
samples (:func:`baselines._oe_aiding.aiding_samples`: on the flight's grid); between them
the rows are masked (:func:`baselines._imu_states.with_mask`: no information). Their noise
variance is the log's stated sd squared, fixed through every pass (the IMU channels' noise
law is refitted as before).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from aeroid.model import N_STATE
from baselines import _common, _kalman
from baselines._oe_aiding import AidingSamples, ned_velocity


def with_ned_velocity(model: _kalman.DiscreteModel) -> _kalman.DiscreteModel:
    """``model`` with ``C_nb [u v w]`` of its state appended to its measurement."""
    observe, observe_batch = model.observe, model.observe_batch

    def observe_aided(x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        y, H = observe(x, k)
        v, dv = ned_velocity(x[None, :])
        rows = np.zeros((3, model.dim_x))
        rows[:, :N_STATE] = dv[0]
        return np.concatenate([y, v[0]]), np.vstack([H, rows])

    def batch_aided(X: np.ndarray, k: int) -> np.ndarray:
        assert observe_batch is not None
        return np.hstack([observe_batch(X, k), ned_velocity(X)[0]])

    return dataclasses.replace(model, dim_z=model.dim_z + 3, observe=observe_aided,
                               observe_batch=None if observe_batch is None else batch_aided)


def aided_setup(setup: _common.FilterSetup, samples: AidingSamples) -> _common.FilterSetup:
    """``setup`` with the GNSS velocity appended: measurements (0 between samples: masked),
    the stated variances as a fixed noise law (``b = 0``)."""
    n = setup.zs.shape[0]
    z = np.zeros((n, 3))
    z[samples.index] = samples.z
    var = samples.sd ** 2
    a, b = setup.law
    return setup._replace(zs=np.hstack([setup.zs, z]),
                          R=np.diag(np.concatenate([np.diag(setup.R), var])),
                          meas_sd=np.concatenate([setup.meas_sd, samples.sd]),
                          law=(np.concatenate([a, var]), np.concatenate([b, np.zeros(3)])),
                          r_floor=np.concatenate([setup.r_floor, var]))


def aided_mask(mask: np.ndarray | None, n: int, m: int, samples: AidingSamples) -> np.ndarray:
    """The measurements in the likelihood: the IMU's (``mask``, or all), the GNSS's at its
    samples, shape (n, m + 3)."""
    aid = np.zeros((n, 3), bool)
    aid[samples.index] = True
    return np.hstack([np.ones((n, m), bool) if mask is None else mask, aid])


def first_channels(out: _kalman.FilterOutput, m: int) -> _kalman.FilterOutput:
    """A pass's output restricted to its first ``m`` measurement channels (the IMU's)."""
    def cut(a: np.ndarray | None) -> np.ndarray | None:
        return None if a is None else a[:, :m]

    return dataclasses.replace(out, innovation=cut(out.innovation),
                               innovation_var=cut(out.innovation_var),
                               noise_var=cut(out.noise_var))
