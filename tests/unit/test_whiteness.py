"""The whiteness tests of the fit check: closed forms, their null distribution, their power."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from aeroid.estimation import autocorrelation_test, switch_test

#: Series per Monte-Carlo check and their length (a reference flight's 501 samples).
N_SERIES, N_SAMPLES = 400, 501
#: Nominal level of the Monte-Carlo checks; the rejection count is binomial(400, 0.05):
#: 20 expected, sd 4.4; the band below is +-3.5 sd.
LEVEL = 0.05
BAND = (5, 36)


def test_one_lag_statistic_is_the_robust_squared_correlation() -> None:
    """With one lag the score statistic is (sum e_t e_(t-1))^2 / sum e_t^2 e_(t-1)^2."""
    e = np.random.default_rng(0).standard_normal(300)
    test = autocorrelation_test(e, lags=1)
    head, lag = e[1:], e[:-1]
    expected = np.sum(head * lag) ** 2 / np.sum(head**2 * lag**2)
    assert test.statistic == pytest.approx(expected, rel=1e-12)
    assert test.dof == 1
    assert test.p_value == pytest.approx(stats.chi2.sf(expected, 1), rel=1e-12)


def test_switch_statistic_with_isolated_switches_is_a_sum_over_them() -> None:
    """Isolated switches of signs s_i at samples t_i, one lag: the statistic is
    (sum s_i e_(t_i))^2 / sum e_(t_i)^2."""
    e = np.random.default_rng(1).standard_normal(200)
    delta = np.zeros(200)
    delta[50:120] = 0.1  # up at 50, down at 120
    test = switch_test(e, delta, lags=0)
    expected = (e[50] - e[120]) ** 2 / (e[50] ** 2 + e[120] ** 2)
    assert test.statistic == pytest.approx(expected, rel=1e-12)
    assert test.dof == 1


@pytest.mark.parametrize("noise", ["gaussian", "uniform, variance changing 10x"])
def test_white_noise_is_refused_at_the_nominal_rate(noise: str) -> None:
    """White noise, constant or with a variance changing over time (the paper's noise is
    proportional to the signal): rejection at 5 % within the binomial band."""
    rng = np.random.default_rng(2)
    delta = np.where(np.sin(np.arange(N_SAMPLES) / 3.0) > 0, 0.14, -0.14)
    rejected_auto = rejected_switch = 0
    for _ in range(N_SERIES):
        if noise == "gaussian":
            e = rng.standard_normal(N_SAMPLES)
        else:
            e = rng.uniform(-1, 1, N_SAMPLES) * np.linspace(1, 10, N_SAMPLES)
        rejected_auto += autocorrelation_test(e).p_value < LEVEL
        rejected_switch += switch_test(e, delta).p_value < LEVEL
    assert BAND[0] <= rejected_auto <= BAND[1]
    assert BAND[0] <= rejected_switch <= BAND[1]


def test_structure_is_found() -> None:
    """An AR(1) residual (coefficient 0.4) and a residual with a spike at each switch of
    twice the noise's sd: found at p < 1e-6 on 501 samples (53 switches)."""
    rng = np.random.default_rng(3)
    e = rng.standard_normal(N_SAMPLES)
    ar = e.copy()
    for t in range(1, ar.size):
        ar[t] += 0.4 * ar[t - 1]
    assert autocorrelation_test(ar).p_value < 1e-6
    delta = np.where(np.sin(np.arange(N_SAMPLES) / 3.0) > 0, 0.14, -0.14)
    spikes = e + 2.0 * np.sign(np.diff(delta, prepend=delta[0]))
    assert switch_test(spikes, delta).p_value < 1e-6
    assert switch_test(e, np.zeros(N_SAMPLES)).p_value == 1.0  # no switch: nothing to test


def test_a_filter_residual_belongs_to_the_last_samples() -> None:
    e = np.random.default_rng(4).standard_normal(N_SAMPLES)
    delta = np.where(np.sin(np.arange(N_SAMPLES) / 3.0) > 0, 0.14, -0.14)
    half = N_SAMPLES // 2
    spikes = e + 3.0 * np.sign(np.diff(delta, prepend=delta[0]))
    assert switch_test(spikes[half:], delta).p_value < 1e-4  # 26 switches
    assert switch_test(spikes[half:], np.roll(delta, 5)).p_value > 1e-3  # misaligned
    with pytest.raises(ValueError, match="residuals for"):
        switch_test(np.ones(N_SAMPLES + 1), delta)
