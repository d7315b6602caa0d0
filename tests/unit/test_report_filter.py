"""The gust filters' figures are the filter's fit (issue 26, "see the fit").

Reference: the filters' own innovations, taken from the result before the fit check
drops them (a spy on :func:`aeroid.estimation.apply_fit_check`, as the estimator calls
it): the report's one-step predictions, made again from the filtered states the result
keeps by aeroid's numba model, must give the same innovations as filter-error's compiled
CasADi filter and the EKF's. Known wrong: the open-loop still-air simulation in Dryden
turbulence, which the numbers must show far from the noise.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import aeroid.estimation._estimator as estimator_module
from aeroid.estimation import get_estimator, predict
from aeroid.estimation._fitcheck import RATIO_LIMIT
from aeroid.flights import GaussianNoise, Wind, simulate
from aeroid.model import OUTPUT_CHANNELS
from aeroid.report import fit_view, write_report
from aeroid.report._filter_steps import filter_prediction

#: The one-step predictions against the filters' innovations: the same model in numba
#: and in compiled CasADi (measured 1.5e-12 of an innovation's RMS, p; 1e-13 elsewhere).
INNOVATION_RTOL = 1e-9
#: The open-loop still-air simulation in Dryden sd 3 m/s: its worst channel against the
#: noise (measured 77x, p).
OPEN_LOOP_MIN = 10.0


@pytest.fixture(scope="module")
def gusty(reference_scenario):
    s = reference_scenario
    m = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=(3.0, 4.0, 0.0),
                                                   turbulence_sd_mps=3.0, scale_length_m=533.4))
    return simulate(s.airframe, s.coefficient_vector, m, GaussianNoise(), rng=1)


def _fit_with_innovations(name, options, flight):
    """The fit and the innovations its fit check read (before it drops them)."""
    captured: dict[str, np.ndarray] = {}
    original = estimator_module.apply_fit_check

    def spy(result, *args, **kwargs):
        captured.update(result.info.get("fit_residuals", {}))
        return original(result, *args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(estimator_module, "apply_fit_check", spy)
        result = get_estimator(name)(**options).fit(flight, rng=1)
    assert set(OUTPUT_CHANNELS) <= set(captured)
    return result, captured


@pytest.fixture(scope="module")
def fem(gusty):
    return _fit_with_innovations("filter-error", {}, gusty)


@pytest.fixture(scope="module")
def ekf(gusty):
    """The EKF's default (``gust_stderr = one-step``): its reported estimate is judged by
    filter-error's filter run there, over the whole record; that filter is drawn."""
    return _fit_with_innovations("ekf", {"gust_sd_mps": 3.0}, gusty)


@pytest.fixture(scope="module")
def ekf_own(gusty):
    """The EKF's own estimate and innovations (the second half, what its fit check reads)."""
    return _fit_with_innovations("ekf", {"gust_sd_mps": 3.0, "gust_stderr": "innovations"},
                                 gusty)


def _levels(result):
    return {c: float(result.info["fit_check"]["noise_sd"][c]) for c in OUTPUT_CHANNELS}


@pytest.mark.parametrize("which", ["fem", "ekf", "ekf_own"])
def test_the_one_step_predictions_are_the_filter_s(which, request, gusty) -> None:
    result, innovations = request.getfixturevalue(which)
    assert result.success, result.message
    frame = predict(result, gusty)
    outputs, why = filter_prediction(result, gusty, frame.attrs["input"],
                                     frame.attrs["delay_s"])
    assert outputs is not None and why == ""
    n = gusty.n_samples
    assert np.all(np.isnan(outputs[0]))  # the fit's start is not kept
    for j, name in enumerate(OUTPUT_CHANNELS):
        reference = innovations[name]
        rows = np.arange(n - reference.size, n)[1:]  # filter-error: all; the EKF: 2nd half
        ours = gusty[name][rows] - outputs[rows, j]
        theirs = reference[rows - (n - reference.size)]
        scale = float(np.sqrt(np.mean(theirs ** 2)))
        assert np.max(np.abs(ours - theirs)) < INNOVATION_RTOL * scale, name
    view = fit_view(result, gusty, frame, _levels(result))
    assert view.kind == "filter" and view.wind is not None
    for name, drawn in view.channels.items():
        assert drawn.ratio < RATIO_LIMIT, (name, drawn.ratio)  # the fit the check passed
        np.testing.assert_array_equal(drawn.second, frame[name].to_numpy())
    assert max(c.second_ratio for c in view.channels.values()) > OPEN_LOOP_MIN
    # the ratio is the captured innovations' over the samples the fit check read
    reference = innovations["q"] if which == "ekf_own" else innovations["q"][1:]
    expected = float(np.sqrt(np.mean(reference ** 2))) / _levels(result)["q"]
    assert view.channels["q"].ratio == pytest.approx(expected, rel=1e-9)


def test_the_filter_report_says_what_it_draws(fem, gusty, tmp_path) -> None:
    result, _ = fem
    text = write_report(result, gusty, tmp_path / "fem").read_text()
    assert "Drawn from the filter: its one-step predictions" in text
    assert "![q [rad/s]: measured, filter's one-step prediction and innovation](q.png)" in text
    assert "| channel | filter's innovation | open-loop model |" in text
    assert (tmp_path / "fem" / "wind.png").is_file()


def test_filters_that_keep_too_little_are_drawn_open_loop(ekf_own, fem, gusty) -> None:
    result, _ = ekf_own
    frame = predict(result, gusty)
    cases = {
        "sigma points": dataclasses.replace(result, estimator="ukf"),
        "IMU errors": dataclasses.replace(result, info={**result.info,
                                                        "imu_errors": {"bax1": 0.1}}),
        "a steady wind": dataclasses.replace(result, info={**result.info,
                                                           "wind_ned_mps": [1.0, 0.0, 0.0]}),
    }
    cases["dryden gust states"] = dataclasses.replace(
        fem[0], info={**fem[0].info, "gust_model": "dryden"})
    for words, case in cases.items():
        outputs, why = filter_prediction(case, gusty, frame.attrs["input"],
                                         frame.attrs["delay_s"])
        assert outputs is None and words in why and "\n" not in why
    view = fit_view(cases["sigma points"], gusty, frame, _levels(result))
    assert view.kind == "open-loop" and view.wind is not None  # the filter's gusts
    np.testing.assert_array_equal(view.wind[0], result.info["gust_ned_mps"])
    assert any(line.startswith("Not drawn from the filter: ukf's one-step prediction")
               for line in view.lines)


def test_filter_error_s_steady_wind_is_where_its_gusts_decay_to(reference_scenario) -> None:
    s = reference_scenario
    m = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=(3.0, 4.0, 0.0),
                                                   turbulence_sd_mps=1.0, scale_length_m=533.4))
    flight = simulate(s.airframe, s.coefficient_vector, m, GaussianNoise(), rng=1)
    result, innovations = _fit_with_innovations("filter-error", {"estimate_wind": True},
                                                flight)
    assert result.info["wind_ned_mps"] is not None
    frame = predict(result, flight)
    assert frame.attrs["air"] == "steady"  # the open-loop trace in the fitted wind
    outputs, _ = filter_prediction(result, flight, frame.attrs["input"],
                                   frame.attrs["delay_s"])
    assert outputs is not None
    for j, name in enumerate(OUTPUT_CHANNELS):  # measured 1.5e-12
        theirs = innovations[name][1:]
        ours = flight[name][1:] - outputs[1:, j]
        assert np.max(np.abs(ours - theirs)) < INNOVATION_RTOL * np.sqrt(np.mean(theirs ** 2))


def test_a_one_step_fit_is_drawn_from_the_filter_that_judged_it(ekf, gusty) -> None:
    """The one-step estimate's filter (filter-error's, run at the reported estimate) is
    the same for the EKF and the UKF: a UKF result drawn from it, not open-loop."""
    result, innovations = ekf
    as_ukf = dataclasses.replace(result, estimator="ukf")
    frame = predict(as_ukf, gusty)
    outputs, why = filter_prediction(as_ukf, gusty, frame.attrs["input"],
                                     frame.attrs["delay_s"])
    assert outputs is not None and why == ""
    ours = gusty["q"][1:] - outputs[1:, OUTPUT_CHANNELS.index("q")]
    theirs = innovations["q"][1:]
    assert np.max(np.abs(ours - theirs)) < INNOVATION_RTOL * np.sqrt(np.mean(theirs ** 2))
