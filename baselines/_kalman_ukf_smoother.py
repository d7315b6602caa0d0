"""The UKF's smoothed passes: iterated posterior linearisation (issue 26; private).

The EKF's smoothed passes (:mod:`baselines._kalman_smoother`, Bell 1994) linearise each
pass along the previous pass's smoothed trajectory and start it from the original prior;
their fixed point is the record's MAP, so the along-path wind cannot walk as it does
with carried passes. The UKF's counterpart is the iterated posterior linearisation
smoother (García-Fernández, Svensson, Särkkä 2017, "Iterated posterior linearization
smoother", IEEE TAC 62(4)): each pass replaces the transition and the measurement by
their statistical linear regressions (SLR) on the sigma points of the previous pass's
*smoothed* posterior ``N(x^s_k, P^s_k)``::

    f(x) ~ A x + b + e,  A = P_xy' P^-1,  b = ybar - A m,  cov e = Omega = P_yy - A P A'

(``ybar``, ``P_xy``, ``P_yy`` the sigma points' weighted mean and covariances, filterpy's
Merwe scaled points and weights), runs the Kalman filter of that affine model from the
original prior (``Omega`` added to ``Q``, the measurement's ``Lambda`` to ``R``) and the
Rauch-Tung-Striebel smoother with covariances. Pass 1 linearises at the filter's own
prior and posterior: the plain UKF (sigma points of ``N(x_k, P_k)`` for the prediction,
of ``N(x^-_k, P^-_k)`` for the update), smoothed.

The states' variances span ~20 decades (coefficients, velocities, wind): the square root
and the regressions' solves are equilibrated (unit diagonal).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints
from scipy import linalg

from baselines import _kalman
from baselines._kalman_smoother import SmoothedOutput


def _sqrt(P: np.ndarray) -> np.ndarray:
    """``L`` with ``L L' = P`` (equilibrated Cholesky; eigenvalues clipped at rounding's
    level when it fails, as :func:`baselines._kalman._check` does)."""
    d = np.sqrt(np.maximum(np.diag(P), 1e-300))
    C = P / np.outer(d, d)
    try:
        return d[:, None] * np.linalg.cholesky(C)
    except np.linalg.LinAlgError:
        eig, vec = np.linalg.eigh(0.5 * (C + C.T))
        eig = np.maximum(eig, _kalman.ROUNDING_RTOL * eig[-1])
        return d[:, None] * (vec * np.sqrt(eig))


def _solve_pd(P: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``P^-1 B`` for a positive definite ``P`` of any scaling (equilibrated)."""
    d = np.sqrt(np.maximum(np.diag(P), 1e-300))
    return linalg.solve(P / np.outer(d, d), B / d[:, None], assume_a="pos") / d[:, None]


def slr(fun: Callable[[np.ndarray, int], np.ndarray], m: np.ndarray, P: np.ndarray, k: int,
        points: MerweScaledSigmaPoints) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The statistical linear regression ``(A, b, Omega)`` of ``fun(., k)`` (batched: (n,
    dim) -> (n, out)) on the sigma points of ``N(m, P)``."""
    n = m.size
    lam = points.alpha**2 * (n + points.kappa) - n
    U = _sqrt((n + lam) * P).T  # rows: the offsets
    X = np.concatenate([m[None, :], m + U, m - U])
    Y = np.asarray(fun(X, k), dtype=float)
    ybar = points.Wm @ Y
    dX, dY = X - m, Y - ybar
    Pxy = (points.Wc[:, None] * dX).T @ dY
    Pyy = (points.Wc[:, None] * dY).T @ dY
    A = _solve_pd(P, Pxy).T
    omega = Pyy - A @ P @ A.T
    return A, ybar - A @ m, 0.5 * (omega + omega.T)


def run_ipls(model: _kalman.DiscreteModel, x0: np.ndarray, P0: np.ndarray, Q: np.ndarray,
             R: np.ndarray, zs: np.ndarray, nominal: tuple[np.ndarray, np.ndarray] | None = None,
             R_of: Callable[[np.ndarray], np.ndarray] | None = None, *, alpha: float = 0.5,
             beta: float = 2.0, kappa: float = 0.0) -> SmoothedOutput:
    """One pass linearised on the smoothed posterior ``nominal = (means (n, dim_x), covs
    (n, dim_x, dim_x))`` (None: at the filter's own, the UKF), then the RTS smoother
    with covariances. Arguments as :func:`baselines._kalman.run_ukf`."""
    if model.transition_batch is None or model.observe_batch is None:
        raise ValueError("run_ipls: the model needs transition_batch and observe_batch")
    with _kalman.collapsed_warnings():
        return _run_ipls(model, x0, P0, Q, R, zs, nominal, R_of,
                         MerweScaledSigmaPoints(model.dim_x, alpha=alpha, beta=beta,
                                                kappa=kappa))


def _run_ipls(model: _kalman.DiscreteModel, x0: np.ndarray, P0: np.ndarray, Q: np.ndarray,
              R: np.ndarray, zs: np.ndarray, nominal: tuple[np.ndarray, np.ndarray] | None,
              R_of: Callable[[np.ndarray], np.ndarray] | None,
              points: MerweScaledSigmaPoints) -> SmoothedOutput:
    assert model.transition_batch is not None and model.observe_batch is not None
    n, dx, dz = zs.shape[0], model.dim_x, model.dim_z
    xs, sds = np.empty((n, dx)), np.empty((n, dx))
    x_pred, P_pred = np.empty((n, dx)), np.empty((n, dx, dx))
    P_filt, As = np.empty((n, dx, dx)), np.empty((n, dx, dx))
    innov, s_var, r_var = np.empty((n, dz)), np.empty((n, dz)), np.empty((n, dz))
    x, P, nll = np.asarray(x0, dtype=float).copy(), np.array(P0, dtype=float), 0.0
    eye = np.eye(dx)

    def failed(k: int, reason: str) -> SmoothedOutput:
        for a in (xs, sds, innov, s_var, r_var):
            a[k:] = np.nan
        return SmoothedOutput(xs, sds, P, k, reason, innov, s_var, r_var, np.nan, None)

    for k in range(n):
        try:
            if k > 0:
                m, C = (x, P) if nominal is None else (nominal[0][k - 1], nominal[1][k - 1])
                A, b, omega = slr(model.transition_batch, m, C, k - 1, points)
                As[k - 1] = A
                x = A @ x + b
                P = A @ P @ A.T + Q + omega
                P = 0.5 * (P + P.T)
            x_pred[k], P_pred[k] = x, P
            m, C = (x, P) if nominal is None else (nominal[0][k], nominal[1][k])
            H, d, lam = slr(model.observe_batch, m, C, k, points)
            z_hat = H @ x + d
            R_k = R if R_of is None else R_of(z_hat)
            S = H @ P @ H.T + R_k + lam
            e = zs[k] - z_hat
            K = linalg.solve(S, H @ P, assume_a="pos").T
        except (np.linalg.LinAlgError, ValueError) as exc:  # not positive definite
            return failed(k, f"sigma-point linearisation failed ({exc})")
        x = x + K @ e
        IKH = eye - K @ H
        P = IKH @ P @ IKH.T + K @ (R_k + lam) @ K.T
        P = 0.5 * (P + P.T)
        innov[k], s_var[k], r_var[k] = e, np.diag(S), np.diag(R_k)
        nll += 0.5 * (np.linalg.slogdet(S)[1] + e @ np.linalg.solve(S, e))
        reason, P = _kalman._check(P, x)
        if reason:
            return failed(k, reason)
        xs[k], sds[k], P_filt[k] = x, np.sqrt(np.diag(P)), P
    smoothed, covs = xs.copy(), P_filt.copy()
    for k in range(n - 2, -1, -1):
        G = _solve_pd(P_pred[k + 1], As[k] @ P_filt[k]).T
        smoothed[k] = xs[k] + G @ (smoothed[k + 1] - x_pred[k + 1])
        cov = P_filt[k] + G @ (covs[k + 1] - P_pred[k + 1]) @ G.T
        covs[k] = 0.5 * (cov + cov.T)
    return SmoothedOutput(xs, sds, P, None, "", innov, s_var, r_var, float(nll), smoothed,
                          covs)
