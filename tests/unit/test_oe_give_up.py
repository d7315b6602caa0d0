"""Output-error gives up a start that cannot reach a converged start's cost (give_up).

References: the rule's closed form on made-up cost histories (the projected cost is the
last cost less the pace over :data:`PACE_ITERATIONS` iterations times the iterations
left); the fit without the rule (every start to its end): what the fit reports is the same
(benchmarks/bench_oe_give_up.py asserts it on every test fit it applies to).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from suite_flights import clean_suite_flight

import baselines.output_error as oe
from baselines._oe_starts import PACE_ITERATIONS, give_up

#: A converged end's cost and its number of parameters (the margin).
TARGET, N_P = -1000.0, 30
EST = SimpleNamespace(max_iterations=50)


def _end(nll: float, converged: bool = True):
    return SimpleNamespace(nll=nll, converged=converged, p=np.zeros(N_P))


def _costs(first: float, per_iteration: float, n: int = PACE_ITERATIONS + 1) -> list:
    return [first - per_iteration * k for k in range(n)]


def test_a_crawling_start_is_given_up_with_its_projection():
    stop = give_up([_end(TARGET)], EST)
    costs = _costs(-100.0, 10.0)  # 10 per iteration, at -200 after 10 of 50
    said = stop(PACE_ITERATIONS, costs)
    # -200 - 10 x (50 - 10) = -600, not within 30 of -1000
    assert said == ("stopped after 10 iterations: at its pace (10 per iteration) its cost "
                    "-200 would be -600 at max_iterations (50), not within 30 of a "
                    "converged start's -1000")


@pytest.mark.parametrize(("first", "per_iteration", "why"), [
    (-100.0, 25.0, "its pace reaches -1350 by the limit"),
    (-975.0, 0.0, "within the margin of the converged cost"),
    (-1100.0, 0.0, "below the converged cost (a likelier end)"),
])
def test_a_start_that_can_still_reach_the_converged_cost_goes_on(first, per_iteration, why):
    stop = give_up([_end(TARGET)], EST)
    assert stop(PACE_ITERATIONS, _costs(first, per_iteration)) is None, why


def test_nothing_is_given_up_before_a_start_converged_or_a_pace_is_known():
    assert give_up([], EST) is None
    assert give_up([_end(TARGET, converged=False)], EST) is None
    stop = give_up([_end(TARGET, converged=False), _end(-500.0)], EST)  # the converged one
    assert stop(PACE_ITERATIONS - 1, _costs(-100.0, 1.0, PACE_ITERATIONS)) is None
    assert "of a converged start's -500" in stop(PACE_ITERATIONS, _costs(-100.0, 1.0))
    rising = _costs(-100.0, -1.0)  # a cost that rose: no pace, projected where it is
    assert "would be -90 at max_iterations" in stop(PACE_ITERATIONS, rising)


def test_the_equation_error_start_of_a_noise_free_suite_fit_is_given_up():
    """The fit of tests/unit/test_output_error_imu_errors.py: the prior start converges,
    the equation-error start is given up (it ran to its 50 iterations before) and the
    fit is the one without the rule, bit for bit."""
    _, flight = clean_suite_flight(seed=3)
    est = oe.OutputErrorEstimator(imu_errors="bias+scale")
    now = est.fit(flight, rng=0)
    assert now.success and list(now.info["start_stopped"]) == ["equation-error"]
    assert now.info["start_converged"] == [True, False]
    assert now.n_iterations < 50
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(oe, "give_up", lambda ends, est: None)
        before = est.fit(flight, rng=0)
    assert "start_stopped" not in before.info and before.n_iterations > now.n_iterations
    np.testing.assert_array_equal(now.theta, before.theta)
    np.testing.assert_array_equal(now.stderr, before.stderr)
    assert (now.message, now.warnings) == (before.message, before.warnings)
