"""The gust filters' standard errors from the innovations' information (issue 26).

References: filter-error's own Cramér-Rao covariance at its own estimate on the same
flight (the problem built the way :class:`baselines.filter_error.FilterErrorEstimator`
builds it); the curvature of the innovations' likelihood by central second differences
of its value alone (the observed information, against the expected one); the filtered
covariance the EKF reported before (kept in ``info``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import aeroid
from aeroid.estimation import CoefficientSpec
from aeroid.flights import GaussianNoise, Wind, simulate
from aeroid.model import NAMES
from baselines import _fem_fit, _kalman_information, _kalman_likelihood
from baselines.ekf import ExtendedKalmanEstimator
from baselines.filter_error import FilterErrorEstimator

#: The same code on the same problem: rounding only (the batched filters run once more).
SAME_RTOL = 1e-8
#: Second difference of the likelihood in the scaled parameters (order 1): truncation
#: ~h^2 relative, rounding ~eps |L| / h^2 = 2e-16 * 3e3 / 4e-6 ~ 2e-7 of entries ~1e4.
HESSIAN_STEP = 2e-3
#: The expected information (``M``) against the observed one (the likelihood's curvature)
#: on the coefficients: they differ by zero-mean terms in the innovations (measured on
#: seeds 1-2 of this flight: 0.1-0.3 %); 1 % is 3x that.
COEFFICIENT_CURVATURE_RTOL = 0.01
#: On ``log sigma`` (measured 2-6 %): the intensity's information comes from ``S`` alone.
SIGMA_CURVATURE_RTOL = 0.15
#: The profile's intensity against filter-error's joint optimum: both searches stop at
#: ~1 % in log sigma (PROFILE_LOG_TOL; filter-error's tol 0.01 sd); measured 0.03 %.
PROFILE_RTOL = 0.02
#: Filter-error stops when its step is below 0.01 se: a step from there is that size
#: (measured 0.001 se).
AT_OPTIMUM_SE = 0.01
#: The one-step estimate from the EKF's against filter-error's converged one [se]: a
#: single step, not converged (measured 0.13 se from the EKF's 1.37 on this flight).
ONE_STEP_SE = 0.3
#: How far a fit's coefficients may be from the truth in its own se.
WITHIN_SE = 3.0
#: The 95 % interval's half-width in se.
Z95 = 1.959964
#: Six flights are 54 coefficient-runs, correlated within a run: a calibrated 0.95 gives
#: 0.87 or more (7 misses in 54; measured on seeds 1-6: 0.963, 2 misses, max 2.14 se).
MIN_COVERAGE = 0.87
#: The filtered intervals' coverage on those flights is below this (measured 0.796, max
#: 3.85 se): the test tells the two apart.
FILTERED_BELOW = 0.87


@pytest.fixture(scope="module")
def turbulent(reference_scenario):
    """Dryden sd 3 m/s, no steady wind, Gaussian IMU noise (filter-error's study)."""
    s = reference_scenario
    rough = dataclasses.replace(s.manoeuvre, wind=Wind(turbulence_sd_mps=3.0))
    return simulate(s.airframe, s.coefficient_vector, rough, GaussianNoise(), rng=1)


@pytest.fixture(scope="module")
def fe_fit(turbulent):
    return FilterErrorEstimator().fit(turbulent, rng=1)


def _information(flight, theta, sd):
    problem, noise = _kalman_information.gust_problem(
        flight, theta, scale_length_m=aeroid.flights.MIL_SCALE_LENGTH_M, substeps=1,
        input_mode="auto", delay_s=0.0)
    return problem, noise, _kalman_information.innovation_covariance(problem, noise, sd)


def test_at_filter_errors_estimate_it_is_filter_errors_covariance(turbulent, fe_fit) -> None:
    """At filter-error's optimum: its covariance, its intensity (the profile's maximum,
    found alone), and a one-step that does not move (its score is ~0 there)."""
    assert fe_fit.success, fe_fit.message
    sd = fe_fit.info["gust_sd_mps"]
    problem, noise, found = _information(turbulent, fe_fit.theta, sd)
    assert found.ok
    np.testing.assert_allclose(found.covariance, fe_fit.covariance, rtol=SAME_RTOL,
                               atol=SAME_RTOL * np.max(np.abs(fe_fit.covariance)))
    assert found.gust_sd_stderr_mps == pytest.approx(fe_fit.info["gust_sd_stderr_mps"],
                                                     rel=SAME_RTOL)
    profile = _kalman_information.likelihood_gust_sd(problem, found.R)
    assert profile == pytest.approx(sd, rel=PROFILE_RTOL)
    theta, _ = _kalman_likelihood.one_step(problem, found)
    assert np.max(np.abs(theta - fe_fit.theta) / fe_fit.stderr) < AT_OPTIMUM_SE


def test_with_a_hold_and_a_prior_it_is_filter_errors_covariance(turbulent,
                                                                  reference_scenario) -> None:
    """The held coefficient leaves the information (se 0 here, NaN in filter-error) and a
    prior's information joins it, as in filter-error at its own optimum."""
    truth = reference_scenario.coefficient_vector
    cmq = NAMES.index("Cmq")
    spec = CoefficientSpec.from_mapping({"hold": {"Czq": float(truth[NAMES.index("Czq")])},
                                         "prior": {"Cmq": [float(truth[cmq]),
                                                           0.1 * abs(float(truth[cmq]))]}})
    fe = FilterErrorEstimator(max_iterations=8).fit(turbulent, rng=1, holds=spec)
    problem, noise = _kalman_information.gust_problem(
        turbulent, fe.theta, scale_length_m=aeroid.flights.MIL_SCALE_LENGTH_M, substeps=1,
        input_mode="auto", delay_s=0.0, holds=spec)
    found = _kalman_information.innovation_covariance(problem, noise, fe.info["gust_sd_mps"])
    free = spec.free_index
    assert found.stderr[NAMES.index("Czq")] == 0.0
    np.testing.assert_allclose(found.stderr[free], fe.stderr[free], rtol=SAME_RTOL)
    np.testing.assert_allclose(found.covariance, fe.covariance, rtol=SAME_RTOL,
                               atol=SAME_RTOL * np.max(np.abs(fe.covariance)))


def test_the_information_is_the_likelihoods_curvature(turbulent, fe_fit) -> None:
    """Diagonal of ``M`` against the central second difference of the likelihood's value
    (:func:`baselines._fem_fit.nll`, no sensitivities) at filter-error's optimum."""
    sd = fe_fit.info["gust_sd_mps"]
    problem, noise, found = _information(turbulent, fe_fit.theta, sd)
    p = np.concatenate([fe_fit.theta / problem.scale, [math.log(sd)]])
    n = p.size
    rows = np.vstack([p, p + HESSIAN_STEP * np.eye(n), p - HESSIAN_STEP * np.eye(n)])
    cost = _fem_fit.nll(problem.run(rows, noise.R))
    curvature = (cost[1:n + 1] - 2.0 * cost[0] + cost[n + 1:]) / HESSIAN_STEP**2
    expected = np.diag(found.information)
    np.testing.assert_allclose(curvature[:-1], expected[:-1], rtol=COEFFICIENT_CURVATURE_RTOL)
    assert curvature[-1] == pytest.approx(expected[-1], rel=SIGMA_CURVATURE_RTOL)


@pytest.fixture(scope="module")
def ekf_fits(turbulent):
    """The EKF told the true intensity: ``innovations`` and ``one-step`` (the default)."""
    return {mode: aeroid.make_estimator("ekf", {"gust_sd_mps": 3.0, "gust_stderr": mode}
                                        ).fit(turbulent, rng=1)
            for mode in ("innovations", "one-step")}


def test_an_ekf_gust_fit_reports_the_informations_se(turbulent, reference_scenario,
                                                     ekf_fits) -> None:
    """``innovations``: the information's se at the EKF's own estimate and the likelihood's
    intensity there; the filtered ones kept (2.4x smaller on Cza, Cma here, measured);
    said once, with the warning that they are not calibrated in turbulence (also in
    ``info['intervals']``)."""
    result = ekf_fits["innovations"]
    assert result.success, result.message
    problem, noise, _ = _information(turbulent, result.theta, 3.0)
    R = _kalman_information.noise_at(problem, noise, 3.0)
    sd = _kalman_information.likelihood_gust_sd(problem, R)
    found = _kalman_information.innovation_covariance(problem, noise, sd, R=R)
    np.testing.assert_allclose(result.stderr, found.stderr, rtol=SAME_RTOL)
    assert result.info["gust_information"]["gust_sd_mps"] == sd
    filtered = result.info["stderr_filtered"]
    assert np.all(filtered > 0) and np.max(result.stderr / filtered) > 2.0
    np.testing.assert_array_equal(result.info["theta_filtered"], result.theta)
    said = [w for w in result.warnings if "innovations' information" in w]
    assert len(said) == 1 and "not the final filtered covariance" in said[0], result.warnings
    assert sum("these intervals are not calibrated" in w for w in result.warnings) == 1
    assert result.info["intervals"]["calibrated"] is False
    z = np.abs(result.theta - reference_scenario.coefficient_vector) / result.stderr
    assert np.all(z < WITHIN_SE), dict(zip(NAMES, z.round(2), strict=True))


def test_the_one_step_lands_at_filter_errors_optimum(ekf_fits, fe_fit) -> None:
    """``one-step``: from the EKF's estimate (1.4 se from filter-error's on Cza, Cma) to
    within :data:`ONE_STEP_SE` of filter-error's converged estimate; said once."""
    result = ekf_fits["one-step"]
    start = np.max(np.abs(result.info["theta_filtered"] - fe_fit.theta) / fe_fit.stderr)
    moved = np.max(np.abs(result.theta - fe_fit.theta) / fe_fit.stderr)
    assert moved < ONE_STEP_SE < start
    assert sum("Le Cam's one-step" in w for w in result.warnings) == 1
    assert not any("not calibrated" in w for w in result.warnings)


def test_the_option_is_listed_checked_and_refused_where_not_built(capsys, turbulent) -> None:
    from aeroid.cli import main

    for method in ("ekf", "ukf"):
        assert main(["methods", "--options", method]) == 0
        listed = "  gust_stderr : {auto, filtered, innovations, one-step} = auto"
        assert listed in capsys.readouterr().out
    with pytest.raises(aeroid.EstimatorError, match="gust_stderr=.sandwich. not one of"):
        aeroid.make_estimator("ekf", {"gust_stderr": "sandwich"})
    with pytest.raises(ValueError, match="gust_stderr must be one of"):
        ExtendedKalmanEstimator(gust_stderr="sandwich")
    with pytest.raises(aeroid.EstimatorError, match="innovations needs gust states"):
        aeroid.make_estimator("ekf", {"gust_stderr": "innovations"}).fit(turbulent, rng=1)
    with pytest.raises(aeroid.EstimatorError, match="innovations with estimate_wind is not "):
        aeroid.make_estimator("ukf", {"gust_stderr": "innovations", "gust_sd_mps": 3.0,
                                      "estimate_wind": True}).fit(turbulent, rng=1)


def test_where_not_built_the_filtered_se_are_kept_and_said(turbulent) -> None:
    """``auto`` with ``estimate_wind`` or saturated samples: the filtered covariance, with
    the one-line warning."""
    result = aeroid.make_estimator("ekf", {"gust_sd_mps": 3.0, "estimate_wind": True,
                                           "max_passes": 1}).fit(turbulent, rng=1)
    assert "stderr_filtered" not in result.info
    said = [w for w in result.warnings if "final filtered covariance's" in w]
    assert len(said) == 1 and "with estimate_wind" in said[0], result.warnings
    clipped = dataclasses.replace(turbulent, metadata={**turbulent.metadata,
                                                       "saturated": {"az1": np.array([5])}})
    saturated = aeroid.make_estimator("ekf", {"gust_sd_mps": 3.0, "max_passes": 1}).fit(
        clipped, rng=1)
    assert "stderr_filtered" not in saturated.info
    assert sum("with saturated samples left out" in w for w in saturated.warnings) == 1
    plain = aeroid.make_estimator("ekf", {"max_passes": 1}).fit(turbulent, rng=1)
    assert "stderr_filtered" not in plain.info  # no gust states: untouched
    assert not any("filtered covariance" in w for w in plain.warnings)


def test_in_still_air_the_intensity_is_held_and_nothing_is_said(reference_scenario) -> None:
    """Gust states on a still-air flight: the likelihood's intensity is at the search's lower
    bound, held there (no sd), and the not-calibrated warning is not said (its false alarm;
    over 12 still-air flights: ``benchmarks/results/gust_stderr_stillair.md``)."""
    s = reference_scenario
    flight = simulate(s.airframe, s.coefficient_vector, s.manoeuvre, GaussianNoise(), rng=2)
    result = aeroid.make_estimator("ekf", {"gust_sd_mps": 0.5, "max_passes": 2}).fit(
        flight, rng=2)
    found = result.info["gust_information"]
    assert found["gust_sd_mps"] < _kalman_information.CALM_GUST_SD_MPS
    assert math.isnan(found["gust_sd_stderr_mps"])
    assert not any("not calibrated" in w for w in result.warnings), result.warnings
    z = np.abs(result.theta - s.coefficient_vector) / result.stderr
    assert np.all(z < WITHIN_SE), dict(zip(NAMES, z.round(2), strict=True))


@pytest.mark.slow
def test_the_one_steps_intervals_cover_where_the_filtered_ones_did_not(reference_scenario
                                                                       ) -> None:
    """Statistical (seeds 1-6, Dryden sd 3 m/s, the intensity estimated): the one-step's
    95 % intervals cover at least :data:`MIN_COVERAGE` of the coefficient-runs with every
    coefficient within 3 se on every flight, where the same fits' filtered intervals
    cover less than :data:`FILTERED_BELOW` (measured over 20 flights: 0.961 against
    0.789, ``benchmarks/results/gust_stderr_still.md``)."""
    s = reference_scenario
    rough = dataclasses.replace(s.manoeuvre, wind=Wind(turbulence_sd_mps=3.0))
    est = aeroid.make_estimator("ekf", {"estimate_gust_sd": True, "gust_stderr": "one-step"})
    z, z_filtered = [], []
    for seed in range(1, 7):
        flight = simulate(s.airframe, s.coefficient_vector, rough, GaussianNoise(), rng=seed)
        r = est.fit(flight, rng=seed)
        z.append(np.abs(r.theta - s.coefficient_vector) / r.stderr)
        z_filtered.append(np.abs(r.info["theta_filtered"] - s.coefficient_vector)
                          / r.info["stderr_filtered"])
    z, z_filtered = np.array(z), np.array(z_filtered)
    assert np.mean(z <= Z95) >= MIN_COVERAGE, z.round(2)
    assert np.all(z < WITHIN_SE), z.round(2)
    assert np.mean(z_filtered <= Z95) < FILTERED_BELOW, z_filtered.round(2)
