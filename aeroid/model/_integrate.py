"""Fixed-step fourth-order Runge-Kutta integration, batched over trajectories.

Two layers:

* :func:`rk4` integrates any batched right-hand side ``fun(t, x, *args)`` with numpy.
* :func:`propagate` integrates the airframe model (:mod:`aeroid.model._equations`) for
  many coefficient sets at once with the fin deflection held constant over each sample
  interval (zero-order hold of the measured ``delta``). This is the hot loop of the
  output-error estimators (EAM-PSO: ~400 passes over 450 coefficient sets), so it has a
  compiled backend (numba kernels of the same equations, :mod:`aeroid.model._compiled`)
  and a pure-numpy backend that gives the same numbers (tested to 1e-12 of each
  channel's range) for readers and for platforms without numba.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from aeroid.model import _compiled
from aeroid.model._compiled import HAVE_NUMBA, PARALLEL_MIN_SETS
from aeroid.model._dynamics import N_STATE, Constants, state_derivative


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
        kernel = (_compiled.propagate_parallel if n_sets >= PARALLEL_MIN_SETS
                  else _compiled.propagate_serial)
        with np.errstate(all="ignore"):
            return kernel(state0, coefficients, delta, dt / substeps, substeps,
                          Constants(*(float(v) for v in const)))
    if backend == "numpy":
        with np.errstate(all="ignore"):
            return _propagate_numpy(state0, coefficients, delta, dt, const, substeps)
    raise ValueError(f"propagate: unknown backend {backend!r} (expected auto, numba or numpy)")
