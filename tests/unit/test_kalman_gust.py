"""Gust states of the EKF/UKF, the innovations' likelihood and the passes' verdict (issue 26).

References: the simulator's Dryden longitudinal autocorrelation (closed form) for the
Gauss-Markov gust; the wind model (:func:`baselines._kalman_wind.wind_model`) at the
summed wind and central differences for the gust model; the joint Gaussian density of
all measurements of a linear model (scipy) for the filter's likelihood; known-wrong
(drifting) and correct fits for the verdict.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import stats

import aeroid
from aeroid.flights import (
    MIL_SCALE_LENGTH_M,
    GaussianNoise,
    NoNoise,
    Wind,
    dryden_autocorrelation,
    flight_record,
    simulate,
)
from aeroid.model import N_COEFFICIENTS, N_STATE, U, V, W
from baselines import _common, _kalman, _kalman_gust, _kalman_verdict, _kalman_wind

#: The wind and gust states are summed before the same CasADi function: rounding only.
SAME_RTOL = 1e-12
#: Central difference of 1e-3 m/s on a step analytic in the wind: truncation ~1e-9.
FD_STEP = 1e-3
FD_RTOL = 1e-6
#: Closed forms evaluated two ways (exp of a sum against a power): rounding only.
CLOSED_RTOL = 1e-12
#: The likelihood sums 40 terms of size ~1: rounding ~1e-13.
NLL_ATOL = 1e-9


@pytest.fixture(scope="module")
def turbulent_clean(reference_scenario):
    s = reference_scenario
    windy = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=(3.0, 4.0, 0.0),
                                                       turbulence_sd_mps=3.0))
    return simulate(s.airframe, s.coefficient_vector, windy, NoNoise(), rng=3)


def test_the_gauss_markov_gust_is_drydens_first_order_form() -> None:
    """The gust's autocovariance ``phi^k sd^2`` is the Dryden longitudinal closed form
    ``sd^2 exp(-V t / L)`` at every lag, and the start is stationary."""
    dt, speed, sd = 0.002, 505.0, 3.0
    phi = _kalman_gust.gust_phi(dt, speed, MIL_SCALE_LENGTH_M)
    lags = np.arange(0, 600)
    longitudinal, _ = dryden_autocorrelation(lags * dt, sd=sd, scale_length_m=MIL_SCALE_LENGTH_M,
                                             airspeed_mps=speed)
    np.testing.assert_allclose(sd**2 * phi**lags, longitudinal, rtol=CLOSED_RTOL)
    n = N_STATE
    setup = _common.FilterSetup(np.zeros(n), np.eye(n), np.zeros((n, n)), np.eye(1),
                                np.zeros((2, 1)), np.ones(1), (np.ones(1), np.zeros(1)),
                                np.zeros(1), ())
    out = _kalman_gust.gust_setup(setup, sd, phi)
    g = slice(n, n + len(_kalman_gust.GUST_NAMES))
    P0, Q = out.P0[g, g], out.Q[g, g]
    np.testing.assert_allclose(phi**2 * P0 + Q, P0, rtol=CLOSED_RTOL)  # stationary
    np.testing.assert_allclose(np.diag(P0), sd**2, rtol=CLOSED_RTOL)
    np.testing.assert_array_equal(out.P0[:n, :n], setup.P0)


@pytest.mark.parametrize("steady", [False, True])
def test_the_gust_states_are_the_models_wind(turbulent_clean, reference_scenario,
                                             steady) -> None:
    flight = turbulent_clean
    wind = _kalman_wind.wind_model(flight, 1, flight_record(flight), ())
    phi = 0.99
    model = _kalman_gust.with_gusts(wind, phi, steady=steady)
    k_g = len(_kalman_gust.GUST_NAMES)
    assert model.dim_x == wind.dim_x + (k_g if steady else 0)
    states = flight.states()
    w_steady, gust = np.array([3.0, 4.0, 0.0]), np.array([0.5, -1.0, 0.8])
    for k in (0, 250):
        z_in = np.concatenate([states[k], reference_scenario.coefficient_vector,
                               w_steady + gust if steady else gust])
        z = np.concatenate([z_in[:-k_g], w_steady, gust]) if steady else z_in
        ref_next, _ = wind.transition(z_in, k)
        z_next, F = model.transition(z, k)
        np.testing.assert_allclose(z_next[:N_STATE], ref_next[:N_STATE], rtol=SAME_RTOL)
        np.testing.assert_array_equal(z_next[N_STATE:N_STATE + N_COEFFICIENTS],
                                      z[N_STATE:N_STATE + N_COEFFICIENTS])
        np.testing.assert_allclose(z_next[-k_g:], phi * gust, rtol=SAME_RTOL)
        if steady:
            np.testing.assert_array_equal(z_next[-2 * k_g:-k_g], w_steady)
        y, H = model.observe(z, k)
        np.testing.assert_allclose(y, wind.observe(z_in, k)[0], rtol=SAME_RTOL)
        for j in range(model.dim_x - (2 if steady else 1) * k_g, model.dim_x):
            step = np.zeros(model.dim_x)
            step[j] = FD_STEP
            fd_f = (model.transition(z + step, k)[0] - model.transition(z - step, k)[0]) / (
                2 * FD_STEP)
            fd_h = (model.observe(z + step, k)[0] - model.observe(z - step, k)[0]) / (
                2 * FD_STEP)
            np.testing.assert_allclose(F[:, j], fd_f, rtol=FD_RTOL, atol=1e-9)
            np.testing.assert_allclose(H[:, j], fd_h, rtol=FD_RTOL, atol=1e-9)
        Z = z + np.linspace(-0.1, 0.1, 3)[:, None] * np.ones(model.dim_x)
        np.testing.assert_allclose(model.transition_batch(Z, k),
                                   [model.transition(p, k)[0] for p in Z], rtol=1e-12)
        np.testing.assert_allclose(model.observe_batch(Z, k),
                                   [model.observe(p, k)[0] for p in Z], rtol=1e-12)


def _linear_model(A: np.ndarray, C: np.ndarray) -> _kalman.DiscreteModel:
    def transition(x, k):
        return A @ x, A

    def observe(x, k):
        return C @ x, C

    return _kalman.DiscreteModel(A.shape[0], C.shape[0], transition, observe,
                                 lambda X, k: X @ A.T, lambda X, k: X @ C.T)


@pytest.mark.parametrize("run", [_kalman.run_ekf, _kalman.run_ukf])
def test_the_filters_likelihood_is_the_joint_gaussian_density(run) -> None:
    """Prediction-error decomposition: on a linear-Gaussian model the innovations'
    likelihood is the joint density of all measurements (scipy), less its constant."""
    rng = np.random.default_rng(4)
    A = np.array([[0.98, 0.1], [0.0, 0.95]])
    C = np.array([[1.0, 0.0], [0.3, 1.0]])
    n, Q, R = 20, np.diag([0.01, 0.04]), np.diag([0.1, 0.2])
    x0, P0 = np.array([1.0, -0.5]), np.diag([0.5, 0.3])
    zs = rng.normal(size=(n, 2))
    out = run(_linear_model(A, C), x0, P0, Q, R, zs)
    # the stacked measurements: x_k = A^k x_0 + sum A^(k-1-j) w_j, z_k = C x_k + v_k
    powers = [np.linalg.matrix_power(A, k) for k in range(n)]
    mean = np.concatenate([C @ powers[k] @ x0 for k in range(n)])
    cov_x = [[None] * n for _ in range(n)]
    for i in range(n):
        for j in range(n):
            m = min(i, j)
            c = powers[i] @ P0 @ powers[j].T
            c = c + sum(powers[i - 1 - s] @ Q @ powers[j - 1 - s].T for s in range(m))
            cov_x[i][j] = C @ c @ C.T + (R if i == j else 0.0)
    cov = np.block(cov_x)
    logpdf = stats.multivariate_normal(mean, cov).logpdf(zs.ravel())
    expected = -logpdf - 0.5 * zs.size * math.log(2 * math.pi)
    assert out.neg_log_likelihood == pytest.approx(expected, abs=NLL_ATOL)


def test_the_intensity_search_finds_the_likelihoods_maximum() -> None:
    """On ``(log sd - log 2.5)^2``, the bounded search's answer is 2.5 within its
    tolerance, and an optimum beyond the bounds is reported at the bound."""
    found = _kalman_gust.search_gust_sd(lambda sd: (math.log(sd) - math.log(2.5)) ** 2)
    assert abs(math.log(found.sd_mps / 2.5)) < _kalman_gust.GUST_SD_LOG_TOL
    assert len(found.trials) <= _kalman_gust.GUST_SD_MAX_TRIALS + 5
    high = _kalman_gust.search_gust_sd(lambda sd: -sd)
    assert "at the search's bound" in high.describe()


def _pass(x_last: np.ndarray, sd_last: np.ndarray) -> _kalman.FilterOutput:
    x = np.vstack([np.zeros_like(x_last), x_last])
    sd = np.vstack([np.ones_like(sd_last), sd_last])
    return _kalman.FilterOutput(x, sd, np.eye(x_last.size), None, "", np.zeros((2, 1)))


def test_the_verdict_measures_the_last_passes_move() -> None:
    before, after = _pass(np.array([1.0, 2.0]), np.array([0.5, 1.0])), _pass(
        np.array([1.2, 5.0]), np.array([0.4, 2.0]))
    np.testing.assert_allclose(_kalman_verdict.last_moves([before, after], np.arange(2)),
                               [0.2 / 0.4, 3.0 / 2.0])
    ok = aeroid.EstimationResult(estimator="ekf", theta=np.zeros(2), success=True,
                                 message="", info={"passes": 2})
    judged = _kalman_verdict.settle_verdict(ok, [before, after], np.arange(2), ("a", "b"))
    assert not judged.success and "moved b by 1.50" in judged.message
    settled = _kalman_verdict.settle_verdict(ok, [before, before], np.arange(2), ("a", "b"))
    assert settled.success and settled.info["last_pass_moves_se"] == {"a": 0.0, "b": 0.0}
    assert _kalman_verdict.last_moves([after], np.arange(2)) is None


def _noisy(reference_scenario, seed: int, wind: bool):
    s = reference_scenario
    man = s.manoeuvre if not wind else dataclasses.replace(
        s.manoeuvre, wind=Wind(steady_ned_mps=(3.0, 4.0, 0.0)))
    return simulate(s.airframe, s.coefficient_vector, man, GaussianNoise(), rng=seed)


def test_a_wind_fit_whose_passes_walk_is_refused(reference_scenario) -> None:
    """Known wrong: seed 1's windy flight, whose along-path wind walks 4 m/s a pass to
    23.6 m/s with the carried passes (9.9 se off); the fit check passed it."""
    flight = _noisy(reference_scenario, 1, wind=True)
    result = aeroid.make_estimator("ekf", {"estimate_wind": True, "passes": "carried"}).fit(
        flight, rng=1)
    assert not result.success
    assert result.message.startswith("the filter's passes did not settle")
    assert max(result.info["last_pass_moves_se"].values()) > _kalman_verdict.SETTLE_LIMIT_SE


@pytest.mark.parametrize(("seed", "wind", "options"), [
    (1, False, {}),  # still air, estimate_wind off
    (6, True, {"estimate_wind": True, "passes": "carried"}),  # settles: max 1.4 se off
])
def test_a_fit_whose_passes_settle_is_accepted(reference_scenario, seed, wind,
                                               options) -> None:
    flight = _noisy(reference_scenario, seed, wind)
    result = aeroid.make_estimator("ekf", options).fit(flight, rng=seed)
    assert result.success, result.message
    assert max(result.info["last_pass_moves_se"].values()) <= _kalman_verdict.SETTLE_LIMIT_SE


def test_the_gust_options_are_named_checked_and_refused_where_not_done(
        capsys, turbulent_clean) -> None:
    from aeroid.cli import main

    for method in ("ekf", "ukf"):
        assert main(["methods", "--options", method]) == 0
        out = capsys.readouterr().out
        for line in ("  gust_sd_mps : float = 0", "  estimate_gust_sd : bool = false",
                     "  gust_scale_length_m : float = 533.4"):
            assert line in out, line
    with pytest.raises(aeroid.EstimatorError, match="gust_sd_mps or estimate_gust_sd"):
        aeroid.make_estimator("ekf", {"gust_sd_mps": 1.0, "estimate_gust_sd": True})
    with pytest.raises(aeroid.EstimatorError, match="gust_sd_mps must be >= 0"):
        aeroid.make_estimator("ekf", {"gust_sd_mps": -1.0})
    est = aeroid.make_estimator("ukf", {"gust_sd_mps": 1.0})
    with pytest.raises(aeroid.EstimatorError, match="gust states with several windows"):
        est.fit(aeroid.flights.Windows((turbulent_clean, dataclasses.replace(turbulent_clean)),
                                       ("a", "b")), rng=0)


def test_a_gust_fit_reports_its_intensity_and_path(turbulent_clean) -> None:
    """One fit: the given intensity, the time constant ``L / V`` and the filtered gust
    path per sample in ``info``, and the notice."""
    result = aeroid.make_estimator("ekf", {"gust_sd_mps": 3.0, "max_passes": 1}).fit(
        turbulent_clean, rng=0)
    info = result.info
    speed = float(np.mean(np.linalg.norm(turbulent_clean.states()[:, [U, V, W]], axis=1)))
    assert info["gust_sd_mps"] == 3.0
    assert info["gust_time_constant_s"] == pytest.approx(MIL_SCALE_LENGTH_M / speed,
                                                         rel=CLOSED_RTOL)
    assert info["gust_ned_mps"].shape == (turbulent_clean.n_samples,
                                          len(_kalman_gust.GUST_NAMES))
    assert sum(w.startswith("gusts: three Gauss-Markov") for w in result.warnings) == 1
    assert _kalman_gust.BOTH_WARNING not in result.warnings  # no estimate_wind: not said
    both = aeroid.make_estimator("ekf", {"gust_sd_mps": 3.0, "estimate_wind": True,
                                         "max_passes": 1}).fit(turbulent_clean, rng=0)
    assert both.warnings.count(_kalman_gust.BOTH_WARNING) == 1
