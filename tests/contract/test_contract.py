"""Contract suite: every registered estimator (built-ins and entry points) obeys the interface.

Parametrised over ``aeroid.estimation.available()`` at collection time, so estimators
registered later through the ``aeroid.estimators`` entry-point group are checked too,
each with a cheap configuration (``FAST_OPTIONS``; unknown estimators run with their
defaults; options an estimator does not have are dropped).
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pandas as pd
import pytest

from aeroid.errors import FlightError
from aeroid.estimation import (
    EstimationResult,
    ProgressEvent,
    available,
    get_estimator,
    make_estimator,
)
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
#: The history axis of every estimator aeroid ships (None: it keeps no history, because
#: equation-error is closed-form least squares with nothing to iterate). A plug-in not
#: listed here may keep none; its history test is then skipped, not passed.
HISTORY_AXIS: dict[str, str | None] = {
    "eam-pso": "iteration", "ebm-pso": "iteration", "sebm-pso": "iteration",
    "pyswarms": "iteration", "output-error": "iteration", "ekf": "time", "ukf": "time",
    "equation-error": None,
    "filter-error": "iteration",
}
METHODS = sorted(available())
SEED = 123


def _estimator(name: str):
    allowed = set(get_estimator(name).option_names())
    options = {k: v for k, v in FAST_OPTIONS.get(name, {}).items() if k in allowed}
    return make_estimator(name, options)


def _copy(flight: Flight, metadata: dict | None = None) -> Flight:
    meta = copy.deepcopy(flight.metadata) if metadata is None else metadata
    return Flight(flight.data.copy(deep=True), flight.airframe, meta)


def _without_truth(flight: Flight) -> Flight:
    meta = {k: v for k, v in copy.deepcopy(flight.metadata).items() if not k.startswith("true")}
    return _copy(flight, meta)


def _poisoned_truth(flight: Flight) -> Flight:
    meta = copy.deepcopy(flight.metadata)
    meta["true_coefficients"] = dict.fromkeys(meta["true_coefficients"], 1e6)
    meta["true_accel_positions_m"] = [[9.0, 9.0, 9.0], [9.0, 9.0, 9.0]]
    return _copy(flight, meta)


@pytest.fixture(scope="module", params=METHODS)
def fitted(request, paper_flight):
    """The fits of one method, all with the same seed: on a flight (kept with a pristine
    copy), again with a progress listener, and on copies without and with false truth."""
    name = request.param
    flight = _copy(paper_flight)
    pristine = _copy(paper_flight)
    est = _estimator(name)
    events: list[ProgressEvent] = []
    return {
        "name": name, "flight": flight, "pristine": pristine,
        "first": est.fit(flight, rng=SEED),
        "listened": est.fit(flight, rng=SEED, progress=events.append), "events": events,
        "no_truth": est.fit(_without_truth(paper_flight), rng=SEED),
        "false_truth": est.fit(_poisoned_truth(paper_flight), rng=SEED),
    }


def _assert_identical(a: EstimationResult, b: EstimationResult) -> None:
    np.testing.assert_array_equal(a.theta, b.theta)
    if a.stderr is None:
        assert b.stderr is None
    else:
        np.testing.assert_array_equal(a.stderr, b.stderr)
    assert a.cost == b.cost or (math.isnan(a.cost) and math.isnan(b.cost))
    assert (a.success, a.message, a.warnings) == (b.success, b.message, b.warnings)
    assert (a.n_evaluations, a.n_iterations) == (b.n_evaluations, b.n_iterations)


def test_at_least_the_papers_three_are_registered() -> None:
    assert {"eam-pso", "ebm-pso", "sebm-pso"} <= set(METHODS)


def test_returns_an_estimation_result_with_the_nine_names(fitted) -> None:
    result = fitted["first"]
    assert isinstance(result, EstimationResult)
    assert result.estimator == fitted["name"]
    assert tuple(result.names) == NAMES
    assert result.theta.shape == (len(NAMES),)
    assert result.wall_time_s > 0
    assert isinstance(result.success, bool)
    if result.success:
        assert np.all(np.isfinite(result.theta))
    else:
        assert result.message
    assert isinstance(result.warnings, tuple)
    assert all(isinstance(w, str) and w and "\n" not in w for w in result.warnings)


def test_does_not_modify_the_flight(fitted) -> None:
    flight, pristine = fitted["flight"], fitted["pristine"]
    pd.testing.assert_frame_equal(flight.data, pristine.data, check_exact=True)
    assert flight.metadata == pristine.metadata
    assert flight.airframe == pristine.airframe


def test_same_seed_and_a_progress_listener_give_identical_results(fitted) -> None:
    _assert_identical(fitted["first"], fitted["listened"])


def test_progress_events_are_well_formed(fitted) -> None:
    for event in fitted["events"]:
        assert isinstance(event, ProgressEvent)
        assert 0 <= event.done <= event.total and event.total >= 1
        assert isinstance(event.stage, str)


def test_never_reads_the_truth(fitted) -> None:
    """Bit-identical results with the flight's true values absent, or false."""
    _assert_identical(fitted["first"], fitted["no_truth"])
    _assert_identical(fitted["first"], fitted["false_truth"])


def test_history_is_well_formed(fitted) -> None:
    name, result, flight = fitted["name"], fitted["first"], fitted["flight"]
    history = result.history
    if name in HISTORY_AXIS and HISTORY_AXIS[name] is None:
        assert not history
        return
    if not history:
        assert name not in HISTORY_AXIS, f"{name} lost its history"
        pytest.skip(f"{name} keeps no history")
    assert history["axis"] == HISTORY_AXIS.get(name, history["axis"])
    n = len(history["step"])
    assert n >= 2
    assert np.shape(history["theta"]) == (n, len(NAMES))
    for key in ("cost", "theta_sd"):
        if key in history:
            assert len(history[key]) == n
    if history["axis"] == "time":
        np.testing.assert_array_equal(history["step"], flight.t)
    else:  # iteration numbers, counted from 0 (the start) or 1
        step = np.asarray(history["step"])
        assert step[0] in (0, 1) and np.all(np.diff(step) == 1)


@pytest.mark.parametrize("name", METHODS)
@pytest.mark.parametrize("channel", ["p", "az1"])
def test_nan_in_a_used_channel_is_refused_before_the_method_runs(name, channel, paper_flight,
                                                                 monkeypatch) -> None:
    flight = _copy(paper_flight)
    flight.data.loc[100, channel] = np.nan
    est = _estimator(name)

    def run(self, flight, rng):
        raise AssertionError("run() must not see an invalid flight")

    monkeypatch.setattr(type(est), "run", run)
    with pytest.raises(FlightError, match=rf"'{channel}'.*row 100"):
        est.fit(flight, rng=SEED)
