"""The one noise-level estimator (aeroid.estimation.estimate_noise_sd) on known noise."""

from __future__ import annotations

import numpy as np
import pytest

from aeroid.estimation import estimate_noise_sd, switch_free_samples

#: MAD estimator on 20000 samples of white Gaussian noise: relative standard error ~1.1 %
#: at this n (the factor 1/sqrt(1 - h0) is exact); 5 % is > 4 sigma.
MAD_RTOL = 0.05
#: RMS estimator: sd of an sd estimate from n samples ~ sd / sqrt(2 n) = 0.5 %; the SG
#: residual is a moving average (correlated), so allow 4x that.
RMS_RTOL = 0.02


def test_mad_estimate_recovers_white_noise_level() -> None:
    rng = np.random.default_rng(2)
    t = np.arange(20000) * 0.002
    x = 5 * np.sin(2 * np.pi * 0.5 * t) + 0.3 * rng.standard_normal(t.size)
    assert abs(estimate_noise_sd(x) / 0.3 - 1) < MAD_RTOL


def test_rms_estimate_recovers_white_noise_sd() -> None:
    rng = np.random.default_rng(5)
    n = 20000
    t = np.arange(n) * 0.002
    sd_true = np.array([0.1, 2.0])
    signal = np.column_stack([np.sin(2 * np.pi * 2 * t), 50 + 3 * t])
    y = signal + sd_true * rng.standard_normal((n, 2))
    sd = estimate_noise_sd(y, statistic="rms", use=switch_free_samples(np.zeros(n)),
                           floor_fraction=1e-6)
    np.testing.assert_allclose(sd, sd_true, rtol=RMS_RTOL)


def test_switch_free_samples_leave_out_relay_jumps() -> None:
    rng = np.random.default_rng(6)
    n = 5000
    delta = np.where((np.arange(n) // 50) % 2 == 0, 1.0, -1.0)
    y = (10.0 * delta + 0.05 * rng.standard_normal(n))[:, None]
    use = switch_free_samples(delta)
    # each switch removes the 7-point window around it (3 on each side, plus the step)
    assert np.count_nonzero(~use) == 8 * (n // 50 - 1)
    sd = estimate_noise_sd(y, statistic="rms", use=use, floor_fraction=1e-6)
    np.testing.assert_allclose(sd, [0.05], rtol=0.05)
    # with the jumps left in, the RMS estimate is ruined: the mask is what makes it work
    assert estimate_noise_sd(y, statistic="rms")[0] > 1.0


def test_noise_free_channel_gets_the_floor_not_zero() -> None:
    x = np.linspace(0.0, 1.0, 101)[:, None] * np.array([2.0, 0.0])
    sd = estimate_noise_sd(x, floor_fraction=1e-9)
    rms = np.sqrt(np.mean(x * x, axis=0))
    assert sd[0] == pytest.approx(1e-9 * rms[0], rel=1e-12)
    assert sd[1] > 0.0


def test_unknown_statistic_is_one_line() -> None:
    with pytest.raises(ValueError, match="statistic must be"):
        estimate_noise_sd(np.zeros(20), statistic="std")


def test_noise_law_with_a_known_part_recovers_the_noise() -> None:
    """e ~ N(0, a + b s^2 + known): the known part (a filter's H P H^T) is not noise."""
    from aeroid.estimation import fit_noise_law

    rng = np.random.default_rng(5)
    n = 40000
    s = 10.0 * np.sin(np.linspace(0.0, 80.0, n))
    known = 0.5 * np.exp(-np.arange(n) / 2000.0)  # large early, as a filter's start
    a, b = 0.04, 0.0009
    e = np.sqrt(a + b * s**2 + known) * rng.standard_normal(n)
    a_hat, b_hat = fit_noise_law((e * e)[:, None], (s * s)[:, None], known=known[:, None])
    # the sd of a weighted regression of 40 000 squared Gaussians: ~2-3 % here
    np.testing.assert_allclose([a_hat[0], b_hat[0]], [a, b], rtol=0.1)
    # ignoring the known part puts it into the noise
    a_naive, _ = fit_noise_law((e * e)[:, None], (s * s)[:, None])
    assert a_naive[0] > 1.5 * a


def test_noise_law_floor_and_constant_law() -> None:
    from aeroid.estimation import fit_noise_law

    rng = np.random.default_rng(6)
    e = 0.3 * rng.standard_normal((50000, 2))
    s2 = np.zeros_like(e)  # regressed on [1] only: a is the mean square
    a, b = fit_noise_law(e * e, s2)
    np.testing.assert_allclose(a, np.mean(e * e, axis=0), rtol=1e-12)
    np.testing.assert_array_equal(b, 0.0)
    a, _ = fit_noise_law(1e-30 * e * e, s2, floor=[1e-6, 2e-6])
    np.testing.assert_array_equal(a, [1e-6, 2e-6])
