"""Equation-error's Newey-West covariance: O(n L) cost, same numbers as the lag-by-lag sums."""

from __future__ import annotations

import numpy as np
import pytest
from closeness import assert_close_in_norm

from aeroid.estimation import _reconstruct as rc
from aeroid.flights._noise import GaussianNoise
from aeroid.flights._scenario import reference_scenario
from aeroid.flights._simulate import simulate_scenario
from baselines.equation_error import (
    SUBPROBLEMS,
    EquationErrorEstimator,
    _lstsq,
    affine_accelerations,
)
from baselines.newey_west import (
    MAX_CORRELATION_LENGTH,
    bartlett_meat,
    hac_covariance,
    residual_correlation_length,
)

#: The FIR-filtered scores and the lag-by-lag products sum the same terms in another
#: order, so they agree to a few ulps of the largest entry, not of each entry: an entry
#: that cancels to 4.8e-4 beside entries of ~1 differed by 5.6e-16 (1.2e-12 relative)
#: on an AVX-512 machine. Compared against the matrix's largest magnitude
#: (tests/closeness.py); measured <= 5e-14 of it at 1..500 lags.
MEAT_RTOL = 1e-12
#: The sandwich B S B multiplies those roundings by the condition of B (1e4 for the
#: Cl0/Clp and the one-step problems after column scaling): measured <= 4e-11.
COV_RTOL = 1e-9


def _meat_reference(g, lags):
    """The former form: one cross-product per lag, summed in a loop (O(n^2 p^2) when the
    bandwidth grows with the record)."""
    S = g.T @ g
    for lag in range(1, min(lags, len(g) - 1) + 1):
        G = g[lag:].T @ g[:-lag]
        S += (1.0 - lag / (lags + 1.0)) * (G + G.T)
    return S


def _hac_reference(A, e, n_time, lags):
    g = (A * e[:, None]).reshape(n_time, -1, A.shape[1]).sum(axis=1)
    bread = np.linalg.pinv(A.T @ A)
    return bread @ _meat_reference(g, lags) @ bread


def _length_reference(e, cap):
    """First lag with |acf| < 2 / sqrt(n), by direct sums lag after lag (max over columns)."""
    e = np.asarray(e, dtype=float).reshape(len(e), -1)
    n, length = e.shape[0], 1
    for j in range(e.shape[1]):
        x = e[:, j] - e[:, j].mean()
        var = float(x @ x)
        lag = cap
        for k in range(1, cap):
            if var == 0.0 or abs(float(x[k:] @ x[:-k])) / var < 2.0 / np.sqrt(n):
                lag = k
                break
        length = max(length, lag)
    return length


@pytest.fixture(scope="module")
def small_flight():
    noise = GaussianNoise(accel_sd_mps2=0.2, rate_sd_radps=0.01, position_sd_m=0.0)
    return simulate_scenario(reference_scenario(), noise, rng=8)


def _problems(flight):
    """(A scaled as in the fit, residuals, n_time, k) of the four sub-problems and one-step."""
    rec = rc.reconstruct(flight)
    X, y = rc.ebm_regression(flight, rec, smoothing="none")
    out = []
    for _, row, cols in SUBPROBLEMS:
        A, b = X[:, row, list(cols)], y[:, row]
        out.append((A, b, flight.n_samples))
    c, A9 = affine_accelerations(flight)
    n = flight.n_samples
    meas = np.concatenate([flight.accelerations().reshape(n, 6), rc.rate_derivatives(flight)],
                          axis=1)
    sd = np.std(meas - c, axis=0)
    out.append(((A9 / sd[None, :, None]).reshape(-1, A9.shape[-1]),
                ((meas - c) / sd).reshape(-1), n))
    scaled = []
    for A, b, n_time in out:
        As = A / np.sqrt(np.sum(A * A, axis=0))
        e = b - As @ np.linalg.lstsq(As, b, rcond=None)[0]
        scaled.append((As, e, n_time))
    return scaled


@pytest.mark.parametrize("lags", [1, 7, 80, 250, 500])
def test_hac_equals_the_lag_by_lag_sum(small_flight, lags):
    """Every sub-problem and the one-step problem (9 rows per sample), bandwidths from 1
    to the whole record (500: every pair of the 501 samples)."""
    for As, e, n_time in _problems(small_flight):
        g = (As * e[:, None]).reshape(n_time, -1, As.shape[1]).sum(axis=1)
        assert_close_in_norm(bartlett_meat(g, lags), _meat_reference(g, lags), MEAT_RTOL)
        assert_close_in_norm(hac_covariance(As, e, n_time, lags),
                             _hac_reference(As, e, n_time, lags), COV_RTOL)


def test_correlation_length_equals_the_direct_search(small_flight):
    """The FFT autocorrelation picks the same lag as the lag-by-lag search, on the fits'
    residuals and on moving averages of 1..60 samples (lengths up to the cap)."""
    for _, e, n_time in _problems(small_flight):
        r = e.reshape(n_time, -1)
        assert residual_correlation_length(r, n_time // 4) == _length_reference(r, n_time // 4)
    rng = np.random.default_rng(3)
    for width in (1, 5, 20, 60):
        x = np.convolve(rng.normal(size=2000 + width), np.ones(width), "valid")[:2000]
        assert residual_correlation_length(x, 500) == _length_reference(x, 500), width


def test_white_noise_gives_a_short_bandwidth():
    """White residuals, 20,000 samples, 3 channels: the first lag is already inside the
    95 % band in each (the chance that one of three is outside at lags 1 and 2 is
    ~1 - 0.9975^3, under 1 %; seeded)."""
    e = np.random.default_rng(11).normal(size=(20_000, 3))
    assert residual_correlation_length(e, 5000) <= 2


def test_correlation_length_is_capped_whatever_the_record_length():
    """A random walk is correlated at every lag: the length stops at the fixed cap, not at
    n // 4 (5000 here), so the bandwidth and the cost do not grow with the record."""
    walk = np.cumsum(np.random.default_rng(5).normal(size=20_000))
    A = np.column_stack([np.ones(20_000), np.linspace(0.0, 1.0, 20_000)])
    *_, bandwidth = _lstsq(A, walk, n_time=20_000)
    assert bandwidth == {"lags": 2 * MAX_CORRELATION_LENGTH, "capped": True}


def test_fit_reports_its_bandwidth_and_warns_when_capped(small_flight):
    res = EquationErrorEstimator().fit(small_flight, rng=0)
    bw = res.info["hac_bandwidth"]
    assert set(bw) == {label for label, _, _ in SUBPROBLEMS}
    assert all(0 < b["lags"] <= 2 * 125 and not b["capped"] for b in bw.values())
    assert not any("Newey-West" in w for w in res.warnings)
    ols = EquationErrorEstimator(covariance="ols", one_step=True).fit(small_flight, rng=0)
    assert ols.info["hac_bandwidth"] == {"one_step": {"lags": 0, "capped": False}}
