"""The pure kernels of the paper's modified PSO (eqs. 17-22), one iteration's pieces.

Each function works on arrays of shape (n_particles, n_dims) in the unit cube, and its
random numbers are passed in (or, for :func:`interpolation_partners`, the generator),
so each can be checked against hand-computed values. :func:`aeroid.estimation.minimize`
(:mod:`aeroid.estimation._pso`) strings them together; its docstring states the
algorithm and the decisions where the paper is silent.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "interpolation_partners",
    "local_best",
    "quadratic_vertex",
    "ring_neighbours",
    "update_velocity_position",
]

FloatArray = NDArray[np.float64]


def ring_neighbours(n: int) -> NDArray[np.intp]:
    """Neighbour indices of the singly-linked ring topology (section 2.1).

    Parameters
    ----------
    n : int
        Number of particles, ``n >= 1``.

    Returns
    -------
    ndarray of int, shape (n, 2)
        Row ``k`` is ``((k - 2) mod n, (k + 1) mod n)``: the two particles that
        particle ``k`` sees.
    """
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    k = np.arange(n)
    return np.column_stack(((k - 2) % n, (k + 1) % n))


def local_best(
    pbest_x: FloatArray, pbest_cost: FloatArray, neighbours: NDArray[np.intp] | None
) -> FloatArray:
    """Best personal best seen by each particle.

    Parameters
    ----------
    pbest_x : ndarray, shape (n, d)
        Personal-best positions (unit cube).
    pbest_cost : ndarray, shape (n,)
        Personal-best costs; ``inf`` for none.
    neighbours : ndarray of int, shape (n, m), or None
        Indices each particle sees besides itself (e.g. :func:`ring_neighbours`);
        ``None`` for the global topology (every particle sees the whole swarm).

    Returns
    -------
    ndarray, shape (n, d)
        Local-best position of each particle. Ties go to the particle itself, then
        to the neighbours in column order (global: to the lowest index).
    """
    n = pbest_x.shape[0]
    if neighbours is None:
        return np.broadcast_to(pbest_x[np.argmin(pbest_cost)], pbest_x.shape).copy()
    candidates = np.column_stack((np.arange(n), neighbours))
    choice = np.argmin(pbest_cost[candidates], axis=1)
    return pbest_x[candidates[np.arange(n), choice]]


def interpolation_partners(n: int, rng: np.random.Generator) -> NDArray[np.intp]:
    """Draw the two random partners ``nb1``, ``nb2`` of every particle (section 2.2).

    Parameters
    ----------
    n : int
        Number of particles, ``n >= 3``.
    rng : numpy.random.Generator
        Source of randomness (two ``integers`` draws of size ``n``).

    Returns
    -------
    ndarray of int, shape (n, 2)
        Row ``i`` holds two distinct indices, both different from ``i``; every ordered
        pair of other particles is equally likely.
    """
    if n < 3:
        raise ValueError(f"n must be >= 3 to choose two other particles, got {n}")
    rows = np.arange(n)
    # Offsets in 1..n-1 from the parent; the second skips the first.
    offset1 = 1 + rng.integers(0, n - 1, size=n)
    offset2 = 1 + rng.integers(0, n - 2, size=n)
    offset2 = offset2 + (offset2 >= offset1)
    return np.column_stack(((rows + offset1) % n, (rows + offset2) % n))


def update_velocity_position(
    x: FloatArray,
    v: FloatArray,
    pbest_x: FloatArray,
    lbest_x: FloatArray,
    *,
    w: FloatArray,
    r1: FloatArray,
    r2: FloatArray,
    r_reset: FloatArray,
    c1: float = 1.0,
    c2: float = 1.0,
    v_max: float = 0.2,
) -> tuple[FloatArray, FloatArray]:
    """One velocity and position update, eqs. 17-19, in the unit cube.

    Parameters
    ----------
    x, v : ndarray, shape (n, d)
        Positions and velocities (fractions of each parameter's range).
    pbest_x, lbest_x : ndarray, shape (n, d)
        Personal-best and local-best positions.
    w, r1, r2 : ndarray, shape (n, d)
        Inertia weights and the two acceleration draws, each in ``[0, 1]``.
    r_reset : ndarray, shape (n, d)
        Replacement velocities, drawn ``U(-v_max, v_max)`` by the caller; component
        ``(i, j)`` is used only where ``|v_new[i, j]| > v_max`` (eq. 19).
    c1, c2 : float
        Cognitive and social coefficients (the paper: 1 and 1).
    v_max : float
        Velocity limit (the paper: 0.2).

    Returns
    -------
    x_new : ndarray, shape (n, d)
        ``clip(x + v_new, 0, 1)``.
    v_new : ndarray, shape (n, d)
        Velocity after eq. 17 and the re-randomisation of eq. 19 (not altered by the
        clipping of the position).
    """
    v_new = w * v + c1 * r1 * (pbest_x - x) + c2 * r2 * (lbest_x - x)
    v_new = np.where(np.abs(v_new) > v_max, r_reset, v_new)
    x_new = np.clip(x + v_new, 0.0, 1.0)
    return x_new, v_new


def quadratic_vertex(
    x_i: ArrayLike,
    x_nb1: ArrayLike,
    x_nb2: ArrayLike,
    J_i: ArrayLike,
    J_nb1: ArrayLike,
    J_nb2: ArrayLike,
    fallback: ArrayLike,
) -> FloatArray:
    """Vertex of the parabola through three points, per dimension (eqs. 20-22).

    Parameters
    ----------
    x_i, x_nb1, x_nb2 : array_like, shape (..., d)
        Coordinates of the main parent and the two other particles (unit cube).
    J_i, J_nb1, J_nb2 : array_like
        Their costs, broadcastable against ``x_i`` (shape (n, 1) for one cost per
        particle); non-finite costs give the fallback.
    fallback : array_like, broadcastable to the result
        Value used where the parabola has no minimum (leading coefficient not
        positive or not finite), where points coincide, or where the vertex is not
        finite; the optimiser passes ``U[0, 1]`` draws.

    Returns
    -------
    ndarray
        ``clip(a / (2 b), 0, 1)`` where the parabola is convex, else ``fallback``
        (also clipped into ``[0, 1]``). Symmetric in the order of the three points.
    """
    x1, x2, x3 = (np.asarray(t, dtype=float) for t in (x_i, x_nb1, x_nb2))
    f1, f2, f3 = (np.asarray(t, dtype=float) for t in (J_i, J_nb1, J_nb2))
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        a = (x2 * x2 - x3 * x3) * f1 + (x3 * x3 - x1 * x1) * f2 + (x1 * x1 - x2 * x2) * f3
        b = (x2 - x3) * f1 + (x3 - x1) * f2 + (x1 - x2) * f3
        denominator = (x1 - x2) * (x2 - x3) * (x3 - x1)
        leading = -b / denominator
        vertex = a / (2.0 * b)
        ok = (denominator != 0.0) & np.isfinite(leading) & (leading > 0.0)
        ok &= np.isfinite(vertex)
    return np.clip(np.where(ok, vertex, fallback), 0.0, 1.0)
