"""The paper's modified particle swarm optimiser (section 2, eqs. 17-22).

The swarm searches the unit cube ``[0, 1]^d``; every point is mapped affinely onto the
caller's bounds just before the cost function is called, so all constants below
(``v_max`` in particular) are fractions of each parameter's range.

Per iteration ``k`` (where the paper is silent or garbled, the decision is stated):

1. Local best (section 2.1): with the singly-linked ring topology particle ``i`` sees
   particles ``i - 2`` and ``i + 1`` (with wrap-around); its local best is the best
   personal best among itself and those two (ties go to the particle itself). The
   ``"global"`` topology uses the swarm's best personal best instead.
2. Velocity and position (eqs. 17-18), ``c1 = c2 = 1`` by default and the inertia
   ``w ~ U[0, 1]`` drawn per particle, per dimension and per iteration, like ``r1`` and
   ``r2``::

       v <- w v + c1 r1 (pbest - x) + c2 r2 (lbest - x)
       x <- clip(x + v, 0, 1)

3. Velocity re-randomisation (eq. 19): any component with ``|v| > v_max`` is replaced
   by a fresh ``U(-v_max, v_max)`` draw (``v_max = 0.2``) before the position update.
   The paper does not say how particles are kept inside the box; decision: positions
   are clipped to ``[0, 1]`` and the velocity is left as it is (it is re-randomised
   by eq. 19 or shrunk by the random inertia within a few iterations).
4. The new positions are evaluated and personal bests updated.
5. Quadratic interpolation (eqs. 20-22): each particle (the "main parent") and two
   other, distinct, randomly chosen particles ``nb1`` and ``nb2`` give, per dimension,
   three points (personal-best position, personal-best cost). The extracted eq. 21 is
   garbled, so the standard three-point vertex formula is used::

       a = (x_nb1^2 - x_nb2^2) J_i + (x_nb2^2 - x_i^2) J_nb1 + (x_i^2 - x_nb1^2) J_nb2
       b = (x_nb1 - x_nb2) J_i + (x_nb2 - x_i) J_nb1 + (x_i - x_nb1) J_nb2
       x_new = a / (2 b)

   The paper's test ``b > 0`` is a convexity test only for ordered points; the vertex
   is used where the parabola's leading coefficient
   ``-b / ((x_i - x_nb1)(x_nb1 - x_nb2)(x_nb2 - x_i))`` is positive and finite, and a
   ``U[0, 1]`` value is used otherwise (concave or flat parabola, coincident points,
   non-finite costs). ``x_new`` is clipped into ``[0, 1]``. The new points are
   evaluated in one batched call and each replaces only its parent's personal best,
   and only if it is better; the parent's position and velocity are not changed.

Other decisions, not given by the paper: initial positions are ``U[0, 1]^d`` (rows of
``x0`` overwrite the first rows), initial velocities ``U(-v_max, v_max)``; non-finite
costs (NaN, +-inf) count as ``+inf``; the optimiser stops after ``n_iterations``
(the paper's criterion), or earlier on stall or on request of the callback.

All random numbers come from one ``numpy.random.Generator`` normalised once with
``np.random.default_rng(rng)``; the same seed gives a bitwise identical result. The
kernels (:mod:`aeroid.estimation._pso_kernels`, importable from here too)
:func:`update_velocity_position`, :func:`ring_neighbours`,
:func:`quadratic_vertex` and :func:`local_best` are pure functions whose random numbers
are passed in, so they can be checked against hand-computed values;
:func:`interpolation_partners` takes the generator explicitly.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from aeroid.estimation._pso_kernels import (
    interpolation_partners,
    local_best,
    quadratic_vertex,
    ring_neighbours,
    update_velocity_position,
)

__all__ = [
    "PSOResult",
    "interpolation_partners",
    "local_best",
    "minimize",
    "quadratic_vertex",
    "ring_neighbours",
    "update_velocity_position",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class PSOResult:
    """Outcome of :func:`minimize`.

    Attributes
    ----------
    x : ndarray, shape (d,)
        Best position found, in the caller's units.
    cost : float
        Cost at ``x`` (``inf`` when no finite cost was ever seen).
    history_cost : ndarray, shape (n_iterations + 1,)
        Best cost after the initial evaluation and after each iteration.
    history_x : ndarray, shape (n_iterations + 1, d)
        Best position after the initial evaluation and after each iteration, in the
        caller's units.
    n_evaluations : int
        Number of points evaluated, the interpolation's candidates included.
    n_iterations : int
        Number of iterations performed (the initial evaluation is not one).
    message : str
        Why the optimiser stopped; it starts with "no finite cost" when no evaluated
        point had a finite cost, and says so when ``n_iterations`` was 0.
    success : bool
        True when the best cost is finite.
    """

    x: FloatArray
    cost: float
    history_cost: FloatArray
    history_x: FloatArray
    n_evaluations: int
    n_iterations: int
    message: str
    success: bool


def _validate_bounds(bounds: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Return (low, high), each of shape (d,), or raise a one-line ValueError."""
    try:
        arr = np.asarray(bounds, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"bounds must be numeric (low, high) pairs: {exc}") from None
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 1:
        raise ValueError(f"bounds must have shape (d, 2) with d >= 1, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("bounds must be finite")
    low, high = arr[:, 0].copy(), arr[:, 1].copy()
    bad = np.flatnonzero(~(low < high))
    if bad.size:
        raise ValueError(f"bounds need low < high; not so for dimension(s) {bad.tolist()}")
    return low, high


def _improvement(old: float, new: float) -> float:
    """Decrease of the best cost from ``old`` to ``new`` (inf -> inf counts as 0)."""
    if old == new:
        return 0.0
    return old - new


def minimize(
    fun: Callable[[FloatArray], ArrayLike],
    bounds: Sequence[tuple[float, float]] | ArrayLike,
    *,
    n_particles: int = 450,
    n_iterations: int = 200,
    rng: int | np.random.Generator | np.random.SeedSequence | None = None,
    c1: float = 1.0,
    c2: float = 1.0,
    v_max: float = 0.2,
    topology: Literal["ring", "global"] = "ring",
    interpolation: bool = True,
    stall_iterations: int | None = None,
    stall_tol: float = 0.0,
    callback: Callable[[int, FloatArray, float], bool | None] | None = None,
    x0: ArrayLike | None = None,
) -> PSOResult:
    """Minimise ``fun`` over a box with the paper's modified PSO.

    Parameters
    ----------
    fun : callable
        ``fun(x) -> costs`` with ``x`` of shape (n, d) in the caller's units and
        ``costs`` of shape (n,). Called once per swarm evaluation (the interpolation's
        candidates form one further call per iteration). NaN and +-inf count as
        ``+inf``.
    bounds : sequence of (low, high) pairs or ndarray, shape (d, 2)
        Finite box with ``low < high`` in every dimension, in the caller's units.
    n_particles : int
        Swarm size (>= 3 with interpolation, which needs two other particles).
    n_iterations : int
        Maximum number of iterations (>= 0; with 0 only the initial swarm is evaluated,
        which the message says: the paper's estimators refuse 0).
    rng : None, int, SeedSequence or Generator
        Source of randomness, passed once through ``np.random.default_rng``.
    c1, c2 : float
        Cognitive and social coefficients of eq. 17.
    v_max : float
        Velocity limit of eq. 19, as a fraction of each parameter's range.
    topology : {"ring", "global"}
        Singly-linked ring (the paper) or global best.
    interpolation : bool
        Apply the quadratic interpolation operator (eqs. 20-22) every iteration.
    stall_iterations : int or None
        Stop when the best cost improved by no more than ``stall_tol`` over the last
        ``stall_iterations`` iterations; ``None`` never stops on stall.
    stall_tol : float
        Absolute improvement threshold for the stall test (>= 0).
    callback : callable or None
        ``callback(iteration, best_x, best_cost)`` after each iteration (1-based),
        ``best_x`` in the caller's units; returning True stops the optimiser.
    x0 : array_like, shape (n0, d), or None
        Initial positions (caller's units) that replace the first ``n0 <= n_particles``
        random ones; clipped into the bounds.

    Returns
    -------
    PSOResult
        Best point, its cost, histories and counts.

    Raises
    ------
    ValueError
        On invalid bounds, options or ``x0``, or when ``fun`` returns the wrong
        number of costs.
    """
    low, high = _validate_bounds(bounds)
    d = low.size
    span = high - low
    if n_particles < (3 if interpolation else 1):
        raise ValueError(f"n_particles must be >= 3 with interpolation, got {n_particles}")
    if n_iterations < 0:
        raise ValueError(f"n_iterations must be >= 0, got {n_iterations}")
    if not v_max > 0.0:
        raise ValueError(f"v_max must be > 0, got {v_max}")
    if topology not in ("ring", "global"):
        raise ValueError(f"topology must be 'ring' or 'global', got {topology!r}")
    if stall_iterations is not None and stall_iterations < 1:
        raise ValueError(f"stall_iterations must be >= 1 or None, got {stall_iterations}")
    if not stall_tol >= 0.0:
        raise ValueError(f"stall_tol must be >= 0, got {stall_tol}")
    rng = np.random.default_rng(rng)
    n = int(n_particles)

    def to_caller(u: FloatArray) -> FloatArray:
        return np.clip(low + u * span, low, high)

    n_evaluations = 0

    def evaluate(u: FloatArray) -> FloatArray:
        nonlocal n_evaluations
        costs = np.asarray(fun(to_caller(u)), dtype=float).reshape(-1)
        if costs.size != u.shape[0]:
            raise ValueError(f"fun returned {costs.size} costs for {u.shape[0]} points")
        n_evaluations += u.shape[0]
        return np.where(np.isfinite(costs), costs, np.inf)

    # Initial swarm.
    x = rng.random((n, d))
    v = rng.uniform(-v_max, v_max, size=(n, d))
    if x0 is not None:
        start = np.atleast_2d(np.asarray(x0, dtype=float))
        if start.ndim != 2 or start.shape[1] != d or start.shape[0] > n:
            raise ValueError(f"x0 must have shape (n0 <= {n}, {d}), got {start.shape}")
        if not np.all(np.isfinite(start)):
            raise ValueError("x0 must be finite")
        x[: start.shape[0]] = np.clip((start - low) / span, 0.0, 1.0)
    pbest_x = x.copy()
    pbest_cost = evaluate(x)
    neighbours = ring_neighbours(n) if topology == "ring" else None

    best = int(np.argmin(pbest_cost))
    history_cost = [float(pbest_cost[best])]
    history_u = [pbest_x[best].copy()]
    message = "maximum number of iterations reached"
    iteration = 0
    for iteration in range(1, n_iterations + 1):
        lbest_x = local_best(pbest_x, pbest_cost, neighbours)
        w, r1, r2, u_reset = rng.random((4, n, d))
        r_reset = v_max * (2.0 * u_reset - 1.0)
        x, v = update_velocity_position(
            x, v, pbest_x, lbest_x, w=w, r1=r1, r2=r2, r_reset=r_reset, c1=c1, c2=c2, v_max=v_max
        )
        cost = evaluate(x)
        improved = cost < pbest_cost
        pbest_x[improved] = x[improved]
        pbest_cost[improved] = cost[improved]

        if interpolation:
            nb1, nb2 = interpolation_partners(n, rng).T
            candidates = quadratic_vertex(
                pbest_x,
                pbest_x[nb1],
                pbest_x[nb2],
                pbest_cost[:, None],
                pbest_cost[nb1, None],
                pbest_cost[nb2, None],
                fallback=rng.random((n, d)),
            )
            cost_new = evaluate(candidates)
            better = cost_new < pbest_cost
            pbest_x[better] = candidates[better]
            pbest_cost[better] = cost_new[better]

        best = int(np.argmin(pbest_cost))
        history_cost.append(float(pbest_cost[best]))
        history_u.append(pbest_x[best].copy())

        if callback is not None and callback(
            iteration, to_caller(pbest_x[best]), float(pbest_cost[best])
        ):
            message = "stopped by callback"
            break
        if (
            stall_iterations is not None
            and iteration >= stall_iterations
            and _improvement(history_cost[-1 - stall_iterations], history_cost[-1]) <= stall_tol
        ):
            message = (
                f"stalled: best cost improved by <= {stall_tol:g} "
                f"over {stall_iterations} iterations"
            )
            break

    history_x = to_caller(np.asarray(history_u))
    best_cost = history_cost[-1]
    if n_iterations == 0:
        message = "no iteration run (n_iterations=0): the best point of the initial swarm"
    if not np.isfinite(best_cost):
        message = (f"no finite cost: all {n_evaluations} evaluated points gave NaN or inf "
                   f"({message})")
    return PSOResult(
        x=history_x[-1].copy(),
        cost=best_cost,
        history_cost=np.asarray(history_cost),
        history_x=history_x,
        n_evaluations=n_evaluations,
        n_iterations=iteration,
        message=message,
        success=bool(np.isfinite(best_cost)),
    )
