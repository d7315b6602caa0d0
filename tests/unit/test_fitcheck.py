"""The fit check: residual RMS against the data's own noise level, per channel."""

from __future__ import annotations

import numpy as np
import pytest

import aeroid
from aeroid.estimation import EstimationResult
from aeroid.estimation._fitcheck import (
    RATIO_LIMIT,
    RESOLUTION,
    apply_fit_check,
    data_noise_levels,
    data_noise_sd,
    fit_check,
)

#: The ratio of white residuals to the estimated noise of the same white noise on 501
#: samples: the MAD estimator's relative standard error ~5 %, the RMS's ~3 %.
WHITE_RTOL = 0.2


def _result(residuals, **info) -> EstimationResult:
    return EstimationResult(estimator="x", theta=np.ones(aeroid.model.N_COEFFICIENTS),
                            info={"fit_residuals": residuals, **info})


def test_white_residuals_have_ratio_one_and_structure_shows(paper_flight) -> None:
    rng = np.random.default_rng(0)
    n = paper_flight.n_samples
    sd = {c: data_noise_sd(paper_flight, paper_flight[c]) for c in ("ay1", "az1")}
    check = fit_check(paper_flight, {"ay1": sd["ay1"] * rng.standard_normal(n),
                                     "az1": 10 * sd["az1"] * rng.standard_normal(n)})
    assert check["ratio"]["ay1"] == pytest.approx(1.0, rel=WHITE_RTOL)
    assert check["ratio"]["az1"] > 5.0 and check["worst"] == "az1"


def test_a_model_missing_the_data_fails_with_the_worst_channel(paper_flight) -> None:
    n = paper_flight.n_samples
    sd = data_noise_sd(paper_flight, paper_flight["q"])
    result = apply_fit_check(_result({"q": np.full(n, 8.0 * sd), "p": np.zeros(n)}),
                             paper_flight)
    assert not result.success
    assert result.message.startswith("the model does not fit the data: q residual RMS is 8")
    assert "fit_residuals" not in result.info
    assert result.info["fit_check"]["limit"] == RATIO_LIMIT


def test_noise_free_data_are_judged_at_their_resolution(clean_flight) -> None:
    """On a noise-free log the yardstick is the 4th differences' leakage (below 3e-5 of
    each channel's RMS, measured 2e-5 at most) or the floor: far below a tactical IMU's
    noise (1e-4 of the roll rate), never ten times it. A residual at 0.3 of it fits (and
    is not tested for whiteness: it is not the noise), at 5 times it does not."""
    n = clean_flight.n_samples
    levels = data_noise_levels(clean_flight)
    for name, level in levels.items():
        rms = float(np.sqrt(np.mean(clean_flight[name] ** 2)))
        assert level < 3e-5 * rms, name
    yardstick = max(levels["az1"], RESOLUTION * np.sqrt(np.mean(clean_flight["az1"] ** 2)))
    fine = apply_fit_check(_result({"az1": np.full(n, 0.3 * yardstick)}), clean_flight)
    coarse = apply_fit_check(_result({"az1": np.full(n, 5 * yardstick)}), clean_flight)
    assert fine.success and fine.info["fit_check"]["ratio"]["az1"] == pytest.approx(0.3)
    assert fine.info["fit_check"]["whiteness"] == {}  # a residual below the noise: untested
    assert not coarse.success


#: The continuous relay with Cl0 raised from 0.041 to 0.095: the steady roll rate
#: (Cl0 / Clp) rises 2.3x and the relay switches 76 times a second in the log.
DENSE_CL0 = 0.095
#: Known-noise tolerances of the yardstick on one 501-sample flight: the RMS of ~200
#: overlapping 4th differences has a relative sd of ~8 % (Gaussian); under the paper's
#: noise, proportional to the signal, the windows clear of a switch see q 17-25 % below
#: its average (measured on two seeds and both relays): a 30 % band.
GAUSSIAN_RTOL, PAPER_RTOL = 0.2, 0.3


@pytest.fixture(scope="module")
def dense_relay():
    import dataclasses
    from pathlib import Path

    path = Path(__file__).parents[2] / "studies" / "scenarios" / "continuous_relay.toml"
    scenario = aeroid.load_scenario(path)
    coefficients = list(scenario.coefficients)
    coefficients[aeroid.NAMES.index("Cl0")] = DENSE_CL0
    return dataclasses.replace(scenario, coefficients=tuple(coefficients))


@pytest.mark.parametrize(("noise", "rtol"), [("gaussian", GAUSSIAN_RTOL),
                                             ("paper", PAPER_RTOL)])
def test_yardstick_meets_known_noise_where_switches_are_dense(dense_relay, noise, rtol) -> None:
    """Each channel's level against the noise actually added (noisy minus noise-free log
    of the same seed), on a relay switching 76 times a second, where a 7-point smoother
    finds no sample clear of a switch (the old yardstick read az2 46x its noise)."""
    from aeroid.estimation import switch_free_windows

    clean = aeroid.simulate_scenario(dense_relay, aeroid.NoNoise(), rng=5)
    noisy = aeroid.simulate_scenario(dense_relay, aeroid.make_noise(noise), rng=5)
    switches = np.count_nonzero(np.diff(clean["delta"])) / (clean.t[-1] - clean.t[0])
    assert switches >= 70
    assert aeroid.estimation.switch_free_samples(clean["delta"]).all()  # the old fallback
    assert switch_free_windows(clean["delta"], 5).size >= 150
    levels = data_noise_levels(noisy)
    for name, level in levels.items():
        true = float(np.sqrt(np.mean((noisy[name] - clean[name]) ** 2)))
        assert level == pytest.approx(true, rel=rtol), name
    imu = aeroid.GaussianNoise()  # noise-free: the leakage only (ay2 1.5 % of a tactical IMU)
    for name, level in data_noise_levels(clean).items():
        assert level < 0.02 * (imu.rate_sd_radps if name in "pqr" else imu.accel_sd_mps2)


def test_given_noise_levels_and_failed_results(paper_flight) -> None:
    n = paper_flight.n_samples
    result = apply_fit_check(_result({"MX": np.full(n, 2.0)}, fit_noise_sd={"MX": 1.0},
                                     fit_signals={"MX": np.full(n, 10.0)}), paper_flight)
    assert result.info["fit_check"]["ratio"]["MX"] == pytest.approx(2.0)
    failed = EstimationResult(estimator="x", theta=np.ones(aeroid.model.N_COEFFICIENTS),
                              success=False, message="diverged",
                              info={"fit_residuals": {"q": np.ones(n)}})
    assert apply_fit_check(failed, paper_flight).message == "diverged"


def test_standard_errors_below_the_floor_are_flagged(reference_scenario) -> None:
    import dataclasses

    from aeroid.estimation._fitcheck import data_floor, floor_warnings

    flight = aeroid.simulate_scenario(reference_scenario, aeroid.GaussianNoise(), rng=3)
    fit = aeroid.make_estimator("output-error", {"noise_model": "channel"}).fit(flight, rng=1)
    # output-error reaches the floor (measured 0.96-0.99 of it on this flight)
    np.testing.assert_allclose(fit.stderr / data_floor(flight, fit.theta), 1.0, atol=0.1)
    # the only warning: Cl0 and Clp confounded (their correlation from the covariance)
    corr = fit.covariance[4, 5] / np.sqrt(fit.covariance[4, 4] * fit.covariance[5, 5])
    assert corr < -0.98
    assert fit.warnings == (f"nearly confounded (|correlation| > 0.98): Cl0-Clp ({corr:+.5f}); "
                            "the data determine a combination of each pair better than either",)
    boasting = dataclasses.replace(fit, stderr=fit.stderr * np.where(
        np.arange(aeroid.model.N_COEFFICIENTS) == 4, 0.3, 1))
    (warning,) = floor_warnings(boasting, flight)
    assert "below half the Cramér-Rao floor for Cl0" in warning and "Clp" not in warning
    # the check reads the input and noise model the result carries as fields (set by
    # Estimator.fit), not the options dict: the field says "signal" -> no per-channel
    # yardstick, whatever info["options"] says
    assert (fit.input, fit.noise_model) == (fit.info["input"], "channel")
    assert fit.input in aeroid.flights.INPUTS and fit.input != "auto"  # resolved
    assert floor_warnings(dataclasses.replace(boasting, noise_model="signal"), flight) == ()
    no_options = dataclasses.replace(
        boasting, info={k: v for k, v in boasting.info.items() if k != "options"})
    assert floor_warnings(no_options, flight) == (warning,)
    clean = aeroid.simulate_scenario(reference_scenario, aeroid.NoNoise(), rng=0)
    assert data_floor(clean, fit.theta) is None  # noise-free: nothing to compare with


def test_per_sample_weighting_is_not_judged_by_the_per_channel_floor(reference_scenario):
    """Under the paper's signal-proportional noise output-error's default (per-sample
    weights) is far below the per-channel floor, legitimately: no warning (there was
    one before the check looked at the method's noise model)."""
    from aeroid.estimation._fitcheck import data_floor

    flight = aeroid.simulate_scenario(reference_scenario, aeroid.PaperNoise(), rng=2)
    fit = aeroid.make_estimator("output-error").fit(flight, rng=1)
    assert fit.success
    assert np.any(fit.stderr < 0.5 * data_floor(flight, fit.theta))  # what it used to flag
    assert not any("Cramér-Rao floor" in w for w in fit.warnings)


def test_difference_yardstick_closed_forms() -> None:
    """4th differences annihilate a cubic exactly; on white noise their RMS over
    sqrt(C(8, 4)) = sqrt(70) is the noise sd (100 000 samples: within 1 %); only windows
    of constant deflection enter, and with too few of them a robust spread of all."""
    from aeroid.estimation import difference_noise_sd, switch_free_windows

    t = np.linspace(0.0, 1.0, 200)
    cubic = 3.0 - 2.0 * t + 5.0 * t**2 - 7.0 * t**3
    sd, how = difference_noise_sd(cubic)
    assert sd < 1e-12 and how == "between switches"
    noise = np.random.default_rng(0).standard_normal(100_000) * 0.3
    assert difference_noise_sd(noise)[0] == pytest.approx(0.3, rel=0.01)
    delta = np.array([0.0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 0, 0])
    np.testing.assert_array_equal(switch_free_windows(delta, 5), [0, 1, 6])
    steps = delta[np.arange(noise.size) % delta.size]  # a switch every 5-6 samples
    jumps = 50.0 * steps + noise
    assert difference_noise_sd(jumps)[0] > 10  # told of no switch: the jumps enter
    assert difference_noise_sd(jumps, steps)[0] == pytest.approx(0.3, rel=0.02)
    assert difference_noise_sd(jumps[:13], delta)[1] == "robust, all windows"  # 3 windows
