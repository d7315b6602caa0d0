"""Masked measurements (saturated samples) in the filter loops (baselines._imu_states)."""

from __future__ import annotations

import numpy as np
import pytest

from baselines import _kalman
from baselines._imu_states import masked_output, with_mask

#: The filterpy loops against the hand-written filter below: the same algebra in another
#: order (the UKF's unscented transform of a linear model is exact).
LINEAR_KF_TOL = 1e-10


def _problem():
    rng = np.random.default_rng(7)
    A = np.array([[1.0, 0.1, 0.0], [0.0, 0.95, 0.1], [0.0, -0.1, 0.9]])
    C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 1.0]])
    Q = np.diag([1e-3, 2e-3, 1e-3])
    R = np.diag([0.04, 0.09, 0.05])
    n = 30
    x = np.array([1.0, -0.5, 0.3])
    zs = np.empty((n, 3))
    for k in range(n):
        zs[k] = C @ x + rng.normal(0, np.sqrt(np.diag(R)))
        x = A @ x + rng.multivariate_normal(np.zeros(3), Q)
    model = _kalman.DiscreteModel(3, 3, transition=lambda x, k: (A @ x, A),
                                  observe=lambda x, k: (C @ x, C),
                                  transition_batch=lambda X, k: X @ A.T,
                                  observe_batch=lambda X, k: X @ C.T)
    mask = np.ones((n, 3), dtype=bool)
    mask[4:9, 1] = False  # one channel saturated for a while
    mask[12, :] = False  # a sample with nothing in
    mask[20:22, [0, 2]] = False
    return model, A, C, Q, R, np.array([0.8, 0.0, 0.0]), np.diag([0.5, 0.5, 0.5]), zs, mask


def _textbook(A, C, Q, R, x0, P0, zs, mask):
    """The Kalman filter on each sample's measurements in, the others removed."""
    x, P = x0.copy(), P0.copy()
    xs, Ps = [], []
    for k, z in enumerate(zs):
        if k > 0:
            x, P = A @ x, A @ P @ A.T + Q
        u = mask[k]
        if u.any():
            Cu, Ru = C[u], R[np.ix_(u, u)]
            S = Cu @ P @ Cu.T + Ru
            K = np.linalg.solve(S, Cu @ P).T
            x = x + K @ (z[u] - Cu @ x)
            P = (np.eye(3) - K @ Cu) @ P
        xs.append(x)
        Ps.append(P)
    return np.array(xs), np.array(Ps)


@pytest.mark.parametrize("loop", [_kalman.run_ekf, _kalman.run_ukf])
def test_masked_filter_equals_filter_without_those_measurements(loop):
    model, A, C, Q, R, x0, P0, zs, mask = _problem()
    out = masked_output(loop(with_mask(model, zs, mask), x0, P0, Q, R, zs), mask)
    xs, Ps = _textbook(A, C, Q, R, x0, P0, zs, mask)
    assert out.failed_at is None
    np.testing.assert_allclose(out.x, xs, rtol=0, atol=LINEAR_KF_TOL)
    np.testing.assert_allclose(out.P, Ps[-1], rtol=0, atol=LINEAR_KF_TOL)
    assert np.all(np.isnan(out.innovation[~mask])) and np.all(np.isfinite(out.innovation[mask]))
    assert np.all(np.isnan(out.innovation_var[~mask]))
    # the mask matters: the unmasked filter ends elsewhere
    full = loop(model, x0, P0, Q, R, zs)
    assert np.max(np.abs(full.x[12] - out.x[12])) > 1e3 * LINEAR_KF_TOL
    # an all-True mask is the unmasked filter exactly
    same = loop(with_mask(model, zs, np.ones_like(mask)), x0, P0, Q, R, zs)
    np.testing.assert_array_equal(same.x, full.x)
