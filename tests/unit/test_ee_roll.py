"""Equation-error's roll row seen through the p derivative's window (baselines/_ee_roll.py).

References: the identity ``D[p] = S[pdot]`` on a roll rate written in closed form (its
derivative by hand); on a noise-free flight the reconstruction's roll moment equals
``S`` of the true moment (the model's loads at the true coefficients); on a Dryden sd 3
flight with the true wind given, the per-sample regressors leave the roll moment's
residual > 3x its noise (the fit check's false alarm, seed 6: 3.4x) and the windowed
ones near 1x.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import stats
from scipy.signal import savgol_filter

from aeroid import estimation as rc
from aeroid.flights import (
    GaussianNoise,
    Wind,
    record_flight,
    reference_scenario,
    simulate_truth,
)
from baselines._ee_roll import (
    ROLL_ROW,
    derivative_adjoint,
    roll_window,
    roll_window_blocks,
    through_roll_window,
)
from baselines.equation_error import EquationErrorEstimator

#: Rounding beyond the trapezoid's own error (relative to the largest pdot).
IDENTITY_RTOL = 1e-9
#: The reconstruction's noise-free roll moment against the windowed model, relative to
#: the moment's largest value: the trapezoid and SG rounding (measured 3.5e-8; the
#: per-sample model is 3.7e-4 off, the window's smoothing of a still-air moment).
WINDOWED_ATOL = 1e-6


def test_window_identity_on_a_closed_form_rate(clean_flight) -> None:
    f = clean_flight
    t = f.t - f.t[0]
    w = 2 * math.pi * 8.0  # the roll frequency's scale: 8 Hz
    p = 50.0 + 3.0 * t - 0.4 * t**2 + 0.7 * np.sin(w * t)
    pdot = 3.0 - 0.8 * t + 0.7 * w * np.cos(w * t)
    derivative = savgol_filter(p, roll_window(f), rc.ROLL_POLYORDER, deriv=1, delta=f.dt,
                               mode="interp")
    seen = through_roll_window(f, pdot)
    # the trapezoid is exact on the polynomial part and scales a sinusoid's integral by
    # (w dt / 2) / tan(w dt / 2) = 1 - (w dt)^2 / 12 + ...: its error, before the window
    trapezoid = (w * f.dt) ** 2 / 12 * 0.7 * w
    np.testing.assert_allclose(seen, derivative, rtol=0,
                               atol=1.01 * trapezoid + IDENTITY_RTOL * np.abs(pdot).max())
    # the window smooths: the 8 Hz part is not pdot's (the target never was)
    assert np.max(np.abs(seen - pdot)) > 0.5 * 0.7 * w


def test_noise_free_roll_moment_is_the_windowed_model(clean_flight, reference_scenario
                                                      ) -> None:
    f = clean_flight
    rec = rc.reconstruct(f)
    X, _ = rc.ebm_regression(f, rec, smoothing="none")
    model = X[:, ROLL_ROW] @ reference_scenario.coefficient_vector  # per sample
    scale = np.abs(model).max()
    windowed = through_roll_window(f, model)
    off_windowed = np.max(np.abs(rec.fm[:, ROLL_ROW] - windowed)) / scale
    off_per_sample = np.max(np.abs(rec.fm[:, ROLL_ROW] - model)) / scale
    assert off_windowed < WINDOWED_ATOL
    assert off_per_sample > 100 * WINDOWED_ATOL


def _turbulent(seed):
    """The reference flight in a 3/4 wind with Dryden sd 3 m/s (tactical IMU, no probe)
    and the simulator's wind per sample."""
    s = reference_scenario()
    m = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=(3.0, 4.0, 0.0),
                                                   turbulence_sd_mps=3.0))
    rng = np.random.default_rng(seed)
    truth = simulate_truth(s.airframe, s.coefficient_vector, m, rng=rng)
    f = record_flight(s.airframe, s.coefficient_vector, m, truth, GaussianNoise(), rng=rng)
    k0 = int(round(m.window_s[0] / m.dt))
    return f, np.asarray(truth.wind[k0:], dtype=float)


@pytest.mark.parametrize("seed", [6])
def test_roll_false_alarm_in_turbulence_with_the_true_wind(seed) -> None:
    f, wind = _turbulent(seed)
    rec = rc.reconstruct(f)
    X, y = rc.ebm_regression(f, rec, smoothing="none", wind=wind)
    problem = next(p for p in rc.SEBM_PROBLEMS if p.row == ROLL_ROW)
    cols = list(problem.coefficients)
    noise = rec.fm_sd[ROLL_ROW]

    def ratio(a):
        theta = np.linalg.lstsq(a, y[:, ROLL_ROW], rcond=None)[0]
        return float(np.sqrt(np.mean((y[:, ROLL_ROW] - a @ theta) ** 2)) / noise)

    per_sample = ratio(X[:, ROLL_ROW, cols])
    windowed = ratio(through_roll_window(f, X[:, ROLL_ROW])[:, cols])
    assert per_sample > 3.0  # the known inconsistency: above the fit check's limit
    assert windowed < 2.0
    r = EquationErrorEstimator()._solve(f, wind=wind)  # the estimator, the true wind
    check = r.info["fit_residuals"]["MX"]
    assert np.sqrt(np.mean(check**2)) / r.info["fit_noise_sd"]["MX"] == pytest.approx(
        windowed, rel=1e-6)


def test_derivative_adjoint_is_the_dense_transpose(clean_flight) -> None:
    f = clean_flight
    n = f.n_samples
    dense = savgol_filter(np.eye(n), roll_window(f), rc.ROLL_POLYORDER, deriv=1,
                          delta=f.dt, axis=0, mode="interp")  # D, column j = D e_j
    x = np.random.default_rng(4).standard_normal((n, 2))
    np.testing.assert_allclose(derivative_adjoint(f, x), dense.T @ x, rtol=0,
                               atol=1e-9 * np.abs(dense.T @ x).max())


@pytest.mark.slow  # 20 flights, ~30 s
def test_roll_pair_standard_errors_hold_their_errors(reference_scenario) -> None:
    """Still air, tactical IMU: Cl0's and Clp's z = error / se over 20 seeds, mean z^2
    within chi-square(20)'s 0.1 % tails (the Newey-West se gave ~2.0 over 30 seeds:
    intervals 1.4x too narrow; the known structure 1.02)."""
    s = reference_scenario
    i = next(list(p.coefficients) for p in rc.SEBM_PROBLEMS if p.row == ROLL_ROW)
    z = []
    for seed in range(20):
        rng = np.random.default_rng(seed)
        truth = simulate_truth(s.airframe, s.coefficient_vector, s.manoeuvre, rng=rng)
        f = record_flight(s.airframe, s.coefficient_vector, s.manoeuvre, truth,
                          GaussianNoise(), rng=rng)
        r = EquationErrorEstimator(air_data="inertial").fit(f)
        z.append((r.theta[i] - s.coefficient_vector[i]) / r.stderr[i])
    z2 = np.mean(np.square(z), axis=0)
    low, high = stats.chi2.ppf([1e-3, 1 - 1e-3], 20) / 20
    assert np.all((low < z2) & (z2 < high)), z2


def test_window_only_for_a_wind_that_varies(clean_flight) -> None:
    """Per sample (the blocks themselves) without a wind or with a steady one: under the
    paper's noise the window costs Cl0 and Clp ~2.5x (benchmarks/bench_air_data_roll.py
    --noise paper), so it is used where the air data give a wind per sample only."""
    f = clean_flight

    def blocks():
        return rc.regressor_blocks(f, smoothing="none", block=100)

    plain = np.concatenate([p for _, _, p in blocks()])
    steady = np.broadcast_to([3.0, 4.0, 0.0], (f.n_samples, 3))
    for wind in (None, steady):
        got = np.concatenate([p for _, _, p in roll_window_blocks(f, wind, blocks)()])
        np.testing.assert_array_equal(got, plain)
    moving = steady + np.linspace(0.0, 1.0, f.n_samples)[:, None]
    got = np.concatenate([p for _, _, p in roll_window_blocks(f, moving, blocks)()])
    np.testing.assert_allclose(got[:, ROLL_ROW], through_roll_window(f, plain[:, ROLL_ROW]))
    others = [r for r in range(plain.shape[1]) if r != ROLL_ROW]
    np.testing.assert_array_equal(got[:, others], plain[:, others])


def test_roll_row_is_collected_in_the_fits_own_pass(clean_flight) -> None:
    """Per sample, the roll row comes from the first full pass the fit makes (one pass
    over the blocks in all, not two) and equals the blocks' row; windowed, the window
    needs it first (two passes). Reference: the blocks' row concatenated by hand."""
    f = clean_flight
    passes = []

    def blocks():
        passes.append(1)
        return rc.regressor_blocks(f, smoothing="none", block=100)

    plain = np.concatenate([p for _, _, p in blocks()])[:, ROLL_ROW]
    passes.clear()
    rolled = roll_window_blocks(f, None, blocks)
    assert not passes
    for _ in rolled():  # the fit's pass
        pass
    assert len(passes) == 1
    np.testing.assert_array_equal(rolled.roll_row, plain)
    for _ in rolled():  # a later pass (the fit check's) leaves the row as it was
        pass
    assert len(passes) == 2
    np.testing.assert_array_equal(rolled.roll_row, plain)
    passes.clear()
    asked_first = roll_window_blocks(f, None, blocks)  # asked before any pass: one of its own
    np.testing.assert_array_equal(asked_first.roll_row, plain)
    assert len(passes) == 1
    passes.clear()
    moving = np.linspace(0.0, 1.0, f.n_samples)[:, None] * np.ones(3)
    windowed = roll_window_blocks(f, moving, blocks)
    np.testing.assert_array_equal(windowed.roll_row, through_roll_window(f, plain))
    assert len(passes) == 1
