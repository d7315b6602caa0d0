"""The Kalman smoother of the wind the air data imply, and equation-error's consider term.

References: the smoother against the dense generalized-least-squares solution of the
same random-walk problem (its normal equations solved by numpy, its covariance the
inverse of their matrix, the record-mean's covariance summed from it); a steady wind
(q = 0) against the weighted mean in closed form; equation-error's wind sensitivity
against the bias a known along-path wind leaves on a noise-free flight without an
airspeed channel (the truth).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aeroid import estimation as rc
from aeroid.errors import EstimatorError
from aeroid.flights import GaussianNoise, NoNoise, Wind, simulate
from baselines._ee_air import flight_direction
from baselines.equation_error import EquationErrorEstimator

WIND = (3.0, 4.0, 0.0)
#: The diffuse start (sd 1e3 m/s) against data of precision ~600 / (m/s)^2: the smoother
#: and the prior-free GLS differ by ~1e-9 m/s; rounding of the 3x3 recursions ~1e-12.
GLS_ATOL_MPS = 1e-6
#: Relative agreement of covariances with the dense inverse (same diffuse-start effect).
COV_RTOL = 1e-5
#: The central difference over +-1 m/s against the bias of a 3 m/s along-path wind:
#: measured 0.1-1 % on seven coefficients (the static loads scale with (V - w)^2, the
#: damping ones with V - w), 6 % on Clp and 2.7 % on Cl0, the collinear roll pair
#: (|r| 0.9998) that mixes the two scalings: 10 % bounds a first-order prediction.
BIAS_RTOL = 0.10


@pytest.fixture(scope="module")
def steady_flight(reference_scenario):
    s = reference_scenario
    m = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND))
    return simulate(s.airframe, s.coefficient_vector, m, NoNoise(), rng=0)


def _synthetic(flight, wind_ned, sd_body, rng):
    """Implied wind: ``wind_ned`` (n, 3) plus white noise of ``sd_body`` in body axes."""
    c = np.stack([np.stack(rc_ned_to_body(flight, e), axis=1) for e in np.eye(3)], axis=2)
    noise = rng.standard_normal((flight.n_samples, 3)) * sd_body
    return wind_ned + np.einsum("nbk,nb->nk", c, noise), c


def rc_ned_to_body(flight, e):
    from aeroid.model import equations

    return equations.ned_to_body(flight["phi"], flight["theta"], flight["psi"], *e)


def _dense_gls(z, c, sd, q, dt):
    """The random walk (q > 0) smoothed by one dense least-squares solve (no prior)."""
    n = len(z)
    r_inv = np.einsum("nbi,b,nbj->nij", c, 1.0 / sd**2, c)
    h = np.zeros((3 * n, 3 * n))
    b = np.zeros(3 * n)
    for k in range(n):
        h[3 * k:3 * k + 3, 3 * k:3 * k + 3] += r_inv[k]
        b[3 * k:3 * k + 3] = r_inv[k] @ z[k]
    w = np.eye(3) / (q * dt)
    for k in range(n - 1):
        i, j = slice(3 * k, 3 * k + 3), slice(3 * k + 3, 3 * k + 6)
        h[i, i] += w
        h[j, j] += w
        h[i, j] -= w
        h[j, i] -= w
    cov = np.linalg.inv(h)
    x = cov @ b
    ones = np.tile(np.eye(3), (n, 1)) / n  # (3n, 3): the record mean
    return x.reshape(n, 3), cov, ones.T @ cov @ ones


@pytest.mark.parametrize("q", [0.0, 20.0])
def test_smoother_equals_dense_least_squares(steady_flight, q) -> None:
    f = steady_flight
    n = 200  # the first 200 samples: a 600 x 600 dense problem
    part = dataclasses.replace(f, data=f.data.iloc[:n].reset_index(drop=True))
    t = np.arange(n) * part.dt
    truth = np.stack([3 + np.sin(5 * t), 4 + 0 * t, -0.5 * t], axis=1)
    z, c = _synthetic(part, truth, np.array([0.5, 0.9, 0.8]), np.random.default_rng(3))
    out = rc.smooth_air_wind(part, z, intensity=q)
    assert out.intensity == q
    if q == 0:  # a steady wind: the noise-weighted mean, every sample the same
        r_inv = np.einsum("nbi,b,nbj->nij", c, 1.0 / out.noise_sd_body**2, c)
        p = np.linalg.inv(r_inv.sum(axis=0))
        mean = p @ np.einsum("nij,nj->i", r_inv, z)
        np.testing.assert_allclose(out.wind, np.broadcast_to(mean, (n, 3)), atol=GLS_ATOL_MPS)
        np.testing.assert_allclose(out.covariance, np.broadcast_to(p, (n, 3, 3)),
                                   rtol=COV_RTOL)
        np.testing.assert_allclose(out.mean_covariance, p, rtol=COV_RTOL)
        return
    x, cov, mean_cov = _dense_gls(z, c, out.noise_sd_body, q, part.dt)
    np.testing.assert_allclose(out.wind, x, rtol=0, atol=GLS_ATOL_MPS)
    blocks = np.stack([cov[3 * k:3 * k + 3, 3 * k:3 * k + 3] for k in range(n)])
    np.testing.assert_allclose(out.covariance, blocks, rtol=COV_RTOL, atol=1e-12)
    np.testing.assert_allclose(out.mean_covariance, mean_cov, rtol=COV_RTOL, atol=1e-12)


def test_noise_sd_and_intensity_from_the_data(steady_flight) -> None:
    f = steady_flight
    rng = np.random.default_rng(7)
    sd = np.array([0.5, 0.9, 0.9])
    steady, _ = _synthetic(f, np.broadcast_to(WIND, (f.n_samples, 3)), sd, rng)
    out = rc.smooth_air_wind(f, steady)
    # the 4th differences' sd of 501 samples: ~5 % (1 sd); 20 % is 4 of it
    np.testing.assert_allclose(out.noise_sd_body, sd, rtol=0.2)
    assert out.intensity <= 1e-2  # a steady wind: (almost) no random walk
    assert np.all(np.abs(out.wind.mean(axis=0) - WIND) < 4 * np.sqrt(
        np.diag(out.mean_covariance)))
    q_true = 20.0  # a random walk of 20 (m/s)^2/s (Dryden sd 3 m/s, tau 1 s: ~18)
    walk = np.cumsum(rng.standard_normal((f.n_samples, 3)) * np.sqrt(q_true * f.dt), axis=0)
    gusty, _ = _synthetic(f, walk, sd, rng)
    out = rc.smooth_air_wind(f, gusty)
    assert q_true / 4 <= out.intensity <= 4 * q_true


def test_along_path_sensitivity_is_the_known_bias(steady_flight, reference_scenario) -> None:
    f = steady_flight  # noise-free, logged angles, no airspeed: 3 m/s along the path unseen
    truth = reference_scenario.coefficient_vector
    r = EquationErrorEstimator(air_data="measured").fit(f)
    consider = r.info["air_data_wind_consider"]
    d = flight_direction(f)
    along_true = float(np.dot(WIND, d))
    # the airspeed taken as |u, v, w| is along_true too high (to first order)
    predicted = consider["along_path_sensitivity"] * along_true
    bias = r.theta - truth
    assert np.max(np.abs(bias / truth)) > 0.01  # ~1.2 %: a known-wrong fit
    assert np.all(np.abs(bias - predicted) <= BIAS_RTOL * np.abs(predicted)
                  + 1e-4 * np.abs(truth)), (bias / truth, predicted / truth)
    # the default sd: the steady wind measured across the path (~4 m/s)
    across = np.linalg.norm(np.array(WIND) - along_true * d)
    # measured from the implied wind, whose error lies along the air velocity (the path
    # tilted by the angle of attack: its mean moves the across part by ~0.6 %)
    assert consider["along_path_sd_mps"] == pytest.approx(across, rel=0.02)
    assert np.all(np.abs(r.theta - truth) <= 1.96 * r.stderr)  # the intervals hold it
    said = [w for w in r.warnings if "airspeed taken as |u, v, w|" in w]
    sd = consider["along_path_sd_mps"]
    assert len(said) == 1 and f"consider {sd:.3g} m/s of it" in said[0]
    # told there is no along-path wind, the standard errors cannot hold the bias
    blind = EquationErrorEstimator(air_data="measured", along_path_wind_sd_mps=0.0).fit(f)
    assert np.max(np.abs(blind.theta - truth) / blind.stderr) > 10


def test_along_path_option_refused_where_unused(reference_scenario) -> None:
    s = reference_scenario
    m = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND))
    probe = GaussianNoise(alpha_sd_rad=1e-3, beta_sd_rad=1e-3, airspeed_sd_mps=0.5)
    f = simulate(s.airframe, s.coefficient_vector, m, probe, rng=2)
    with pytest.raises(EstimatorError, match="along_path_wind_sd_mps .* airspeed channel"):
        EquationErrorEstimator(along_path_wind_sd_mps=1.0).fit(f)
    with pytest.raises(ValueError, match="along_path_wind_sd_mps must be >= 0"):
        EquationErrorEstimator(along_path_wind_sd_mps=-1.0)
    r = EquationErrorEstimator().fit(f)  # with the airspeed: only the smoother's own share
    assert r.info["air_data_wind_consider"]["along_path_sd_mps"] is None
    assert "Kalman-smoothed" in r.info["air_data_note"]
