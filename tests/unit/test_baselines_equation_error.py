"""Equation-error baseline: noise-free recovery, least-squares identities, collinearity."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from closeness import assert_close_in_norm
from scipy.signal import savgol_filter

import aeroid
from aeroid.estimation import _reconstruct as rc
from aeroid.flights._noise import GaussianNoise
from aeroid.flights._scenario import reference_scenario
from aeroid.flights._simulate import simulate_scenario
from baselines._ee_roll import ROLL_ROW, roll_window
from baselines.equation_error import SUBPROBLEMS, EquationErrorEstimator, affine_accelerations

#: Two-step on noise-free data: the step-1 rate-derivative rows use SG derivatives of
#: p, q, r, exact only for polynomials; measured errors <= 3.7e-5 (Clp, Cl0), <= 3e-7
#: elsewhere. Tolerance 5x the measured.
TWO_STEP_RTOL = 2e-4
#: One-step on noise-free data: the accelerometer rows are exact (their residual sd drives
#: the second-pass weights to ~1e10 over the derivative rows); measured <= 2e-10.
ONE_STEP_RTOL = 1e-8
#: accelerometers() and state_derivative() are affine in theta: c + A theta reproduces
#: them up to rounding of ~1e3-sized terms.
AFFINE_ATOL = 1e-9


@pytest.fixture(scope="module")
def noisy_flight():
    noise = GaussianNoise(accel_sd_mps2=0.2, rate_sd_radps=0.01, position_sd_m=0.0)
    return simulate_scenario(reference_scenario(), noise, rng=8)


@pytest.mark.parametrize("options", [{}, {"lateral_rows": True}, {"smoothing": "none"}])
def test_two_step_recovers_noise_free_flight(prior_off_flight, options):
    res = EquationErrorEstimator(**options).fit(prior_off_flight, rng=0)
    assert res.success, res.message
    np.testing.assert_allclose(res.theta, aeroid.nominal(), rtol=TWO_STEP_RTOL)


@pytest.mark.parametrize("smoothing", ["both", "none"])
def test_one_step_recovers_noise_free_flight(prior_off_flight, smoothing):
    res = EquationErrorEstimator(one_step=True, smoothing=smoothing).fit(prior_off_flight, rng=0)
    assert res.success, res.message
    np.testing.assert_allclose(res.theta, aeroid.nominal(), rtol=ONE_STEP_RTOL)


def test_smoothing_forces_only_biases_fin_coefficients(prior_off_flight):
    # notes, "Smoothing": smoothing one side of a regression on a square-wave delta
    # biases Czd and Cmd even without noise (prototype: +6-7 %)
    res = EquationErrorEstimator(smoothing="forces").fit(prior_off_flight, rng=0)
    rel = np.abs(res.theta / aeroid.nominal() - 1.0)
    assert rel[aeroid.NAMES.index("Czd")] > 0.01
    assert rel[aeroid.NAMES.index("Cmd")] > 0.01


def test_affine_form_reproduces_sensor_model(noisy_flight):
    const = aeroid.model.constants(noisy_flight.airframe)
    theta = aeroid.nominal() * np.linspace(0.7, 1.3, len(aeroid.NAMES))
    c, A = affine_accelerations(noisy_flight)
    states = noisy_flight.states()
    delta = noisy_flight["delta"]
    acc = aeroid.model.accelerometers(states, delta, theta, const,
                                noisy_flight.airframe.accel_positions).reshape(-1, 6)
    wdot = aeroid.model.state_derivative(states, delta, theta, const)[:, 3:6]
    model = c + np.einsum("noc,c->no", A, theta)
    np.testing.assert_allclose(model, np.concatenate([acc, wdot], axis=1), rtol=0,
                               atol=AFFINE_ATOL * np.abs(acc).max())


@pytest.mark.parametrize("smoothing", ["none", "both"])
def test_two_step_equals_independent_least_squares(noisy_flight, smoothing):
    """theta and sigma^2 (X^T X)^-1 per sub-problem, recomputed with numpy.linalg."""
    res = EquationErrorEstimator(covariance="ols", smoothing=smoothing).fit(noisy_flight, rng=0)
    rec = rc.reconstruct(noisy_flight)
    X, y = rc.ebm_regression(noisy_flight, rec, smoothing=smoothing)
    for label, row, cols in SUBPROBLEMS:
        cols = list(cols)
        A, b = X[:, row, cols], y[:, row]
        theta, rss, *_ = np.linalg.lstsq(A, b, rcond=None)
        sigma2 = float(np.sum((b - A @ theta) ** 2)) / (len(b) - len(cols))
        cov = sigma2 * np.linalg.inv(A.T @ A)
        np.testing.assert_allclose(res.theta[cols], theta, rtol=1e-8, err_msg=label)
        np.testing.assert_allclose(res.covariance[np.ix_(cols, cols)], cov, rtol=1e-6,
                                   err_msg=label)
    np.testing.assert_allclose(res.stderr, np.sqrt(np.diag(res.covariance)))


@pytest.mark.parametrize("smoothing", ["none", "both"])
def test_hac_covariance_equals_the_direct_newey_west_sum(noisy_flight, smoothing):
    """Default covariance (the roll row's unsmoothed: its known structure, below):
    (A^T A)^-1 G^T W G (A^T A)^-1 with the Bartlett matrix
    W_ts = max(0, 1 - |t - s| / (L + 1)) written out in full (O(n^2), independent of the
    estimator's lag loop), L = twice the first lag of insignificant autocorrelation
    (found here with numpy.correlate), scaled by n / (n - k)."""
    res = EquationErrorEstimator(smoothing=smoothing).fit(noisy_flight, rng=0)
    rec = rc.reconstruct(noisy_flight)
    X, y = rc.ebm_regression(noisy_flight, rec, smoothing=smoothing)
    n = X.shape[0]
    lag_index = np.abs(np.arange(n)[:, None] - np.arange(n)[None, :])
    for label, row, cols in SUBPROBLEMS:
        cols = list(cols)
        A, b = X[:, row, cols], y[:, row]
        theta = np.linalg.lstsq(A, b, rcond=None)[0]
        e = b - A @ theta
        ec = e - e.mean()
        acf = np.correlate(ec, ec, mode="full")[n - 1:] / (ec @ ec)
        first = next(k for k in range(1, n // 4) if abs(acf[k]) < 2 / np.sqrt(n))
        lags = 2 * first
        W = np.clip(1.0 - lag_index / (lags + 1.0), 0.0, None)
        G = A * e[:, None]
        bread = np.linalg.inv(A.T @ A)
        cov = bread @ (G.T @ W @ G) @ bread * n / (n - len(cols))
        if row == ROLL_ROW and smoothing == "none":  # the roll row's known noise structure
            # (baselines/_ee_roll.py): the p derivative D written out densely, its noise
            # s D eps, s^2 from the residual's expectation s^2 tr((I - H) D D^T)
            D = savgol_filter(np.eye(n), roll_window(noisy_flight), rc.ROLL_POLYORDER,
                              deriv=1, delta=noisy_flight.dt, axis=0, mode="interp")
            DDt = D @ D.T
            s2 = (e @ e) / np.trace(DDt - A @ bread @ A.T @ DDt)
            cov = s2 * bread @ A.T @ DDt @ A @ bread
        np.testing.assert_allclose(res.covariance[np.ix_(cols, cols)], cov, rtol=1e-6,
                                   err_msg=label)


def test_collinearity_of_cl0_and_clp_is_flagged(noisy_flight):
    for options in ({}, {"one_step": True}):
        res = EquationErrorEstimator(**options).fit(noisy_flight, rng=0)
        pairs = {(a, b) for a, b, _ in res.info["collinear"]}
        assert ("Cl0", "Clp") in pairs
        i, j = aeroid.NAMES.index("Cl0"), aeroid.NAMES.index("Clp")
        assert abs(res.info["correlation"][i, j]) > 0.99
        assert res.info["correlation"].shape == (len(aeroid.NAMES),) * 2


def test_noisy_two_step_lies_within_reported_bounds(noisy_flight):
    # small Gaussian noise, true positions: the regression is nearly unbiased; its
    # reported sd are optimistic (coloured residuals), so only a loose 6-sd check here;
    # the coverage itself is measured in tests/statistical/test_coverage.py
    res = EquationErrorEstimator(one_step=True).fit(noisy_flight, rng=0)
    z = (res.theta - aeroid.nominal()) / res.stderr
    assert np.all(np.abs(z) < 6.0), z


def test_bad_smoothing_is_rejected():
    with pytest.raises(aeroid.EstimatorError, match="smoothing"):
        EquationErrorEstimator.from_options({"smoothing": "magic"})


# --------------------------------------------------------------------------------------
# Uncertain sensor positions: the consider covariance
# --------------------------------------------------------------------------------------
def test_consider_adds_the_position_effect_and_keeps_the_estimate(paper_flight):
    """Paper noise: the airframe gives 4 uncertain position components. The estimate is
    that of known positions; the covariance grows by G diag(sd^2) G^T, with G the
    estimate's own central difference (checked here against a 10x smaller step: the
    regression is smooth in the positions)."""
    known = EquationErrorEstimator(positions="known").fit(paper_flight, rng=0)
    cons = EquationErrorEstimator().fit(paper_flight, rng=0)
    assert known.success and cons.success
    np.testing.assert_array_equal(cons.theta, known.theta)
    G = cons.info["position_sensitivity"]
    free = cons.info["position_components"]
    sd = paper_flight.airframe.accel_position_sd.ravel()[free]
    assert len(free) == 4 and G.shape == (len(aeroid.NAMES), 4)
    assert_close_in_norm(cons.covariance - known.covariance, (G * sd**2) @ G.T, 1e-12)
    # G by a step of sd / 10, independently of the estimator's loop
    given = paper_flight.airframe.accel_positions.ravel()
    for j, c in enumerate(free):
        ends = []
        for sign in (1.0, -1.0):
            pos = given.copy()
            pos[c] += sign * sd[j] / 10
            moved = paper_flight.airframe.replace(accel1_position_m=tuple(pos[:3]),
                                                  accel2_position_m=tuple(pos[3:]))
            flight = dataclasses.replace(paper_flight, airframe=moved)
            ends.append(EquationErrorEstimator(positions="known").fit(flight, rng=0).theta)
        small = (ends[0] - ends[1]) / (2 * sd[j] / 10)
        np.testing.assert_allclose(G[:, j], small, rtol=0.05, atol=1e-6 * np.abs(G).max())
    # what the position error does: Cx, Czd, Cmd's intervals widen several-fold
    ratio = cons.stderr / known.stderr
    assert np.all(ratio >= 1.0)
    assert np.all(ratio[[aeroid.NAMES.index(n) for n in ("Cx", "Czd", "Cmd")]] > 1.5), ratio


def test_exact_positions_leave_nothing_to_consider(noisy_flight):
    cons = EquationErrorEstimator().fit(noisy_flight, rng=0)
    known = EquationErrorEstimator(positions="known").fit(noisy_flight, rng=0)
    np.testing.assert_array_equal(cons.covariance, known.covariance)
    assert "position_sensitivity" not in cons.info
    with pytest.raises(ValueError, match="positions"):
        EquationErrorEstimator(positions="estimate")
