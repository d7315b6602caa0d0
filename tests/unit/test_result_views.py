"""EstimationResult's views: predict, to_frame, the short repr and HTML, and JSON info."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from aeroid.estimation import (
    EstimationResult,
    cramer_rao_sd,
    data_floor,
    json_safe,
    make_estimator,
)
from aeroid.flights import PaperNoise
from aeroid.model import NAMES, OUTPUT_CHANNELS

#: predict at the true coefficients against the simulator's noise-free outputs, relative
#: to each channel's RMS: both integrate the same equations with RK4 at the simulator's
#: 8 steps per sample from the same state, so only round-off separates them.
PREDICT_RTOL = 1e-8
#: The same with the fitted start (p, q, r fitted to the outputs): the least squares
#: recovers the true rates from noise-free data to round-off (7e-14 measured).
FITTED_START_RTOL = 1e-8


def _truth_result(flight, substeps, **info) -> EstimationResult:
    return EstimationResult(estimator="truth", theta=flight.true_coefficients,
                            info={"options": {"substeps": substeps}, **info})


def _relative_error(frame, flight) -> np.ndarray:
    measured = np.column_stack([flight[c] for c in OUTPUT_CHANNELS])
    rms = np.sqrt(np.mean(measured**2, axis=0))
    return np.max(np.abs(frame[list(OUTPUT_CHANNELS)].to_numpy() - measured), axis=0) / rms


def test_predict_reproduces_the_simulators_noise_free_outputs(clean_flight,
                                                              reference_scenario) -> None:
    steps = reference_scenario.manoeuvre.truth_substeps
    result = _truth_result(clean_flight, steps, initial_state=clean_flight.states()[0])
    frame = result.predict(clean_flight)
    assert list(frame.columns) == list(OUTPUT_CHANNELS)
    np.testing.assert_array_equal(frame.index.to_numpy(), clean_flight.t)
    assert frame.index.name == "t"
    assert frame.attrs["input"] == "hold" and frame.attrs["substeps"] == steps
    assert np.all(_relative_error(frame, clean_flight) < PREDICT_RTOL)


def test_predict_fits_the_start_of_a_method_without_one(clean_flight,
                                                        reference_scenario) -> None:
    steps = reference_scenario.manoeuvre.truth_substeps
    frame = _truth_result(clean_flight, steps).predict(clean_flight)
    assert "fitted" in frame.attrs["initial_state_from"]
    assert np.all(_relative_error(frame, clean_flight) < FITTED_START_RTOL)
    # at a wrong estimate the model no longer reproduces the data
    wrong = dataclasses.replace(_truth_result(clean_flight, steps),
                                theta=clean_flight.true_coefficients * 1.2)
    assert np.max(_relative_error(wrong.predict(clean_flight), clean_flight)) > 1e-2


def test_predict_uses_the_fits_positions_and_input(clean_flight) -> None:
    x0 = clean_flight.states()[0]
    moved = np.array(clean_flight.airframe.accel_positions) + [[0.1, 0, 0], [0, 0, 0]]
    base = _truth_result(clean_flight, 8, initial_state=x0)
    shifted = _truth_result(clean_flight, 8, initial_state=x0, accel_positions_m=moved)
    a, b = base.predict(clean_flight), shifted.predict(clean_flight)
    # triad 2 and the rates are unchanged, triad 1 moved: its outputs change
    np.testing.assert_array_equal(a[["ax2", "ay2", "az2", "p", "q", "r"]].to_numpy(),
                                  b[["ax2", "ay2", "az2", "p", "q", "r"]].to_numpy())
    assert np.max(np.abs(a["az1"] - b["az1"])) > 1e-3
    events = _truth_result(clean_flight, 8, initial_state=x0,
                           options={"substeps": 8, "input": "events", "delay_s": 0.001})
    frame = events.predict(clean_flight)
    assert frame.attrs["input"] == "events" and frame.attrs["delay_s"] == 0.001


def test_output_error_predict_equals_its_own_residuals(paper_flight) -> None:
    """Two evaluations of one model: the CasADi record output-error fits and the numpy
    forward model of predict, with output-error's fitted start and positions."""
    result = make_estimator("output-error", {}).fit(paper_flight, rng=0)
    assert result.success, result.message
    frame = result.predict(paper_flight)
    assert frame.attrs["initial_state_from"].startswith("the fit's")
    measured = np.column_stack([paper_flight[c] for c in OUTPUT_CHANNELS])
    rms = np.sqrt(np.mean((measured - frame.to_numpy()) ** 2, axis=0))
    reported = [result.info["fit_check"]["residual_rms"][c] for c in OUTPUT_CHANNELS]
    np.testing.assert_allclose(rms, reported, rtol=1e-6)


def test_to_frame_without_and_with_the_flight(paper_flight, clean_flight) -> None:
    result = EstimationResult(estimator="x", theta=paper_flight.true_coefficients * 1.01,
                              stderr=np.arange(1.0, 10.0))
    bare = result.to_frame()
    assert list(bare.index) == list(NAMES) and list(bare.columns) == ["estimate", "stderr"]
    np.testing.assert_array_equal(bare["stderr"], np.arange(1.0, 10.0))
    floor = data_floor(paper_flight, result.theta)
    full = result.to_frame(paper_flight, floor=floor)
    np.testing.assert_array_equal(full["prior"], paper_flight.airframe.prior_vector())
    np.testing.assert_allclose(full["error_pct"], 1.0, rtol=1e-9)
    assert np.all(full["floor"] > 0)
    # the data floor is the Cramér-Rao floor of the data's noise levels: the floor of the
    # noise the flight was simulated with (per-channel sd) up to the estimate of those
    # levels (measured ratio 0.91-1.05, seed 1)
    known = cramer_rao_sd(clean_flight, PaperNoise(), noise_form="homoscedastic",
                          estimate_initial=("p", "q", "r"))
    ratio = full["floor"].to_numpy() / known
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio
    assert data_floor(clean_flight, result.theta) is None  # noise-free: no floor
    assert "floor" not in result.to_frame(clean_flight).columns
    assert np.all(np.isnan(EstimationResult(estimator="x", theta=np.zeros(9))
                           .to_frame()["stderr"]))


def test_repr_is_short_and_html_has_the_table(paper_flight) -> None:
    info = {"state": np.zeros((5000, 9)), "fit_check": {"ratio": {"p": 1.1}, "worst": "p",
                                                         "limit": 3.0}}
    result = EstimationResult(estimator="ekf", theta=np.ones(9), stderr=np.ones(9),
                              info=info, warnings=("one <thing>",))
    text = repr(result)
    assert "\n" not in text and len(text) < 200 and "ekf" in text and "1 warning" in text
    page = result._repr_html_()
    assert all(f"<th>{name}</th>" in page for name in NAMES)
    assert "one &lt;thing&gt;" in page and "fit check" in page


def test_json_info_is_json_safe_and_names_what_it_leaves_out() -> None:
    cov = np.diag(np.arange(1.0, 10.0))
    cov[0, 1] = cov[1, 0] = 0.5
    info = {"series": np.zeros((2000, 3)), "law": {"a": np.array([1.0, np.nan])},
            "passes": np.int64(3), "flag": np.bool_(True), "pair": ("a", 1.5),
            "fit_check": {"ratio": {"p": np.float64(np.inf)}, "new_key": [1, 2]}}
    result = EstimationResult(estimator="x", theta=np.ones(9), covariance=cov, info=info)
    out = result.to_json_dict()["info"]
    json.dumps(out, allow_nan=False)  # raises on NaN or a numpy type
    assert out["omitted"] == ["series (2000, 3)"] and "series" not in out
    assert out["law"] == {"a": [1.0, None]} and out["passes"] == 3 and out["flag"] is True
    assert out["pair"] == ["a", 1.5]
    assert out["fit_check"] == {"ratio": {"p": None}, "new_key": [1, 2]}
    assert out["correlation"][0][1] == pytest.approx(0.5 / np.sqrt(2.0))
    assert json_safe(np.float32(2.5)) == 2.5


def test_ekf_json_carries_passes_noise_law_positions_and_fit_check(paper_flight) -> None:
    result = make_estimator("ekf", {"max_passes": 2}).fit(paper_flight, rng=0)
    out = json.loads(json.dumps(result.to_json_dict(), allow_nan=False))["info"]
    assert out["passes"] == result.info["passes"]
    assert len(out["noise_law"]["a"]) == len(OUTPUT_CHANNELS)
    assert np.array(out["accel_positions_m"]).shape == (2, 3)
    assert set(out["fit_check"]["ratio"]) == set(OUTPUT_CHANNELS)
    assert any(item.startswith("state ") for item in out["omitted"])
    assert "filter passes: " in result.summary()


#: predict with ``law`` on the continuous-relay flight: the switch instants are located on
#: the roll angle interpolated between samples, not on the truth's (measured 1.7e-7).
LAW_RTOL = 1e-6


def test_predict_uses_the_fits_input_between_samples() -> None:
    """On a flight whose relay switched between samples (continuous evaluation), the
    model with the true switch instants (``events``) or the fin law (``law``) reproduces
    the simulator; the held deflection misses by a third of a channel's RMS."""
    from pathlib import Path

    from aeroid.flights import NoNoise, load_scenario, simulate_scenario

    path = Path(__file__).resolve().parents[2] / "studies/scenarios/continuous_relay.toml"
    scenario = load_scenario(path)
    flight = simulate_scenario(scenario, NoNoise(), rng=0)
    steps = scenario.manoeuvre.truth_substeps

    def error(input_mode: str) -> float:
        result = _truth_result(flight, steps, initial_state=flight.states()[0],
                               options={"substeps": steps, "input": input_mode})
        return float(np.max(_relative_error(result.predict(flight), flight)))

    assert error("events") < PREDICT_RTOL
    assert error("law") < LAW_RTOL
    assert error("hold") > 0.1
