"""The Dryden-shaped smoother of the wind the air data imply, against independent references.

References: the dense Gaussian conditional of the wind given the implied wind, its prior
covariance written from the Dryden autocorrelations in closed form
(:func:`aeroid.flights.dryden_autocorrelation`, no state space) plus a steady wind
(universal kriging); the steady-state smoothed covariance from the discrete Riccati
equation (:func:`scipy.linalg.solve_discrete_are`) and the RTS recursion's Lyapunov
equation (:func:`scipy.linalg.solve_discrete_lyapunov`); the maximum-likelihood gust sd
against the sd the simulator's gust generator (:meth:`aeroid.flights.Wind.gusts`) drew,
within its standard error over 20 draws (chi-square).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import linalg, stats

from aeroid import estimation as rc
from aeroid.errors import EstimatorError, FlightError
from aeroid.estimation._air_dryden import DIFFUSE_SD_MPS, dryden_system, fit_dryden
from aeroid.flights import (
    MIL_SCALE_LENGTH_M,
    GaussianNoise,
    NoNoise,
    Wind,
    dryden_autocorrelation,
    path_axes,
    simulate,
)
from aeroid.model import equations
from baselines.equation_error import EquationErrorEstimator

WIND = (3.0, 4.0, 0.0)
SD = 3.0  # the issue's moderate turbulence [m/s]
#: The smoother (diffuse steady wind, sd 1e3 m/s) against the exact conditional with that
#: same prior: both float64 solutions of well-conditioned problems (the implied wind's
#: noise >= 0.25 (m/s)^2 on the diagonal); measured agreement ~1e-10 m/s.
DENSE_ATOL_MPS = 1e-7
#: Covariances against the dense conditional, relative (measured ~1e-9).
COV_RTOL = 1e-6
#: The smoother's covariance in the middle of the record against the steady state: the
#: wind settles in ~20 ms, but the transverse filters' second state (the gusts' low
#: frequencies) slower than exp(-t / tau) (measured at tau 1 s: the filter 6e-8 off at 16
#: s, 1e-11 at 24 s); at tau = L / V = 0.13 s, 4 s each side leave ~1e-11.
RICCATI_RTOL = 1e-6
#: Vane-like noise of the implied wind [m/s], along, across and down (0.5 m/s airspeed,
#: 0.1 deg at 500 m/s).
NOISE_SD = np.array([0.5, 0.87, 0.87])
DT = 0.002


@pytest.fixture(scope="module")
def steady_flight(reference_scenario):
    s = reference_scenario
    m = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND))
    return simulate(s.airframe, s.coefficient_vector, m, NoNoise(), rng=0)


def _ned_to_body(flight):
    return np.stack([np.stack(equations.ned_to_body(flight["phi"], flight["theta"],
                                                    flight["psi"], *e), axis=1)
                     for e in np.eye(3)], axis=2)  # (n, body, ned)


def _gusts(n, velocity, rng):
    return Wind(turbulence_sd_mps=SD).gusts(n, DT, np.asarray(velocity, float), rng)


def _dense(z, r, dt, axes, speed, sd, length, prior_var):
    """The exact conditional mean and error covariance of the wind (3n) given ``z``:
    ``w = 1 s + g``, ``s ~ N(0, prior_var I)``, ``g`` Dryden with the closed-form
    autocorrelations in the path ``axes``, ``z = w + v``, ``v ~ N(0, blockdiag(r))``."""
    n = len(z)
    lags = np.abs(np.subtract.outer(np.arange(n), np.arange(n))) * dt
    along, across = dryden_autocorrelation(lags, sd=sd, scale_length_m=length,
                                           airspeed_mps=speed)
    sigma = sum(np.kron(acf, np.outer(a, a)) for acf, a in zip((along, across, across),
                                                              axes, strict=True))
    m = sigma + linalg.block_diag(*r)
    j = np.tile(np.eye(3), (n, 1))
    m_inv_j = np.linalg.solve(m, j)
    cov_s = np.linalg.inv(np.eye(3) / prior_var + j.T @ m_inv_j)
    mean_s = cov_s @ (m_inv_j.T @ z.ravel())
    k = np.linalg.solve(m, sigma).T  # sigma m^-1
    wind = j @ mean_s + k @ (z.ravel() - j @ mean_s)
    lead = j - k @ j
    cov = sigma - k @ sigma + lead @ cov_s @ lead.T
    return wind.reshape(n, 3), cov


def test_dryden_smoother_equals_dense_conditional(steady_flight) -> None:
    n = 200  # a 600 x 600 dense problem
    part = dataclasses.replace(steady_flight,
                               data=steady_flight.data.iloc[:n].reset_index(drop=True))
    c = _ned_to_body(part)
    inertial = np.einsum("nbk,nb->nk", c, np.stack([part[k] for k in "uvw"], axis=1))
    rng = np.random.default_rng(5)
    truth = np.asarray(WIND) + _gusts(n, inertial[0], rng)
    z = truth + np.einsum("nbk,nb->nk", c, rng.standard_normal((n, 3)) * NOISE_SD)
    out = rc.smooth_air_wind(part, z, model="dryden", gust_sd_mps=SD,
                             scale_length_m=MIL_SCALE_LENGTH_M)
    assert out.model == "dryden" and out.dryden["length_source"] == "given"
    air = np.mean(inertial - z, axis=0)  # the smoother's path axes and airspeed
    r = np.einsum("nbi,b,nbj->nij", c, out.noise_sd_body**2, c)
    wind, cov = _dense(z, r, part.dt, path_axes(air), float(np.linalg.norm(air)), SD,
                       MIL_SCALE_LENGTH_M, DIFFUSE_SD_MPS**2)
    np.testing.assert_allclose(out.wind, wind, rtol=0, atol=DENSE_ATOL_MPS)
    blocks = np.stack([cov[3 * k:3 * k + 3, 3 * k:3 * k + 3] for k in range(n)])
    np.testing.assert_allclose(out.covariance, blocks, rtol=COV_RTOL, atol=1e-12)
    ones = np.tile(np.eye(3), (n, 1)) / n
    np.testing.assert_allclose(out.mean_covariance, ones.T @ cov @ ones, rtol=COV_RTOL,
                               atol=1e-12)
    # the smoother is not the noisy data: its error is a fraction of the noise's
    assert np.sqrt(np.mean((out.wind - truth) ** 2)) < 0.6 * np.sqrt(np.mean((z - truth) ** 2))


def _riccati(length, speed, velocity, r):
    """The gust states' steady-state smoothed covariance (5, 5) and ``H`` (3, 5): the
    filter's from the discrete Riccati equation, the RTS recursion's fixed point
    ``P_s = P_f + G (P_s - P_p) G^T`` from the Lyapunov equation."""
    f, q, _, h = dryden_system(DT, length, speed, path_axes(velocity))
    g_ = slice(3, None)  # the gust states (no steady wind here)
    f, q, h = f[g_, g_], SD**2 * q[g_, g_], h[:, g_]
    p_pred = linalg.solve_discrete_are(f.T, h.T, q, r)
    p_filt = p_pred - p_pred @ h.T @ np.linalg.solve(h @ p_pred @ h.T + r, h @ p_pred)
    gain = p_filt @ f.T @ np.linalg.inv(p_pred)
    return linalg.solve_discrete_lyapunov(gain, p_filt - gain @ p_pred @ gain.T), h


def test_steady_state_against_riccati() -> None:
    n, speed, length = 4000, 500.0, MIL_SCALE_LENGTH_M / 8  # tau 0.13 s: 60 tau
    velocity = np.array([speed, 0.0, 0.0])
    r = np.diag(NOISE_SD**2)
    rng = np.random.default_rng(11)
    truth = Wind(turbulence_sd_mps=SD, scale_length_m=length).gusts(n, DT, velocity, rng)
    z = truth + rng.standard_normal((n, 3)) * NOISE_SD
    out = fit_dryden(z, np.broadcast_to(r, (n, 3, 3)), DT, velocity, gust_sd_mps=SD,
                     scale_length_m=length, steady_sd_mps=0.0)
    p_smooth, h = _riccati(length, speed, velocity, r)
    mid = n // 2
    np.testing.assert_allclose(out["state_covariance"][mid][3:, 3:], p_smooth, rtol=0,
                               atol=RICCATI_RTOL * np.max(np.abs(p_smooth)))
    var = np.diag(h @ p_smooth @ h.T)
    np.testing.assert_allclose(np.diag(out["covariance"][mid]), var, rtol=RICCATI_RTOL)
    # the smoothed wind's error on the simulator's gusts has that variance: per axis, the
    # errors correlated over ~10 samples (~400 independent values in 4000): 25 % is
    # ~3.5 sd of a variance's estimate from 400 values
    err = (out["wind"] - truth)[100:-100]
    np.testing.assert_allclose(np.mean(err**2, axis=0), var, rtol=0.25)


def test_wiener_floor_of_the_issue_turbulence() -> None:
    """At MIL's length, sd 3 m/s and 500 m/s, the steady-state smoothed variance is the
    Wiener floor of any smoother of these data, ``sqrt(q r dt) / 2`` per axis, ``q`` the
    Dryden spectra's omega^-2 tails (2 sd^2 V / L along the path, 3 sd^2 V / L across):
    the gusts and the probe noise cross at ~15 Hz, far above 1 / tau, where only the
    tails matter (the random-walk smoother's q ~ 18 is the same tail)."""
    speed = 500.0
    velocity = np.array([speed, 0.0, 0.0])
    p_smooth, h = _riccati(MIL_SCALE_LENGTH_M, speed, velocity, np.diag(NOISE_SD**2))
    var = np.diag(h @ p_smooth @ h.T)
    q_tail = np.array([2.0, 3.0, 3.0]) * SD**2 * speed / MIL_SCALE_LENGTH_M
    # the continuous, tails-only formula against the discrete exact answer: 5 %
    np.testing.assert_allclose(var, np.sqrt(q_tail * NOISE_SD**2 * DT) / 2, rtol=0.05)


@pytest.mark.slow  # 20 fits, 10 s
def test_ml_gust_sd_within_its_standard_error() -> None:
    n, speed = 501, 500.0  # the reference record's length
    velocity = np.array([speed, 0.0, 0.0])
    r = np.broadcast_to(np.diag(NOISE_SD**2), (n, 3, 3))
    z_scores = []
    for seed in range(20):
        rng = np.random.default_rng(seed)
        z = (np.asarray(WIND) + _gusts(n, velocity, rng)
             + rng.standard_normal((n, 3)) * NOISE_SD)
        out = fit_dryden(z, r, DT, velocity - np.asarray(WIND),
                         scale_length_m=MIL_SCALE_LENGTH_M)
        assert math.isfinite(out["log_sd_se"]) and out["log_sd_se"] < 0.15
        z_scores.append((math.log(out["gust_sd_mps"]) - math.log(SD)) / out["log_sd_se"])
    z_scores = np.array(z_scores)
    total = float(np.sum(z_scores**2))
    # the ML estimate and its curvature se: sum of 20 squared z within chi2(20)'s 0.1 %
    # tails (a se 2x too small gives ~80, 2x too large ~5)
    assert stats.chi2.ppf(1e-3, 20) < total < stats.chi2.ppf(1 - 1e-3, 20), z_scores
    # still air: the gusts' sd is the grid's smallest or zero, the wind the steady one
    rng = np.random.default_rng(99)
    still = np.asarray(WIND) + rng.standard_normal((n, 3)) * NOISE_SD
    out = fit_dryden(still, r, DT, velocity, scale_length_m=MIL_SCALE_LENGTH_M)
    assert out["gust_sd_mps"] <= 0.1
    assert out["log_likelihood"] - out["steady_log_likelihood"] < 2.0


def test_scale_length_when_the_record_tells_it() -> None:
    """(How often a record of MIL's gusts is said to tell another length: 2 of 40,
    benchmarks/bench_air_data_dryden.py.)"""
    speed = 500.0
    velocity = np.array([speed, 0.0, 0.0])
    length = MIL_SCALE_LENGTH_M / 4  # tau 0.27 s: a 4 s record holds ~15 of it
    n = 2000
    r = np.broadcast_to(np.diag(NOISE_SD**2), (n, 3, 3))
    rng = np.random.default_rng(3)
    gusts = Wind(turbulence_sd_mps=SD, scale_length_m=length).gusts(n, DT, velocity, rng)
    z = gusts + rng.standard_normal((n, 3)) * NOISE_SD
    out = fit_dryden(z, r, DT, velocity)
    assert out["length_source"] == "likelihood"  # not MIL's 533.4 m
    # within one step of the grid (a factor 2; 15 tau tell L to about that)
    assert abs(math.log2(out["scale_length_m"] / length)) <= 1.0 + 1e-9
    # what the record fixes best is the gusts' short-lag increment sd^2 V / L (sd and L
    # trade along a ridge: at 2x the length, sd 4.1 m/s): within 20 % (measured 5 %)
    ratio = out["gust_sd_mps"] ** 2 / out["scale_length_m"] / (SD**2 / length)
    assert abs(math.log(ratio)) < 0.2


def test_equation_error_option(reference_scenario) -> None:
    s = reference_scenario
    m = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND,
                                                   turbulence_sd_mps=SD))
    probe = GaussianNoise(alpha_sd_rad=math.radians(0.1), beta_sd_rad=math.radians(0.1),
                          airspeed_sd_mps=0.5)
    f = simulate(s.airframe, s.coefficient_vector, m, probe, rng=1)
    r = EquationErrorEstimator(air_data="measured", air_data_smoother="dryden").fit(f)
    told = r.info["air_data_smoother"]
    assert told["model"] == "dryden"
    assert abs(math.log(told["gust_sd_mps"] / SD)) < 3 * told["log_sd_se"]
    note = r.info["air_data_note"]
    assert "Dryden gusts" in note and f"gust sd {told['gust_sd_mps']:.3g} m/s" in note
    assert r.info["air_data_wind_consider"]["mean_sd_mps"].shape == (3,)
    with pytest.raises(ValueError, match="air_data_smoother must be one of"):
        EquationErrorEstimator(air_data_smoother="spline")
    with pytest.raises(FlightError, match="dryden smoother is the Kalman smoother's"):
        EquationErrorEstimator(air_data="measured", air_data_smoother="dryden",
                               air_data_window_s=0.1).fit(f)
    with pytest.raises(EstimatorError, match="takes no intensity"):
        rc.smooth_air_wind(f, rc.air_data_wind(f), model="dryden", intensity=1.0)
    with pytest.raises(EstimatorError, match="takes no gust_sd_mps"):
        rc.smooth_air_wind(f, rc.air_data_wind(f), gust_sd_mps=1.0)
