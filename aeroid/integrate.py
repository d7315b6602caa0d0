"""Fixed-step fourth-order Runge-Kutta integration, batched over trajectories.

Two layers:

* :func:`rk4` integrates any batched right-hand side ``fun(t, x, *args)`` with numpy.
* :func:`propagate` integrates the airframe model (:mod:`aeroid.dynamics`) for many
  coefficient sets at once with the fin deflection held constant over each sample
  interval (zero-order hold of the measured ``delta``). This is the hot loop of the
  output-error estimators (EAM-PSO: ~400 passes over 450 coefficient sets), so it has a
  compiled backend (numba, ``parallel=True``: one thread per group of coefficient sets)
  and a pure-numpy backend that gives the same numbers (tested to 1e-10 relative) for
  readers and for platforms without numba.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from aeroid.dynamics import N_STATE, Constants, state_derivative

try:  # numba is a runtime dependency, but the numpy path must work without it
    import numba

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover - exercised only where numba is missing
    HAVE_NUMBA = False


def rk4_step(fun: Callable[..., np.ndarray], t: float, x: np.ndarray, dt: float,
             *args: Any) -> np.ndarray:
    """Return one classical RK4 step of ``dx/dt = fun(t, x, *args)`` (batched ``x``)."""
    k1 = fun(t, x, *args)
    k2 = fun(t + 0.5 * dt, x + 0.5 * dt * k1, *args)
    k3 = fun(t + 0.5 * dt, x + 0.5 * dt * k2, *args)
    k4 = fun(t + dt, x + dt * k3, *args)
    return x + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def rk4(fun: Callable[..., np.ndarray], x0: np.ndarray, t0: float, dt: float, n_steps: int,
        *args: Any) -> np.ndarray:
    """Integrate ``dx/dt = fun(t, x, *args)`` with ``n_steps`` fixed RK4 steps.

    Parameters
    ----------
    fun : callable
        Batched right-hand side returning an array shaped like ``x``.
    x0 : ndarray, shape (..., n)
    t0, dt : float
        Start time and step [s].
    n_steps : int

    Returns
    -------
    ndarray, shape (n_steps + 1, ..., n)
        The state at ``t0 + k dt``, ``k = 0..n_steps``.
    """
    x = np.asarray(x0, dtype=float)
    out = np.empty((n_steps + 1, *x.shape))
    out[0] = x
    for k in range(n_steps):
        x = rk4_step(fun, t0 + k * dt, x, dt, *args)
        out[k + 1] = x
    return out


def _model_rhs(_t: float, x: np.ndarray, delta: float, coefficients: np.ndarray,
               const: Constants) -> np.ndarray:
    return state_derivative(x, delta, coefficients, const)


def _propagate_numpy(state0: np.ndarray, coefficients: np.ndarray, delta: np.ndarray,
                     dt: float, const: Constants, substeps: int) -> np.ndarray:
    n_sets, n_samples = state0.shape[0], delta.shape[0] + 1
    out = np.empty((n_sets, n_samples, N_STATE))
    x = state0.copy()
    out[:, 0] = x
    h = dt / substeps
    for k in range(n_samples - 1):
        for _ in range(substeps):
            x = rk4_step(_model_rhs, 0.0, x, h, delta[k], coefficients, const)
        out[:, k + 1] = x
    return out


if HAVE_NUMBA:

    @numba.njit(cache=True, fastmath=False)
    def _rhs_scalar(x, c, delta, k, out):  # pragma: no cover - compiled
        # k = (rho, area, diameter, mass, ix, iy, iz, thrust, gravity): Constants order
        u, v, w, p, q, r, phi, theta = x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7]
        speed = math.sqrt(u * u + v * v + w * w)
        alpha = math.atan2(w, u)
        beta = math.asin(v / speed)
        qs = 0.5 * k[0] * speed * speed * k[1]
        qsd = qs * k[2]
        kd = k[2] / (2.0 * speed)
        fax = qs * c[0]
        fay = qs * (c[1] * beta - c[3] * kd * r)
        faz = qs * (c[1] * alpha + c[2] * delta + c[3] * kd * q)
        mx = qsd * (c[4] + c[5] * kd * p)
        my = qsd * (c[6] * alpha + c[7] * delta + c[8] * kd * q)
        mz = qsd * (-c[6] * beta + c[8] * kd * r)
        g = k[8]
        sphi, cphi = math.sin(phi), math.cos(phi)
        sth, cth = math.sin(theta), math.cos(theta)
        out[0] = r * v - q * w - g * sth + (fax + k[7]) / k[3]
        out[1] = -r * u + p * w + g * cth * sphi + fay / k[3]
        out[2] = q * u - p * v + g * cth * cphi + faz / k[3]
        out[3] = mx / k[4]
        out[4] = (k[6] - k[4]) / k[5] * p * r + my / k[5]
        out[5] = (k[4] - k[5]) / k[6] * p * q + mz / k[6]
        out[6] = p + (q * sphi + r * cphi) * sth / cth
        out[7] = q * cphi - r * sphi
        out[8] = (q * sphi + r * cphi) / cth

    @numba.njit(cache=True, parallel=True, fastmath=False)
    def _propagate_numba(state0, coefficients, delta, dt, k, substeps):  # pragma: no cover
        n_sets = state0.shape[0]
        n_samples = delta.shape[0] + 1
        out = np.empty((n_sets, n_samples, 9))
        h = dt / substeps
        for i in numba.prange(n_sets):
            c = coefficients[i]
            x = state0[i].copy()
            k1 = np.empty(9)
            k2 = np.empty(9)
            k3 = np.empty(9)
            k4 = np.empty(9)
            tmp = np.empty(9)
            out[i, 0] = x
            for s in range(n_samples - 1):
                d = delta[s]
                for _ in range(substeps):
                    _rhs_scalar(x, c, d, k, k1)
                    for j in range(9):
                        tmp[j] = x[j] + 0.5 * h * k1[j]
                    _rhs_scalar(tmp, c, d, k, k2)
                    for j in range(9):
                        tmp[j] = x[j] + 0.5 * h * k2[j]
                    _rhs_scalar(tmp, c, d, k, k3)
                    for j in range(9):
                        tmp[j] = x[j] + h * k3[j]
                    _rhs_scalar(tmp, c, d, k, k4)
                    for j in range(9):
                        x[j] = x[j] + (h / 6.0) * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
                out[i, s + 1] = x
        return out


def propagate(state0: np.ndarray, coefficients: np.ndarray, delta: np.ndarray, dt: float,
              const: Constants, *, substeps: int = 1, backend: str = "auto") -> np.ndarray:
    """Integrate the airframe model for many coefficient sets with RK4.

    Parameters
    ----------
    state0 : ndarray, shape (9,) or (n_sets, 9)
        Initial state(s) [m/s, rad/s, rad]; one state is shared by all sets.
    coefficients : ndarray, shape (9,) or (n_sets, 9)
    delta : ndarray, shape (n_samples - 1,)
        Fin deflection [rad] held constant over each sample interval
        ``[t_k, t_k + dt)`` (zero-order hold of the recorded ``delta``).
    dt : float
        Sample interval [s].
    const : Constants
    substeps : int
        RK4 steps per sample interval.
    backend : {"auto", "numba", "numpy"}
        ``auto`` takes numba when it is installed.

    Returns
    -------
    ndarray, shape (n_sets, n_samples, 9)
        The state at every sample. A set whose trajectory diverges gives non-finite
        values (never an exception), which the estimators' costs treat as +inf.
    """
    coefficients = np.atleast_2d(np.asarray(coefficients, dtype=float))
    state0 = np.asarray(state0, dtype=float)
    n_sets = max(coefficients.shape[0], 1 if state0.ndim == 1 else state0.shape[0])
    state0 = np.ascontiguousarray(np.broadcast_to(state0, (n_sets, N_STATE)))
    coefficients = np.ascontiguousarray(np.broadcast_to(coefficients, (n_sets, 9)))
    delta = np.ascontiguousarray(delta, dtype=float).reshape(-1)
    if backend == "auto":
        backend = "numba" if HAVE_NUMBA else "numpy"
    if backend == "numba":
        if not HAVE_NUMBA:
            raise ValueError("propagate: backend 'numba' requested but numba is not installed")
        with np.errstate(all="ignore"):
            return _propagate_numba(state0, coefficients, delta, float(dt),
                                    tuple(float(v) for v in const), int(substeps))
    if backend == "numpy":
        with np.errstate(all="ignore"):
            return _propagate_numpy(state0, coefficients, delta, float(dt), const, int(substeps))
    raise ValueError(f"propagate: unknown backend {backend!r} (expected auto, numba or numpy)")
