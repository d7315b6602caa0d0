"""The user's holds and priors tested in the EKF/UKF with gust states (issue 26; private).

In turbulence a pitch-plane coefficient held wrong (Cma, Cza, Cmq) is taken up by the
gust states: the innovations stay white and the gust verdict passes it. Filter-error
tests what the user asserts by a likelihood ratio against a fit with the asserted
coefficients free (:mod:`baselines._fem_holds`). The filters' own likelihood is not
maximised over the coefficients (they are states), so the test is filter-error's, on
filter-error's likelihood with the gusts integrated out, started where the filter ended:
the held fit is converged from the reported point (the one-step estimate, or the
filter's own; :func:`baselines._fem_holds.hold_test_from`), then freed and refitted
(:func:`baselines._fem_holds.hold_test`). The same limit (``LR_ALPHA`` = 0.01), the same
``info['hold_test']`` and the same one-line refusal as filter-error's.

Measured (``benchmarks/bench_gust_filters.py --holds``, ``results/gust_holds_still.md``,
``gust_holds_steady.md``: Dryden sd 3 m/s alone and with a 5 m/s steady wind, seeds 1-10
each, the EKF's defaults): right holds of Cma, Cza, Cmq refused 0/50 (LR mean 1.05, at
most 4.28; limit 6.63), Cma held 0.7x or 1.3x and Cza 0.7x 30/30 (LR at least 19.4), Cmq
1.3x 1/10 (its se is ~20 % of it there: as filter-error's 9/80).

Not tested (said in one line): where filter-error's filter is not built for the fit
(``estimate_wind``, IMU-error, aiding, air-data or sensor-position states, saturated
samples; :func:`baselines._kalman_information.refuse`).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from aeroid.estimation import EstimationResult
from aeroid.flights import Flight
from baselines import _fem_fit, _fem_holds, _fem_setup
from baselines.filter_error import FilterErrorEstimator

#: Filter-error's own iteration limit and tolerance (its defaults).
_FE = FilterErrorEstimator()


def tested(holds: Any) -> tuple[str, ...]:
    """The names the test would free (``_fem_holds.tested_constraints``)."""
    return tuple(_fem_holds.tested_constraints(holds))


def untested_warning(who: str, holds: Any, why: str) -> tuple[str, ...]:
    """The one line saying the holds and priors were not tested (none when none)."""
    names = tested(holds)
    if not names:
        return ()
    return (f"{who}: the likelihood-ratio test of {', '.join(names)} was not done: {why}; "
            "they are assumed, not tested",)


def with_hold_test(who: str, result: EstimationResult, problem: _fem_fit.Problem,
                   p: np.ndarray, noise: _fem_setup.Noise, R: np.ndarray, holds: Any,
                   flight: Flight) -> EstimationResult:
    """``result`` with the likelihood-ratio test of ``holds`` (module docstring) from the
    held point ``p`` (the scaled parameters of ``problem``, filter-error's likelihood with
    the holds); refused in one line when the data refuse them, ``info['hold_test']``."""
    test = _fem_holds.hold_test_from(problem, p, R, holds, flight.airframe.prior_vector(),
                                     update_noise=noise.update, r_floor=noise.floor,
                                     max_iterations=_FE.max_iterations, tol=_FE.tol, who=who)
    if test is None:
        return result
    info = {**result.info, "hold_test": test.figures}
    if result.success and not test.ok:
        return dataclasses.replace(result, success=False, message=test.message, info=info)
    said = (test.message,) if test.message else ()  # not done, or refused a refused fit
    return dataclasses.replace(result, info=info, warnings=(*result.warnings, *said))
