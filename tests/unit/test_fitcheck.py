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


def test_noise_free_data_are_judged_at_the_resolution(clean_flight) -> None:
    n = clean_flight.n_samples
    level = float(np.sqrt(np.mean(clean_flight["az1"] ** 2)))
    fine = apply_fit_check(_result({"az1": np.full(n, 0.5 * RESOLUTION * level)}), clean_flight)
    coarse = apply_fit_check(_result({"az1": np.full(n, 5 * RESOLUTION * level)}), clean_flight)
    assert fine.success and fine.info["fit_check"]["ratio"]["az1"] == pytest.approx(0.5)
    assert not coarse.success


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
    assert fit.warnings == ()
    boasting = dataclasses.replace(fit, stderr=fit.stderr * np.where(
        np.arange(aeroid.model.N_COEFFICIENTS) == 4, 0.3, 1))
    (warning,) = floor_warnings(boasting, flight)
    assert "below half the Cramér-Rao floor for Cl0" in warning and "Clp" not in warning
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
