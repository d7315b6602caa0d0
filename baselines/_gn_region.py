"""Parameters on which the outputs are only piecewise smooth: the solver's region and step.

An actuator delay moves a relay's switch across a sample instant, where the outputs jump;
the Gauss-Newton solver (:mod:`baselines._gauss_newton`) confines its step to the region
where the outputs are smooth (:func:`held_step`) and tries just across an edge
(:func:`step_across`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class SmoothRegion(NamedTuple):
    """Where the outputs are smooth in the parameters around an iterate (scaled units).

    A parameter on which the outputs are piecewise smooth (an actuator delay: a relay's
    switch crossing a sample instant changes the deflection the accelerometers see there,
    so the outputs jump) is smooth in ``[lo, hi]``; ``below`` and ``above`` are values just
    across each edge. ``-inf``/``inf`` for a parameter smooth everywhere.
    """

    lo: np.ndarray
    hi: np.ndarray
    below: np.ndarray
    above: np.ndarray


def held_step(system: np.ndarray, g: np.ndarray, p: np.ndarray, step: np.ndarray,
              region: SmoothRegion) -> tuple[np.ndarray, np.ndarray] | None:
    """Return ``step`` with the parameters it takes out of their smooth region held there.

    Each such parameter moves to the edge it would cross; the others take the minimum of
    the quadratic model ``-g.s + 1/2 s.system.s`` given those (the Gauss-Newton step of the
    problem confined to the region). Returns the step and the mask of held parameters, or
    None when ``step`` stays inside.
    """
    above, below = p + step > region.hi, p + step < region.lo
    out = above | below
    if not np.any(out):
        return None
    held = np.zeros_like(p)
    held[above] = region.hi[above] - p[above]
    held[below] = region.lo[below] - p[below]
    free = ~out
    try:
        held[free] = np.linalg.solve(system[np.ix_(free, free)],
                                     g[free] - system[np.ix_(free, out)] @ held[out])
    except np.linalg.LinAlgError:
        return None
    return (held, out) if np.all(np.isfinite(held)) else None


def step_across(p: np.ndarray, step: np.ndarray, region: SmoothRegion) -> np.ndarray:
    """``p`` with every parameter that ``step`` takes out of its region just across the edge."""
    across = p.copy()
    above, below = p + step > region.hi, p + step < region.lo
    across[above], across[below] = region.above[above], region.below[below]
    return across


__all__ = ["SmoothRegion", "held_step", "step_across"]
