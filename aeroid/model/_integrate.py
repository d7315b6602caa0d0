"""Fixed-step fourth-order Runge-Kutta integration, batched over trajectories.

Two layers:

* :func:`rk4` integrates any batched right-hand side ``fun(t, x, *args)`` with numpy.
* :func:`propagate` integrates the airframe model (:mod:`aeroid.model`) for many
  coefficient sets at once with the fin deflection held constant over each sample
  interval (zero-order hold of the measured ``delta``). This is the hot loop of the
  output-error estimators (EAM-PSO: ~400 passes over 450 coefficient sets), so it has a
  compiled backend (numba) and a pure-numpy backend that gives the same numbers (tested
  to 1e-12 of each channel's range) for readers and for platforms without numba.

The compiled kernel (benchmarks/bench_foundation.py, results/foundation.md): each
coefficient set is integrated by one thread with its state in nine scalars (no per-set
allocation); the right-hand side is inlined; the RK4 stages get sin/cos of phi and
theta from the step's start values by the addition theorem (one libm sin/cos pair per
angle and step instead of four); fast-math without ``nnan``/``ninf``
(:data:`FASTMATH_FLAGS`). ``parallel=True`` (``prange`` over the sets, numba's default
thread count, never changed here) from :data:`PARALLEL_MIN_SETS` sets on; a serial
kernel below, where starting the threads would cost more than the work.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from aeroid.model._dynamics import N_STATE, Constants, state_derivative

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


#: numba fast-math flags of the compiled kernel: reassociation, contraction (FMA),
#: reciprocals, approximate functions, signed zeros; NOT ``nnan``/``ninf``, so a diverging
#: trajectory still yields inf/NaN (the estimators' costs rely on it). Agreement with the
#: numpy backend is tested to 1e-12 relative.
FASTMATH_FLAGS = {"nsz", "arcp", "contract", "afn", "reassoc"}
#: Below this many coefficient sets :func:`propagate` uses the serial compiled kernel:
#: starting the thread pool costs ~0.1-1 ms per call, more than integrating a few sets
#: (the simulator calls propagate once per sample with one set).
PARALLEL_MIN_SETS = 16

if HAVE_NUMBA:

    @numba.njit(cache=True, inline="always", fastmath=FASTMATH_FLAGS)
    def _sincos_shift(s0, c0, d):  # pragma: no cover - compiled
        # sin(a + d), cos(a + d) from s0 = sin(a), c0 = cos(a) by the addition theorem,
        # with sin(d), cos(d) from their Taylor series when |d| < 0.1 (terms to d^11 and
        # d^12: truncation < 1e-19, i.e. rounding-level) and from libm otherwise. The RK4
        # stages move phi and theta by a small d = h/2 * rate, so this replaces 12 of the
        # 16 sin/cos calls of a step by a few multiplications.
        if abs(d) < 0.1:
            d2 = d * d
            sd = d * (1.0 - d2 / 6.0 * (1.0 - d2 / 20.0 * (1.0 - d2 / 42.0 * (
                1.0 - d2 / 72.0 * (1.0 - d2 / 110.0)))))
            cd = 1.0 - d2 / 2.0 * (1.0 - d2 / 12.0 * (1.0 - d2 / 30.0 * (1.0 - d2 / 56.0 * (
                1.0 - d2 / 90.0 * (1.0 - d2 / 132.0)))))
        else:
            sd = math.sin(d)
            cd = math.cos(d)
        return s0 * cd + c0 * sd, c0 * cd - s0 * sd

    @numba.njit(cache=True, inline="always", fastmath=FASTMATH_FLAGS)
    def _rhs_scalar(u, v, w, p, q, r, sphi, cphi, sth, cth, delta, cx, cza, czd, czq, cl0,
                    clp, cma, cmd, cmq, half_rho_s, diam, mass, ix, iy, iz, thrust,
                    g):  # pragma: no cover - compiled
        # Eqs. 2-10 on scalars, the algebra of aeroid.model.state_derivative; psi does
        # not enter, phi and theta enter through their sines and cosines.
        speed2 = u * u + v * v + w * w
        inv_speed = 1.0 / math.sqrt(speed2)
        alpha = math.atan(w / u) if u > 0.0 else math.atan2(w, u)  # atan: ~10 % faster
        beta = math.asin(v * inv_speed)
        qs = half_rho_s * speed2
        qsd = qs * diam
        kd = 0.5 * diam * inv_speed
        fax = qs * cx
        fay = qs * (cza * beta - czq * kd * r)
        faz = qs * (cza * alpha + czd * delta + czq * kd * q)
        mx = qsd * (cl0 + clp * kd * p)
        my = qsd * (cma * alpha + cmd * delta + cmq * kd * q)
        mz = qsd * (-cma * beta + cmq * kd * r)
        qr = q * sphi + r * cphi
        inv_cth = 1.0 / cth
        return (r * v - q * w - g * sth + (fax + thrust) / mass,
                -r * u + p * w + g * cth * sphi + fay / mass,
                q * u - p * v + g * cth * cphi + faz / mass,
                mx / ix,
                (iz - ix) / iy * p * r + my / iy,
                (ix - iy) / iz * p * q + mz / iz,
                p + qr * sth * inv_cth,
                q * cphi - r * sphi,
                qr * inv_cth)

    @numba.njit(cache=True, fastmath=FASTMATH_FLAGS)
    def _integrate_set(x, c, delta, h, substeps, k, out):  # pragma: no cover - compiled
        # One coefficient set over all samples; the state lives in 9 scalars (registers),
        # no per-set allocation. k = Constants as a tuple (rho, area, diameter, mass, ix,
        # iy, iz, thrust, gravity).
        half_rho_s = 0.5 * k[0] * k[1]
        diam, mass, ix, iy, iz, thrust, g = k[2], k[3], k[4], k[5], k[6], k[7], k[8]
        cx, cza, czd, czq, cl0, clp, cma, cmd, cmq = (c[0], c[1], c[2], c[3], c[4], c[5],
                                                     c[6], c[7], c[8])
        x0, x1, x2, x3, x4, x5, x6, x7, x8 = (x[0], x[1], x[2], x[3], x[4], x[5], x[6],
                                               x[7], x[8])
        hh = 0.5 * h
        h6 = h / 6.0
        for j in range(9):
            out[0, j] = x[j]
        for s in range(delta.shape[0]):
            d = delta[s]
            for _ in range(substeps):
                sf, cf = math.sin(x6), math.cos(x6)
                st, ct = math.sin(x7), math.cos(x7)
                a0, a1, a2, a3, a4, a5, a6, a7, a8 = _rhs_scalar(
                    x0, x1, x2, x3, x4, x5, sf, cf, st, ct, d, cx, cza, czd, czq, cl0, clp,
                    cma, cmd, cmq, half_rho_s, diam, mass, ix, iy, iz, thrust, g)
                sf2, cf2 = _sincos_shift(sf, cf, hh * a6)
                st2, ct2 = _sincos_shift(st, ct, hh * a7)
                b0, b1, b2, b3, b4, b5, b6, b7, b8 = _rhs_scalar(
                    x0 + hh * a0, x1 + hh * a1, x2 + hh * a2, x3 + hh * a3, x4 + hh * a4,
                    x5 + hh * a5, sf2, cf2, st2, ct2, d, cx, cza, czd, czq, cl0, clp, cma,
                    cmd, cmq, half_rho_s, diam, mass, ix, iy, iz, thrust, g)
                sf2, cf2 = _sincos_shift(sf, cf, hh * b6)
                st2, ct2 = _sincos_shift(st, ct, hh * b7)
                e0, e1, e2, e3, e4, e5, e6, e7, e8 = _rhs_scalar(
                    x0 + hh * b0, x1 + hh * b1, x2 + hh * b2, x3 + hh * b3, x4 + hh * b4,
                    x5 + hh * b5, sf2, cf2, st2, ct2, d, cx, cza, czd, czq, cl0, clp, cma,
                    cmd, cmq, half_rho_s, diam, mass, ix, iy, iz, thrust, g)
                sf2, cf2 = _sincos_shift(sf, cf, h * e6)
                st2, ct2 = _sincos_shift(st, ct, h * e7)
                f0, f1, f2, f3, f4, f5, f6, f7, f8 = _rhs_scalar(
                    x0 + h * e0, x1 + h * e1, x2 + h * e2, x3 + h * e3, x4 + h * e4,
                    x5 + h * e5, sf2, cf2, st2, ct2, d, cx, cza, czd, czq, cl0, clp, cma,
                    cmd, cmq, half_rho_s, diam, mass, ix, iy, iz, thrust, g)
                x0 = x0 + h6 * (a0 + 2.0 * b0 + 2.0 * e0 + f0)
                x1 = x1 + h6 * (a1 + 2.0 * b1 + 2.0 * e1 + f1)
                x2 = x2 + h6 * (a2 + 2.0 * b2 + 2.0 * e2 + f2)
                x3 = x3 + h6 * (a3 + 2.0 * b3 + 2.0 * e3 + f3)
                x4 = x4 + h6 * (a4 + 2.0 * b4 + 2.0 * e4 + f4)
                x5 = x5 + h6 * (a5 + 2.0 * b5 + 2.0 * e5 + f5)
                x6 = x6 + h6 * (a6 + 2.0 * b6 + 2.0 * e6 + f6)
                x7 = x7 + h6 * (a7 + 2.0 * b7 + 2.0 * e7 + f7)
                x8 = x8 + h6 * (a8 + 2.0 * b8 + 2.0 * e8 + f8)
            out[s + 1, 0] = x0
            out[s + 1, 1] = x1
            out[s + 1, 2] = x2
            out[s + 1, 3] = x3
            out[s + 1, 4] = x4
            out[s + 1, 5] = x5
            out[s + 1, 6] = x6
            out[s + 1, 7] = x7
            out[s + 1, 8] = x8

    @numba.njit(cache=True, parallel=True)
    def _propagate_parallel(state0, coefficients, delta, h, substeps, k):  # pragma: no cover
        n_sets = state0.shape[0]
        out = np.empty((n_sets, delta.shape[0] + 1, 9))
        for i in numba.prange(n_sets):
            _integrate_set(state0[i], coefficients[i], delta, h, substeps, k, out[i])
        return out

    @numba.njit(cache=True)
    def _propagate_serial(state0, coefficients, delta, h, substeps, k):  # pragma: no cover
        n_sets = state0.shape[0]
        out = np.empty((n_sets, delta.shape[0] + 1, 9))
        for i in range(n_sets):
            _integrate_set(state0[i], coefficients[i], delta, h, substeps, k, out[i])
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

    Raises
    ------
    ValueError
        One line: shapes that are not (9,) / (n_sets, 9) or do not broadcast,
        ``substeps < 1``, ``dt <= 0``, an unknown backend.
    """
    coefficients = np.asarray(coefficients, dtype=float)
    state0 = np.asarray(state0, dtype=float)
    if coefficients.ndim not in (1, 2) or coefficients.shape[-1] != 9:
        raise ValueError(f"propagate: coefficients must have shape (9,) or (n_sets, 9), "
                         f"got {coefficients.shape}")
    if state0.ndim not in (1, 2) or state0.shape[-1] != N_STATE:
        raise ValueError(f"propagate: state0 must have shape (9,) or (n_sets, 9), "
                         f"got {state0.shape}")
    coefficients = np.atleast_2d(coefficients)
    n_sets = max(coefficients.shape[0], 1 if state0.ndim == 1 else state0.shape[0])
    if (coefficients.shape[0] not in (1, n_sets)
            or (state0.ndim == 2 and state0.shape[0] not in (1, n_sets))):
        raise ValueError(f"propagate: {state0.shape[0]} initial states and "
                         f"{coefficients.shape[0]} coefficient sets do not broadcast")
    state0 = np.ascontiguousarray(np.broadcast_to(state0, (n_sets, N_STATE)))
    coefficients = np.ascontiguousarray(np.broadcast_to(coefficients, (n_sets, 9)))
    delta = np.ascontiguousarray(delta, dtype=float).reshape(-1)
    substeps = int(substeps)
    dt = float(dt)
    if substeps < 1:
        raise ValueError(f"propagate: substeps must be >= 1, got {substeps}")
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"propagate: dt must be a positive number of seconds, got {dt}")
    if backend == "auto":
        backend = "numba" if HAVE_NUMBA else "numpy"
    if backend == "numba":
        if not HAVE_NUMBA:
            raise ValueError("propagate: backend 'numba' requested but numba is not installed")
        kernel = _propagate_parallel if n_sets >= PARALLEL_MIN_SETS else _propagate_serial
        with np.errstate(all="ignore"):
            return kernel(state0, coefficients, delta, dt / substeps, substeps,
                          tuple(float(v) for v in const))
    if backend == "numpy":
        with np.errstate(all="ignore"):
            return _propagate_numpy(state0, coefficients, delta, dt, const, substeps)
    raise ValueError(f"propagate: unknown backend {backend!r} (expected auto, numba or numpy)")
