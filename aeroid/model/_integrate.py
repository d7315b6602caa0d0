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
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from aeroid.model import _compiled
from aeroid.model import _inputs as inputs
from aeroid.model._coefficients import N_COEFFICIENTS
from aeroid.model._compiled import HAVE_NUMBA, PARALLEL_MIN_SETS
from aeroid.model._dynamics import N_STATE, Constants, state_derivative
from aeroid.model._inputs import Pieces


def rk4_stages(fun: Callable[..., Any], x: Any, h: float, start: Sequence[Any],
               middle: Sequence[Any], end: Sequence[Any]) -> Any:
    """Return one classical RK4 step of ``h`` of ``dx/dt = fun(x, *inputs)``, written once.

    ``start``, ``middle`` and ``end`` are the inputs at the step's start, middle and end
    (the first stage, the two middle stages, the last). Only arithmetic on ``x`` and
    ``fun``'s values, so numpy arrays (:func:`propagate`'s numpy backend, :func:`rk4`)
    and CasADi vectors (:func:`aeroid.model.symbolic.interval_step`) take the same
    step. The numba kernel has its own (:func:`aeroid.model._compiled.rk4_substep`): its
    state is a named tuple in registers and its stages get the attitude trigonometry
    by the addition theorem, which this generic form cannot express.
    """
    k1 = fun(x, *start)
    k2 = fun(x + 0.5 * h * k1, *middle)
    k3 = fun(x + 0.5 * h * k2, *middle)
    k4 = fun(x + h * k3, *end)
    return x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def rk4_step(fun: Callable[..., np.ndarray], t: float, x: np.ndarray, dt: float,
             *args: Any) -> np.ndarray:
    """Return one classical RK4 step of ``dx/dt = fun(t, x, *args)`` (batched ``x``)."""
    return rk4_stages(lambda y, time: fun(time, y, *args), x, dt, (t,), (t + 0.5 * dt,),
                      (t + dt,))


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


def _propagate_numpy(state0: np.ndarray, coefficients: np.ndarray, pieces: Pieces,
                     exo: np.ndarray | None, dt: float, const: Constants,
                     substeps: int) -> np.ndarray:
    """The numba kernel's algorithm (:func:`aeroid.model._compiled.integrate_set`) in numpy."""
    n_sets, n_int = state0.shape[0], pieces.end.shape[0]
    out = np.empty((n_sets, n_int + 1, N_STATE))
    x = state0.copy()
    out[:, 0] = x
    k_a = k_b = const
    for s in range(n_int):
        if exo is not None:
            k_a = inputs.with_exogenous(const, exo[s])
            k_b = inputs.with_exogenous(const, exo[s + 1])
        f_start = 0.0
        for piece in range(pieces.end.shape[1]):
            f_end = float(pieces.end[s, piece])
            length = f_end - f_start
            if length > 0.0:
                d_start = float(pieces.start[s, piece])
                d_span = float(pieces.stop[s, piece]) - d_start
                h = length * dt / substeps
                for sub in range(substeps):
                    u = (sub / substeps, (sub + 0.5) / substeps, (sub + 1.0) / substeps)
                    deltas = tuple(d_start + d_span * ui for ui in u)
                    consts = (const, const, const) if exo is None else tuple(
                        inputs.lerp(k_a, k_b, f_start + length * ui) for ui in u)
                    x = rk4_stages(
                        lambda y, d, k: state_derivative(y, d, coefficients, k), x, h,
                        *zip(deltas, consts, strict=True))
            f_start = f_end
        out[:, s + 1] = x
    return out


def propagate(state0: np.ndarray, coefficients: np.ndarray, delta: np.ndarray | Pieces,
              dt: float, const: Constants, *, substeps: int = 1, backend: str = "auto",
              exogenous: np.ndarray | None = None, parallel: bool | None = None
              ) -> np.ndarray:
    """Integrate the airframe model for many coefficient sets with RK4.

    Parameters
    ----------
    state0 : ndarray, shape (N_STATE,) or (n_sets, N_STATE)
        Initial state(s) [m/s, rad/s, rad]; one state is shared by all sets.
    coefficients : ndarray, shape (N_COEFFICIENTS,) or (n_sets, N_COEFFICIENTS)
    delta : ndarray, shape (n_samples - 1,), or Pieces
        Fin deflection [rad]: held constant over each sample interval
        ``[t_k, t_k + dt)`` (an array: zero-order hold of the recorded ``delta``), or
        the pieces of a :class:`aeroid.model.Schedule` (switch instants and ramps inside
        the intervals; every piece gets ``substeps`` RK4 steps).
    dt : float
        Sample interval [s].
    const : Constants
    substeps : int
        RK4 steps per sample interval (per piece).
    backend : {"auto", "numba", "numpy"}
        ``auto`` takes numba when it is installed.
    exogenous : ndarray, shape (n_samples, len(EXOGENOUS)), optional
        Air density, mass, thrust, inertias, gravity and wind at every sample
        (:data:`aeroid.model.EXOGENOUS` columns, :func:`aeroid.model.exogenous_table`),
        interpolated linearly in time within each interval; default the constants.
    parallel : bool or None
        numba backend: the threaded kernel (True) or the serial one (False); default
        (None) threaded from :data:`aeroid.model._compiled.PARALLEL_MIN_SETS` sets on.
        Short calls repeated many times (one interval of a UKF's sigma points) are
        faster serial: starting the thread pool costs more than the work.

    Returns
    -------
    ndarray, shape (n_sets, n_samples, N_STATE)
        The state at every sample. A set whose trajectory diverges gives non-finite
        values (never an exception), which the estimators' costs treat as +inf.

    Raises
    ------
    ValueError
        One line: shapes that are not (n,) / (n_sets, n) or do not broadcast,
        ``substeps < 1``, ``dt <= 0``, an unknown backend.
    """
    coefficients = np.asarray(coefficients, dtype=float)
    state0 = np.asarray(state0, dtype=float)
    if coefficients.ndim not in (1, 2) or coefficients.shape[-1] != N_COEFFICIENTS:
        raise ValueError(f"propagate: coefficients must have shape ({N_COEFFICIENTS},) or "
                         f"(n_sets, {N_COEFFICIENTS}), got {coefficients.shape}")
    if state0.ndim not in (1, 2) or state0.shape[-1] != N_STATE:
        raise ValueError(f"propagate: state0 must have shape ({N_STATE},) or "
                         f"(n_sets, {N_STATE}), got {state0.shape}")
    coefficients = np.atleast_2d(coefficients)
    n_sets = max(coefficients.shape[0], 1 if state0.ndim == 1 else state0.shape[0])
    if (coefficients.shape[0] not in (1, n_sets)
            or (state0.ndim == 2 and state0.shape[0] not in (1, n_sets))):
        raise ValueError(f"propagate: {state0.shape[0]} initial states and "
                         f"{coefficients.shape[0]} coefficient sets do not broadcast")
    state0 = np.ascontiguousarray(np.broadcast_to(state0, (n_sets, N_STATE)))
    coefficients = np.ascontiguousarray(np.broadcast_to(coefficients, (n_sets, N_COEFFICIENTS)))
    pieces = delta if isinstance(delta, Pieces) else inputs.held(delta)
    pieces = Pieces(*(np.ascontiguousarray(a, dtype=float) for a in pieces))
    if pieces.end.ndim != 2 or pieces.start.shape != pieces.end.shape \
            or pieces.stop.shape != pieces.end.shape:
        raise ValueError("propagate: the deflection pieces must be three (n - 1, S) arrays")
    n_samples = pieces.end.shape[0] + 1
    if exogenous is not None:
        exogenous = np.ascontiguousarray(exogenous, dtype=float)
        if exogenous.shape != (n_samples, len(inputs.EXOGENOUS)):
            raise ValueError(f"propagate: exogenous must have shape ({n_samples}, "
                             f"{len(inputs.EXOGENOUS)}), got {exogenous.shape}")
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
        if parallel is None:
            parallel = n_sets >= PARALLEL_MIN_SETS
        kernel = _compiled.propagate_parallel if parallel else _compiled.propagate_serial
        varying = exogenous is not None
        table = exogenous if varying else np.zeros((1, len(inputs.EXOGENOUS)))
        with np.errstate(all="ignore"):
            return kernel(state0, coefficients, pieces.end, pieces.start, pieces.stop, table,
                          varying, dt, substeps, Constants(*(float(v) for v in const)))
    if backend == "numpy":
        with np.errstate(all="ignore"):
            return _propagate_numpy(state0, coefficients, pieces, exogenous, dt, const,
                                    substeps)
    raise ValueError(f"propagate: unknown backend {backend!r} (expected auto, numba or numpy)")
