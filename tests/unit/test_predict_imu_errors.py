"""``EstimationResult.predict`` of a fit with IMU errors, and the report that shows it.

The reference: :func:`aeroid.flights.simulate_suite` logs the raw IMU as ``(1 + s) truth +
b`` with drawn biases and scale factors. On a noise-free suite flight (raw readings, true
states) output-error with ``imu_errors=bias+scale`` fits them to 1e-6, so its prediction
must reproduce the raw readings, and the model's own outputs must differ from them by the
simulator's drawn sensor law.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from suite_flights import clean_suite_flight, truth_errors

from aeroid.errors import EstimatorError
from aeroid.estimation import make_estimator, predict
from aeroid.flights import reference_scenario
from aeroid.model import OUTPUT_CHANNELS
from aeroid.report import report_markdown
from baselines.output_error import OutputErrorEstimator

#: The prediction of the noise-free fit against the raw readings, relative to each
#: channel's RMS: measured largest 3.7e-8 (q, r; the fit's own residual).
PREDICT_RTOL = 1e-6
#: The same with the start fitted by :func:`aeroid.estimation.fitted_start` under the
#: sensor law (no ``initial_state`` in ``info``), at the true coefficients and errors:
#: measured largest 2.1e-7 (r).
START_RTOL = 1e-6
#: The model's own outputs against ``(raw - b) / (1 + s)`` with the simulator's drawn
#: errors: measured largest 5.9e-8 of a channel's RMS (the fit's residual again).
LAW_RTOL = 1e-6
#: The filters' prediction (their final IMU errors, the start fitted through the law)
#: against the raw readings: measured largest 2.0e-6 of a channel's RMS (p; the filters
#: recover the coefficients to 9e-6); without the IMU errors 2.5e-3 (p) to 0.11 (ax2).
FILTER_RTOL = 1e-5


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x * x)))


@pytest.fixture(scope="module")
def suite_fit():
    """Noise-free default suite (seed 3): raw IMU, true states; output-error's fit."""
    sim, flight = clean_suite_flight(seed=3)
    fit = OutputErrorEstimator(imu_errors="bias+scale").fit(flight, rng=0)
    assert fit.success, fit.message
    return sim, flight, fit


def test_predict_applies_the_fits_imu_errors(suite_fit):
    sim, flight, fit = suite_fit
    frame = fit.predict(flight)
    for c in OUTPUT_CHANNELS:
        np.testing.assert_allclose(frame[c].to_numpy(), flight[c], rtol=0,
                                   atol=PREDICT_RTOL * _rms(flight[c]), err_msg=c)
    assert frame.attrs["imu_errors"] == fit.info["imu_errors"]
    assert frame.attrs["imu_errors_note"].startswith("IMU errors of the fit applied")


def test_without_the_imu_errors_the_prediction_misses_by_the_sensor_law(suite_fit):
    """The model's own outputs: the raw readings less the simulator's drawn b and s."""
    sim, flight, fit = suite_fit
    bare = predict(fit, flight, imu_errors=False)
    assert bare.attrs["imu_errors"] == {}
    assert "not applied" in bare.attrs["imu_errors_note"]
    truth = truth_errors(sim)
    for c in OUTPUT_CHANNELS:
        b, s = truth[f"b{c}"], truth[f"s{c}"]
        model = bare[c].to_numpy()
        miss = flight[c] - model
        # at least the bias's size (the scale factor adds s * model on top) ...
        assert np.max(np.abs(miss)) >= 0.5 * abs(b), c
        # ... and exactly the drawn sensor law
        np.testing.assert_allclose(miss, s * model + b, rtol=0,
                                   atol=LAW_RTOL * _rms(flight[c]), err_msg=c)


def test_fitted_start_uses_the_sensor_law(suite_fit):
    """A fit without a start of its own (the filters): p q r fitted through the law."""
    sim, flight, fit = suite_fit
    info = {k: v for k, v in fit.info.items() if k != "initial_state"}
    result = dataclasses.replace(fit, theta=reference_scenario().coefficient_vector,
                                 info={**info, "imu_errors": truth_errors(sim)})
    frame = result.predict(flight)
    assert frame.attrs["initial_state_from"].startswith("first sample, p q r fitted")
    for c in OUTPUT_CHANNELS:
        np.testing.assert_allclose(frame[c].to_numpy(), flight[c], rtol=0,
                                   atol=START_RTOL * _rms(flight[c]), err_msg=c)


@pytest.mark.parametrize("method", ["ekf", "ukf"])
def test_filters_prediction_applies_their_imu_errors(suite_fit, method):
    """The filters fit no start: p q r are fitted to the raw readings through the law."""
    _, flight, _ = suite_fit
    fit = make_estimator(method, {"imu_errors": "bias+scale"}).fit(flight, rng=0)
    assert fit.success, fit.message
    frame = fit.predict(flight)
    assert frame.attrs["initial_state_from"].startswith("first sample, p q r fitted")
    bare = predict(fit, flight, imu_errors=False)
    for c in OUTPUT_CHANNELS:
        scale = _rms(flight[c])
        np.testing.assert_allclose(frame[c].to_numpy(), flight[c], rtol=0,
                                   atol=FILTER_RTOL * scale, err_msg=c)
        assert np.max(np.abs(bare[c].to_numpy() - flight[c])) > 100 * FILTER_RTOL * scale, c


@pytest.mark.parametrize(("errors", "match"), [
    ({"bzz": 0.1}, "names 'bzz', not a bias"),
    ({"xax1": 0.1}, "names 'xax1', not a bias"),
    ({"bax1": float("nan")}, r"\['bax1'\] must be a finite number"),
    ({"sq": "big"}, r"\['sq'\] must be a finite number"),
])
def test_malformed_imu_errors_are_refused_in_one_line(suite_fit, errors, match):
    _, flight, fit = suite_fit
    result = dataclasses.replace(fit, info={**fit.info, "imu_errors": errors})
    with pytest.raises(EstimatorError, match=match) as caught:
        result.predict(flight)
    assert "\n" not in str(caught.value)


def test_report_says_the_imu_errors_were_applied(suite_fit):
    _, flight, fit = suite_fit
    frame = fit.predict(flight)
    text = report_markdown(fit, flight, [], prediction=frame)
    assert "IMU errors of the fit applied: reading = (1 + s) model + b (18 values)" in text
    # the errors' table: every estimate with its standard error, as the fit has them
    rows = {line.split(" | ")[0].strip("| "): line for line in text.splitlines()
            if line.startswith("| b") or line.startswith("| s")}
    assert list(rows) == list(fit.info["imu_errors"])
    for name, line in rows.items():
        estimate, stderr = (float(v) for v in line.strip("| ").split(" | ")[1:])
        assert estimate == pytest.approx(fit.info["imu_errors"][name], rel=1e-5)
        assert stderr == pytest.approx(fit.info["imu_error_stderr"][name], rel=1e-5)
