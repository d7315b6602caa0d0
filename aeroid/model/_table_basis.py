"""The hat basis of piecewise-linear coefficient tables and their knots (one definition).

A table is ``C(x) = sum_i B_i(x) c_i`` over knots ``x_1 < ... < x_k`` of its variable (Mach
number, or the total angle of attack [rad]: :mod:`aeroid.model._alpha_tables`); the hat
functions ``B_i`` are element-wise (numpy and CasADi) and held beyond the end knots.
Moved here from :mod:`aeroid.model._tables`, which re-exports every name.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from aeroid.errors import AirframeError

Scalar = Any  # a float, an ndarray or a CasADi symbol: the functions here are element-wise

#: Closest knots [Mach]: the hat between knots closer than this is steeper than any
#: flight record can inform (1e-3 Mach is 0.3 m/s), and their names would collide.
MIN_KNOT_SPACING = 1e-3
#: Mach range of a table's knots: a knot outside is a typo (a speed in m/s, a percent).
KNOT_RANGE = (0.0, 10.0)
def hat(mach: Scalar, knots: Sequence[float], i: int) -> Scalar:
    """Return the hat function of knot ``i`` of ``knots`` at ``mach`` (element-wise).

    1 at ``knots[i]``, 0 at the other knots, linear between neighbours; the first and
    last hats are 1 beyond their end of the table (end values held). One knot: 1.
    """
    k = len(knots)
    if k == 1:
        return 0.0 * mach + 1.0
    one = 0.0 * mach + 1.0
    rising = one if i == 0 else (mach - knots[i - 1]) / (knots[i] - knots[i - 1])
    falling = one if i == k - 1 else (knots[i + 1] - mach) / (knots[i + 1] - knots[i])
    return np.maximum(np.minimum(np.minimum(rising, falling), 1.0), 0.0)


def basis(knots: Sequence[float], mach: np.ndarray) -> np.ndarray:
    """Return the hat basis of ``knots`` at ``mach``, shape (n, k) (numpy).

    Row ``j`` holds ``B_i(mach_j)``; every row sums to 1, and ``basis @ values`` is the
    table at those Mach numbers.
    """
    mach = np.asarray(mach, dtype=float).reshape(-1)
    return np.stack([hat(mach, knots, i) for i in range(len(knots))], axis=-1)


def table_value(mach: Scalar, knots: Sequence[float], values: Sequence[Scalar]) -> Scalar:
    """Return the table ``sum_i B_i(mach) values[i]`` (element-wise)."""
    total = 0.0
    for i, value in enumerate(values):
        total = total + hat(mach, knots, i) * value
    return total

def check_knots(knots: Any, where: str) -> tuple[float, ...]:
    """Return ``knots`` as increasing floats, or raise a one-line :class:`AirframeError`."""
    if isinstance(knots, str | bytes) or not isinstance(knots, Sequence | np.ndarray):
        raise AirframeError(f"{where}: knots must be a list of Mach numbers, got {knots!r}")
    try:
        values = tuple(float(k) for k in knots)
    except (TypeError, ValueError):
        raise AirframeError(f"{where}: knots must be numbers, got {list(knots)!r}") from None
    if isinstance(knots, Sequence) and any(isinstance(k, bool) for k in knots):
        raise AirframeError(f"{where}: knots must be numbers, got {list(knots)!r}")
    if not values:
        raise AirframeError(f"{where}: no knots (give at least one Mach number)")
    low, high = KNOT_RANGE
    if not all(math.isfinite(k) and low < k <= high for k in values):
        raise AirframeError(f"{where}: knots must be Mach numbers in ({low:g}, {high:g}], "
                            f"got {list(values)}")
    gaps = np.diff(values)
    if np.any(gaps < MIN_KNOT_SPACING):
        raise AirframeError(f"{where}: knots must increase by at least {MIN_KNOT_SPACING:g} "
                            f"Mach, got {list(values)}")
    names = [f"{k:g}" for k in values]
    if len(set(names)) != len(names):
        raise AirframeError(f"{where}: knots {names} have the same name; give them fewer "
                            "digits apart")
    return values


def choose_knots(mach: np.ndarray, count: int) -> tuple[float, ...]:
    """Return ``count`` knots evenly spaced over the range of ``mach``, rounded to 0.01.

    The end knots are the lowest and highest Mach of the data rounded outward to 0.01, so
    no sample lies beyond the table.
    """
    if int(count) != count or count < 1:
        raise AirframeError(f"tables: knot count must be a positive integer, got {count!r}")
    mach = np.asarray(mach, dtype=float)
    mach = mach[np.isfinite(mach)]
    if mach.size == 0:
        raise AirframeError("tables: no finite Mach number in the data to choose knots from")
    # rounded outward to 0.01 Mach (a rounding error of the speed does not move a knot)
    low = math.floor(float(mach.min()) * 100 + 1e-6) / 100
    high = math.ceil(float(mach.max()) * 100 - 1e-6) / 100
    if count == 1 or high - low < MIN_KNOT_SPACING * (count - 1):
        if count > 1:
            raise AirframeError(f"tables: the data span Mach {mach.min():.4g}-{mach.max():.4g},"
                                f" too narrow for {count} knots")
        return (round(0.5 * (low + high), 2),)
    return tuple(round(float(k), 2) for k in np.linspace(low, high, int(count)))


__all__ = ["KNOT_RANGE", "MIN_KNOT_SPACING", "basis", "check_knots", "choose_knots", "hat",
           "table_value"]
