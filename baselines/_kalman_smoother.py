"""An iterated extended Kalman smoother for the EKF's passes (issue 26; private).

Why: the EKF's passes with a steady wind walk along the dynamic pressure's ridge (module
docstring of :mod:`baselines._kalman_verdict`): each pass starts where the last ended,
linearises at its own running estimate and keeps what its first updates did. The
iterated extended Kalman smoother (Bell 1994, "The iterated Kalman smoother as a
Gauss-Newton method") linearises each pass along the previous pass's *smoothed*
trajectory (Rauch-Tung-Striebel) and starts every pass from the original prior: its
fixed point is the maximum a posteriori estimate of the whole record (Gauss-Newton on
it), so there is nothing to walk. Pass 1 (no trajectory yet) is the plain EKF, smoothed.

The forward filter is the EKF's (Joseph-form update, the same positive-definiteness
check, :func:`baselines._kalman.run_ekf`'s outputs), written out because the prediction
is affine about the trajectory (``x^- = f(xbar) + F (x - xbar)``), not filterpy's
``F x``; the backward pass is the RTS recursion ``x^s_k = x_k + C_k (x^s_{k+1} -
x^-_{k+1})``, ``C_k = P_k F_k^T (P^-_{k+1})^-1``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
from scipy import linalg

from baselines import _kalman


@dataclasses.dataclass(frozen=True)
class SmoothedOutput(_kalman.FilterOutput):
    """A forward pass (:class:`baselines._kalman.FilterOutput`) with its RTS-smoothed
    trajectory ``smoothed``, shape (n, dim_x) (None after a failure), and for the UKF's
    smoother (:mod:`baselines._kalman_ukf_smoother`) its covariances ``smoothed_cov``,
    shape (n, dim_x, dim_x)."""

    smoothed: np.ndarray | None = None
    smoothed_cov: np.ndarray | None = None


def run_eks(model: _kalman.DiscreteModel, x0: np.ndarray, P0: np.ndarray, Q: np.ndarray,
            R: np.ndarray, zs: np.ndarray, nominal: np.ndarray | None = None,
            R_of: Callable[[np.ndarray], np.ndarray] | None = None) -> SmoothedOutput:
    """One forward EKF pass linearised along ``nominal`` (n, dim_x) (None: along its own
    estimate, the EKF), then the RTS smoother.

    Arguments as :func:`baselines._kalman.run_ekf`.
    """
    with _kalman.collapsed_warnings():
        return _run_eks(model, x0, P0, Q, R, zs, nominal, R_of)


def _run_eks(model: _kalman.DiscreteModel, x0: np.ndarray, P0: np.ndarray, Q: np.ndarray,
             R: np.ndarray, zs: np.ndarray, nominal: np.ndarray | None,
             R_of: Callable[[np.ndarray], np.ndarray] | None) -> SmoothedOutput:
    n, dx, dz = zs.shape[0], model.dim_x, model.dim_z
    xs, sds = np.empty((n, dx)), np.empty((n, dx))
    x_pred, P_pred = np.empty((n, dx)), np.empty((n, dx, dx))
    P_filt, Fs = np.empty((n, dx, dx)), np.empty((n, dx, dx))
    innov, s_var, r_var = np.empty((n, dz)), np.empty((n, dz)), np.empty((n, dz))
    x, P, nll = np.asarray(x0, dtype=float).copy(), np.array(P0, dtype=float), 0.0
    eye = np.eye(dx)

    def failed(k: int, reason: str) -> SmoothedOutput:
        for a in (xs, sds, innov, s_var, r_var):
            a[k:] = np.nan
        return SmoothedOutput(xs, sds, P, k, reason, innov, s_var, r_var, np.nan, None)

    for k in range(n):
        if k > 0:
            at = x if nominal is None else nominal[k - 1]
            f_at, F = model.transition(at, k - 1)
            Fs[k - 1] = F
            x = f_at + F @ (x - at)
            P = F @ P @ F.T + Q
        x_pred[k], P_pred[k] = x, P
        at = x if nominal is None else nominal[k]
        h_at, H = model.observe(at, k)
        z_hat = h_at + H @ (x - at)
        R_k = R if R_of is None else R_of(z_hat)
        S = H @ P @ H.T + R_k
        e = zs[k] - z_hat
        K = linalg.solve(S, H @ P, assume_a="pos").T
        x = x + K @ e
        IKH = eye - K @ H
        P = IKH @ P @ IKH.T + K @ R_k @ K.T
        P = 0.5 * (P + P.T)
        innov[k], s_var[k], r_var[k] = e, np.diag(S), np.diag(R_k)
        nll += 0.5 * (np.linalg.slogdet(S)[1] + e @ np.linalg.solve(S, e))
        reason, P = _kalman._check(P, x)
        if reason:
            return failed(k, reason)
        xs[k], sds[k], P_filt[k] = x, np.sqrt(np.diag(P)), P
    smoothed = xs.copy()
    for k in range(n - 2, -1, -1):
        # equilibrated (unit diagonal): the states' variances span ~20 decades
        d = np.sqrt(np.diag(P_pred[k + 1]))
        C = (linalg.solve(P_pred[k + 1] / np.outer(d, d), (Fs[k] @ P_filt[k]) / d[:, None],
                          assume_a="pos") / d[:, None]).T
        smoothed[k] = xs[k] + C @ (smoothed[k + 1] - x_pred[k + 1])
    return SmoothedOutput(xs, sds, P, None, "", innov, s_var, r_var, float(nll), smoothed)
