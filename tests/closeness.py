"""Comparisons of computed arrays at a tolerance scaled to the quantity, not per element.

Two sums of the same terms in another order (a reordered loop, a different SIMD width,
FMA on one CPU and not another) agree to a few ulps of the *largest* term they add, not
of each result element: an element that cancels to near zero carries an absolute
rounding error of that size and an arbitrarily large relative one. Element-wise
``rtol`` with ``atol=0`` therefore fails on another machine (seen: an element of 4.8e-4
in a matrix whose largest entry is ~1 differed by 5.6e-16, 1.2e-12 relative, on an AMD
EPYC with AVX-512). Compare instead at ``rtol`` times the reference's largest magnitude.
"""

from __future__ import annotations

import numpy as np


def assert_close_in_norm(actual, desired, rtol: float, *, axis=None, err_msg: str = "") -> None:
    """Assert ``max|actual - desired| <= rtol * max|desired|``.

    With ``axis`` (an int or tuple), the scale is the largest magnitude along it (each
    column of a time series against its own range, for example) instead of the whole
    array's.
    """
    actual = np.asarray(actual, dtype=float)
    desired = np.asarray(desired, dtype=float)
    np.testing.assert_equal(actual.shape, desired.shape, err_msg=err_msg)
    scale = np.max(np.abs(desired), axis=axis, keepdims=axis is not None)
    excess = np.abs(actual - desired) - rtol * scale
    worst = np.unravel_index(np.argmax(excess), excess.shape) if excess.size else ()
    if excess.size and excess[worst] > 0:
        raise AssertionError(
            f"{err_msg + ': ' if err_msg else ''}max|actual - desired| exceeds {rtol:g} x "
            f"max|desired|: at {tuple(int(i) for i in worst)} actual {actual[worst]!r}, "
            f"desired {desired[worst]!r}, scale {np.broadcast_to(scale, excess.shape)[worst]!r}")
