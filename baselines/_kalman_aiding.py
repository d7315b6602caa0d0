"""Aiding sensors as sparse measurements of the augmented-state EKF and UKF (private).

``aiding = "gnss-velocity"`` (:class:`baselines._imu_states.ImuFilterOptions`): the filter's
measurement gains three rows ``vn ve vd = C_nb(phi, theta, psi) [u v w]`` of its own state
(:func:`baselines._oe_aiding.ned_velocity`, exact Jacobian), measured only at the GNSS
samples (:func:`baselines._oe_aiding.aiding_samples`: on the flight's grid); between them
the rows are masked (:func:`baselines._imu_states.with_mask`: no information). Their noise
variance is the log's stated sd squared, fixed through every pass (the IMU channels' noise
law is refitted as before). ``"gnss-velocity+ins-attitude"`` adds three rows ``phi theta
psi`` at the INS samples the same way, on the circle (:func:`baselines._oe_aiding.on_circle`:
the innovation wrapped to (-pi, pi]).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from aeroid.model import N_STATE
from baselines import _common, _kalman
from baselines._oe_aiding import AidingSamples, on_circle, predicted


def with_aiding(model: _kalman.DiscreteModel, samples: tuple[AidingSamples, ...]
                ) -> _kalman.DiscreteModel:
    """``model`` with each source's prediction of its state appended to its measurement
    (:func:`~baselines._oe_aiding.predicted`; the INS's on the circle of its sample at
    step ``k``)."""
    observe, observe_batch = model.observe, model.observe_batch
    n = 1 + max((int(s.index.max()) for s in samples if s.index.size), default=0)
    rows = []
    for s in samples:  # the sample at each step (-1: none)
        row = np.full(n, -1)
        row[s.index] = np.arange(s.index.size)
        rows.append(row)

    def extra(X: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        ys, ds = [], []
        for s, row in zip(samples, rows, strict=True):
            y, dy = predicted(s.source, X)
            if k < n and row[k] >= 0:
                y = on_circle(s._replace(z=s.z[row[k]][None, :]), y)
            ys.append(y)
            ds.append(dy)
        return np.hstack(ys), np.concatenate(ds, axis=1)

    def observe_aided(x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        y, H = observe(x, k)
        v, dv = extra(x[None, :], k)
        more = np.zeros((dv.shape[1], model.dim_x))
        more[:, :N_STATE] = dv[0]
        return np.concatenate([y, v[0]]), np.vstack([H, more])

    def batch_aided(X: np.ndarray, k: int) -> np.ndarray:
        assert observe_batch is not None
        return np.hstack([observe_batch(X, k), extra(X, k)[0]])

    return dataclasses.replace(model, dim_z=model.dim_z + 3 * len(samples),
                               observe=observe_aided,
                               observe_batch=None if observe_batch is None else batch_aided)


def with_ned_velocity(model: _kalman.DiscreteModel) -> _kalman.DiscreteModel:
    """``model`` with ``C_nb [u v w]`` of its state appended (:func:`with_aiding`, GNSS)."""
    return with_aiding(model, (AidingSamples(np.zeros(0, int), np.zeros((0, 3)),
                                             np.ones(3), "gnss"),))


def aided_setup(setup: _common.FilterSetup, samples: tuple[AidingSamples, ...]
                ) -> _common.FilterSetup:
    """``setup`` with the aiding sources appended: measurements (0 between samples:
    masked), the stated variances as a fixed noise law (``b = 0``)."""
    n = setup.zs.shape[0]
    z = np.zeros((n, 3 * len(samples)))
    for j, s in enumerate(samples):
        z[s.index, 3 * j:3 * j + 3] = s.z
    var = np.concatenate([s.sd ** 2 for s in samples])
    a, b = setup.law
    return setup._replace(zs=np.hstack([setup.zs, z]),
                          R=np.diag(np.concatenate([np.diag(setup.R), var])),
                          meas_sd=np.concatenate([setup.meas_sd, np.sqrt(var)]),
                          law=(np.concatenate([a, var]), np.concatenate([b, 0.0 * var])),
                          r_floor=np.concatenate([setup.r_floor, var]))


def aided_mask(mask: np.ndarray | None, n: int, m: int, samples: tuple[AidingSamples, ...]
               ) -> np.ndarray:
    """The measurements in the likelihood: the IMU's (``mask``, or all), each source's at
    its samples, shape (n, m + 3 n_src)."""
    aid = np.zeros((n, 3 * len(samples)), bool)
    for j, s in enumerate(samples):
        aid[s.index, 3 * j:3 * j + 3] = True
    return np.hstack([np.ones((n, m), bool) if mask is None else mask, aid])


def first_channels(out: _kalman.FilterOutput, m: int) -> _kalman.FilterOutput:
    """A pass's output restricted to its first ``m`` measurement channels (the IMU's)."""
    def cut(a: np.ndarray | None) -> np.ndarray | None:
        return None if a is None else a[:, :m]

    return dataclasses.replace(out, innovation=cut(out.innovation),
                               innovation_var=cut(out.innovation_var),
                               noise_var=cut(out.noise_var))
