"""The standard optimiser test functions, vectorised over a swarm (one definition).

Used by the PSO tests (``tests/unit/test_pso.py``, ``tests/statistical``) and by
``benchmarks/bench_pso.py``. Each function takes ``x`` of shape (n, d) and returns the
costs, shape (n,); each has its global minimum 0 (at ``x = 0``, Rosenbrock at
``x = 1``). :data:`DOMAINS` holds the usual search box of each.

Why not pyswarms' ``pyswarms.utils.functions.single_obj``: its sphere, Rosenbrock and
Rastrigin are these formulas, but its Ackley refuses points outside [-32, 32] (the usual
domain is [-32.768, 32.768]), it has no Griewank, and importing it reconfigures the root
logger and creates ``./report.log``. The unit tests check these definitions against the
closed forms at hand-computed points and against pyswarms' where it has them.
"""

from __future__ import annotations

import numpy as np

__all__ = ["DOMAINS", "ackley", "griewank", "rastrigin", "rosenbrock", "sphere"]

#: Usual search domain per dimension, (low, high).
DOMAINS: dict[str, tuple[float, float]] = {
    "sphere": (-5.12, 5.12),
    "rosenbrock": (-5.0, 10.0),
    "rastrigin": (-5.12, 5.12),
    "ackley": (-32.768, 32.768),
    "griewank": (-600.0, 600.0),
}


def sphere(x: np.ndarray) -> np.ndarray:
    """Return ``sum_i x_i^2``, shape (n,)."""
    return np.sum(x**2, axis=1)


def rosenbrock(x: np.ndarray) -> np.ndarray:
    """Return ``sum_i 100 (x_{i+1} - x_i^2)^2 + (1 - x_i)^2``, shape (n,)."""
    return np.sum(100.0 * (x[:, 1:] - x[:, :-1] ** 2) ** 2 + (1.0 - x[:, :-1]) ** 2, axis=1)


def rastrigin(x: np.ndarray) -> np.ndarray:
    """Return ``10 d + sum_i x_i^2 - 10 cos(2 pi x_i)``, shape (n,)."""
    return 10.0 * x.shape[1] + np.sum(x**2 - 10.0 * np.cos(2.0 * np.pi * x), axis=1)


def ackley(x: np.ndarray) -> np.ndarray:
    """Return Ackley's function (a = 20, b = 0.2, c = 2 pi), shape (n,).

    ``-20 exp(-0.2 sqrt(mean x^2)) - exp(mean cos(2 pi x)) + 20 + e``.
    """
    d = x.shape[1]
    term1 = -20.0 * np.exp(-0.2 * np.sqrt(np.sum(x**2, axis=1) / d))
    term2 = -np.exp(np.sum(np.cos(2.0 * np.pi * x), axis=1) / d)
    return term1 + term2 + 20.0 + np.e


def griewank(x: np.ndarray) -> np.ndarray:
    """Return ``1 + sum x_i^2 / 4000 - prod cos(x_i / sqrt(i))`` (i from 1), shape (n,)."""
    i = np.sqrt(np.arange(1, x.shape[1] + 1))
    return 1.0 + np.sum(x**2, axis=1) / 4000.0 - np.prod(np.cos(x / i), axis=1)
