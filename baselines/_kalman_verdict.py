"""The augmented filters' passes that do not settle: a verdict (issue 26; private).

The EKF and UKF run passes over the flight, each started where the last ended
(:meth:`baselines._common.AugmentedFilterOptions.run_passes`). At a fixed point the
constant states (the coefficients and, with ``estimate_wind``, the steady wind) stop
moving; a pass that still moves one of them by more than :data:`SETTLE_LIMIT_SE` of its
own standard error says that the reported standard error does not describe where the
estimate is. Measured on the EKF with ``estimate_wind`` (``benchmarks/results/
wind_filters.md``, Gaussian IMU): the along-path wind walks 4-6 m/s per pass in one
direction (2-3 of its sd), from 3 m/s at the first pass to 19-26 m/s at the sixth on
seeds 1, 4, 5, with the coefficients following it along the dynamic pressure's ridge;
the fit check passes those fits (the residuals stay white and small). Such a fit is
``success=False`` here, with the largest move named.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from aeroid.estimation import EstimationResult
from baselines import _kalman

#: A fit whose last pass moved a constant state by more than this many of its own
#: standard errors is not a result (its se does not cover its own last step). Measured
#: (EKF, estimate_wind, seeds 1-6 of the windy and still flights): the walking fits'
#: last moves 2.0-3.2 se, the settled ones' 0.03-0.65 se; without the wind (still air,
#: seeds 1-6) every fit settled (last move <= 0.1 se, the passes' own tolerance).
SETTLE_LIMIT_SE = 1.0


def last_moves(passes: list[_kalman.FilterOutput], index: np.ndarray) -> np.ndarray | None:
    """``|x_last - x_before| / sd_last`` of the states ``index`` between the last two good
    passes (None with fewer than two; NaN where a state is held, sd 0)."""
    good = [out for out in passes if out.failed_at is None]
    if len(good) < 2:
        return None
    before, last = good[-2], good[-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        moved = np.abs(last.x[-1, index] - before.x[-1, index]) / last.sd[-1, index]
    return np.where(last.sd[-1, index] > 0, moved, np.nan)


def settle_verdict(result: EstimationResult, passes: list[_kalman.FilterOutput],
                   index: np.ndarray, names: tuple[str, ...]) -> EstimationResult:
    """``result`` with ``success=False`` when its passes did not settle.

    ``index``, ``names``: the constant states judged (positions in the filter's state)
    and their names. Adds ``info['last_pass_moves_se']`` (per name) in any case and
    ``info['settle_refused']`` when it refuses.
    """
    moves = last_moves(passes, index)
    if moves is None or not result.success:
        return result
    info = {**result.info, "last_pass_moves_se": dict(zip(names, moves.tolist(), strict=True))}
    if not np.any(moves > SETTLE_LIMIT_SE):
        return dataclasses.replace(result, info=info)
    worst = int(np.nanargmax(moves))
    n_passes = result.info.get("passes", len(passes))
    message = (f"the filter's passes did not settle: pass {n_passes} moved {names[worst]} by "
               f"{moves[worst]:.2f} of its standard errors (limit {SETTLE_LIMIT_SE:g}); the "
               "estimate walks along a direction the data hardly determine and its se does "
               "not cover it")
    return dataclasses.replace(result, success=False, message=message,
                               info={**info, "settle_refused": True}, warnings=result.warnings)


def refused_by_verdict(result: EstimationResult) -> bool:
    """Whether ``result`` failed by a verdict on the filter's estimate: its passes' settling
    (:func:`settle_verdict`) or its gust verdict (``info['gust_verdict_refusal']``, said as
    the message), not by a diverged or non-finite filter."""
    if result.success:
        return False
    gust = result.info.get("gust_verdict_refusal")
    return bool(result.info.get("settle_refused")) or bool(gust and result.message == gust)
