"""The axial-drag method's motor: a thrust curve's thrust and mass on the fit's time grid.

A log reaching into the burn is fitted with the airframe's ``[thrust_curve]``
(:class:`aeroid.model.ThrustCurve`): its thrust inside the burn window (zero outside) and
the mass along the burn, at the grid's nodes and linear between them (the estimators'
convention for per-sample inputs, and the suite simulator's), enter the point mass's
axial specific force ``(Q S Cx + thrust) / m`` (:mod:`baselines._axial_model`). As for a
flight (:func:`aeroid.flights.with_thrust_curve`): nodes inside the burn without the
curve's mass are refused (thrust without the mass it burns would change the physics
quietly); without a node inside the burn the thrust is 0 and the airframe's mass holds.
The mass along the burn is the curve's: an airframe mass sd would not reach it (the
consider path varies the airframe's mass), so the two together are refused, not built.
"""

from __future__ import annotations

import numpy as np

from aeroid.errors import EstimatorError
from aeroid.model import Airframe

__all__ = ["motor_on_grid"]


def motor_on_grid(airframe: Airframe, grid: np.ndarray
                  ) -> tuple[tuple[np.ndarray, np.ndarray] | None, str | None]:
    """Return ``((thrust [N], mass [kg]) at grid, note)``, or ``(None, None)`` without a curve.

    Raises
    ------
    EstimatorError
        One line: nodes inside the burn and no mass along it, or a mass sd beside the
        curve's mass (module docstring).
    """
    curve = airframe.thrust_curve
    if curve is None:
        return None, None
    inside = curve.burning(grid)
    n_in = int(inside.sum())
    start, end = curve.burn_s
    if n_in and curve.mass_kg is None:
        raise EstimatorError(
            f"axial-drag: {n_in} samples ({grid[inside][0]:g}..{grid[inside][-1]:g} s) are "
            f"inside the burn window {start:g}..{end:g} s and the thrust curve "
            f"({curve.source}) has no mass along the burn: give its mass_kg column, or fit "
            f"the samples after {end:g} s only")
    if n_in and airframe.mass_sd.get("mass_kg"):
        raise EstimatorError(
            f"axial-drag: the mass along the burn is the thrust curve's ({curve.source}) "
            "mass_kg, which the airframe's mass sd does not reach: not built (give the mass "
            f"without mass_sd_kg, or fit the samples after {end:g} s only)")
    thrust = curve.thrust(grid)
    if n_in:
        note = (f"{curve.describe()}; {n_in} of {grid.size} time nodes inside the burn, the "
                "thrust and mass linear between them")
        return (thrust, curve.mass(grid)), note
    note = (f"{curve.describe()}; no time node inside the burn ({grid[0]:g}..{grid[-1]:g} "
            "s): thrust 0 throughout, the airframe's mass")
    return (thrust, np.full(grid.shape, airframe.mass_kg)), note
