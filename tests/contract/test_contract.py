"""Contract suite: every registered estimator (built-ins and entry points) obeys the interface.

Parametrised over ``aeroid.estimators.available()`` at collection time, so estimators
registered later through the ``aeroid.estimators`` entry-point group are checked too,
each with a cheap configuration (``FAST_OPTIONS``; unknown estimators run with their
defaults; options an estimator does not have are dropped).
"""

from __future__ import annotations

import copy

import numpy as np
import pandas as pd
import pytest

from aeroid.errors import FlightError
from aeroid.estimation._interface import EstimationResult, available, get_estimator, make_estimator
from aeroid.flights._flight import Flight
from aeroid.model._coefficients import NAMES

#: Cheap configurations (each fit well under 10 s on 2 busy cores).
FAST_OPTIONS: dict[str, dict[str, object]] = {
    "eam-pso": {"n_particles": 12, "n_iterations": 3},
    "ebm-pso": {"n_particles": 30, "n_iterations": 20},
    "sebm-pso": {"n_particles": [10, 10, 10, 10], "n_iterations": 20},
    "pyswarms": {"n_particles": 20, "n_iterations": 10},
    "output-error": {"max_iterations": 5},
}
METHODS = sorted(available())
SEED = 123


def _estimator(name: str):
    allowed = set(get_estimator(name).option_names())
    options = {k: v for k, v in FAST_OPTIONS.get(name, {}).items() if k in allowed}
    return make_estimator(name, options)


def _copy(flight: Flight) -> Flight:
    return Flight(flight.data.copy(deep=True), flight.airframe, copy.deepcopy(flight.metadata))


@pytest.fixture(scope="module", params=METHODS)
def fitted(request, paper_flight):
    """(name, flight given, its pristine copy, two results with the same seed)."""
    name = request.param
    flight = _copy(paper_flight)
    pristine = _copy(paper_flight)
    est = _estimator(name)
    first = est.fit(flight, rng=SEED)
    second = est.fit(flight, rng=SEED)
    return name, flight, pristine, first, second


def test_at_least_the_papers_three_are_registered() -> None:
    assert {"eam-pso", "ebm-pso", "sebm-pso"} <= set(METHODS)


def test_returns_an_estimation_result_with_the_nine_names(fitted) -> None:
    name, _, _, result, _ = fitted
    assert isinstance(result, EstimationResult)
    assert result.estimator == name
    assert tuple(result.names) == NAMES
    assert result.theta.shape == (9,)
    assert result.wall_time_s > 0
    assert isinstance(result.success, bool)
    if result.success:
        assert np.all(np.isfinite(result.theta))
    else:
        assert result.message


def test_does_not_modify_the_flight(fitted) -> None:
    _, flight, pristine, _, _ = fitted
    pd.testing.assert_frame_equal(flight.data, pristine.data, check_exact=True)
    assert flight.metadata == pristine.metadata
    assert flight.airframe == pristine.airframe


def test_same_seed_gives_identical_estimates(fitted) -> None:
    _, _, _, first, second = fitted
    np.testing.assert_array_equal(first.theta, second.theta)
    assert first.success == second.success


def test_history_is_well_formed(fitted) -> None:
    _, _, _, result, _ = fitted
    history = result.history
    if not history:
        return
    assert history["axis"] in ("iteration", "time")
    n = len(history["step"])
    assert np.shape(history["theta"]) == (n, 9)
    for key in ("cost", "theta_sd"):
        if key in history:
            assert len(history[key]) == n


@pytest.mark.parametrize("name", METHODS)
@pytest.mark.parametrize("channel", ["p", "az1"])
def test_nan_in_a_used_channel_is_never_a_silent_number(name, channel, paper_flight) -> None:
    flight = _copy(paper_flight)
    flight.data.loc[100, channel] = np.nan
    try:
        result = _estimator(name).fit(flight, rng=SEED)
    except FlightError as exc:
        assert channel in str(exc)
        return
    assert not result.success
