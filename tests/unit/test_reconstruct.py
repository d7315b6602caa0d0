"""EBM step 1 (aeroid.estimation): smoother, rank of eq. 29, reconstruction accuracy."""

from __future__ import annotations

import numpy as np
import pytest

from aeroid.estimation._reconstruct import (
    accel_only_matrix,
    ebm_regression,
    rate_derivatives,
    reconstruct,
    smooth,
)
from aeroid.flights._flight import make_flight
from aeroid.model import N_COEFFICIENTS
from aeroid.model._airframe import reference_airframe
from aeroid.model._dynamics import accelerometers, aero_forces_moments, constants

#: Float round-off of a 7-tap filter / a 6x6 product on O(1..1e3) numbers.
ROUNDOFF_RTOL = 1e-10
#: A polynomial of degree <= polyorder is differentiated exactly by SG (round-off only,
#: amplified by 1/dt = 500).
POLY_DERIVATIVE_ATOL = 1e-8
#: Noise-free reconstruction vs the simulator's forces, max error / channel RMS.
#: Measured: F_AX 5e-13 (no rate term), F_AY, F_AZ, M_Y, M_Z <= 1.4e-5 (set by the
#: 1e-3-weighted rate rows' derivative bias), M_X 4.2e-4 (the one direction only the
#: 101-point roll-rate derivative sees; its bias at the record ends). Margin x5.
RECON_RTOL = np.array([1e-11, 1e-4, 1e-4, 2e-3, 1e-4, 1e-4])


def test_smoother_is_the_papers_eq32_weights_in_the_interior() -> None:
    x = np.random.default_rng(3).standard_normal(200).cumsum()
    weights = np.array([-2, 3, 6, 7, 6, 3, -2]) / 21.0
    by_hand = np.convolve(x, weights[::-1], mode="valid")
    np.testing.assert_allclose(smooth(x)[3:-3], by_hand, rtol=ROUNDOFF_RTOL, atol=1e-12)


def test_smoother_rejects_even_window() -> None:
    with pytest.raises(ValueError, match="odd"):
        smooth(np.zeros(20), window=6)


def test_accel_only_matrix_has_rank_5_with_null_vector_along_r2_minus_r1() -> None:
    rng = np.random.default_rng(11)
    base = reference_airframe()
    for _ in range(5):
        pos = rng.uniform(-1, 1, (2, 3))
        af = base.replace(accel1_position_m=tuple(pos[0]), accel2_position_m=tuple(pos[1]))
        A = accel_only_matrix(af)
        assert A.shape == (6, 6)
        assert np.linalg.matrix_rank(A) == 5
        # an angular acceleration along R2 - R1 (moments J (R2 - R1)) with the force that
        # cancels its tangential acceleration at R1 is invisible to both triads
        c = constants(af)
        wdot = pos[1] - pos[0]
        null = np.concatenate([-c.mass * np.cross(wdot, pos[0]),
                               np.array([c.ix, c.iy, c.iz]) * wdot])
        np.testing.assert_allclose(A @ null, 0.0, atol=1e-12 * np.abs(null).max())


def test_eq29_matches_the_sensor_model() -> None:
    """a = A FM + B reproduces aeroid.flights.accelerometers (independent code) at random states."""
    af = reference_airframe()
    const = constants(af)
    rng = np.random.default_rng(5)
    state = np.column_stack([rng.uniform(400, 600, 20), rng.uniform(-10, 10, (20, 2)),
                             rng.uniform(-60, 60, (20, 3)), rng.uniform(-0.5, 0.5, (20, 3))])
    delta = rng.uniform(-0.14, 0.14, 20)
    theta = af.prior_vector()
    fm = aero_forces_moments(state, delta, theta, const)
    a_model = accelerometers(state, delta, theta, const, af.accel_positions).reshape(20, 6)
    a_zero = accelerometers(state, delta, np.zeros(N_COEFFICIENTS), const,
                          af.accel_positions).reshape(20, 6)
    # with zero coefficients FM = 0, so the reading is B alone
    A = accel_only_matrix(af)
    np.testing.assert_allclose(fm @ A.T + a_zero, a_model, rtol=ROUNDOFF_RTOL, atol=1e-9)


def test_rate_rows_make_the_system_full_rank(clean_flight) -> None:
    assert reconstruct(clean_flight).rank == 6
    assert reconstruct(clean_flight, rate_rows=False).rank == 5


def test_noise_free_reconstruction_matches_true_forces(clean_flight) -> None:
    truth = clean_flight.true_coefficients
    fm_true = aero_forces_moments(clean_flight.states(), clean_flight["delta"], truth,
                                  constants(clean_flight.airframe))
    rec = reconstruct(clean_flight)
    rms = np.sqrt(np.mean(fm_true**2, axis=0))
    err = np.max(np.abs(rec.fm - fm_true), axis=0) / rms
    assert np.all(err < RECON_RTOL), err
    frame = rec.to_frame()
    assert list(frame.columns[:7]) == ["t", "FAX", "FAY", "FAZ", "MX", "MY", "MZ"]
    np.testing.assert_array_equal(frame["MY_smooth"].to_numpy(), rec.fm_smooth[:, 4])


def test_rate_derivatives_exact_on_quadratics(clean_flight) -> None:
    t = clean_flight.t
    data = clean_flight.data.copy()
    data["p"] = 50 + 3.0 * (t - 5) - 1.5 * (t - 5) ** 2
    data["q"] = 0.2 - 4.0 * (t - 5) ** 2
    data["r"] = -0.1 + 2.0 * (t - 5)
    flight = make_flight(data, clean_flight.airframe)
    d = rate_derivatives(flight, roll_window=101)
    expected = np.column_stack([3.0 - 3.0 * (t - 5), -8.0 * (t - 5), np.full_like(t, 2.0)])
    np.testing.assert_allclose(d, expected, atol=POLY_DERIVATIVE_ATOL)


def test_ebm_regression_smoothing_modes(clean_flight) -> None:
    rec = reconstruct(clean_flight)
    theta = clean_flight.true_coefficients
    X_none, y_none = ebm_regression(clean_flight, rec, smoothing="none")
    X_forces, y_forces = ebm_regression(clean_flight, rec, smoothing="forces")
    X_both, y_both = ebm_regression(clean_flight, rec, smoothing="both")
    assert X_none.shape == (clean_flight.n_samples, 6, N_COEFFICIENTS)
    np.testing.assert_array_equal(y_none, rec.fm)
    np.testing.assert_array_equal(X_forces, X_none)
    np.testing.assert_array_equal(y_forces, rec.fm_smooth)
    # the SG filter is linear: smoothing the regressor columns smooths X theta exactly
    np.testing.assert_allclose(X_both @ theta, smooth(X_none @ theta), rtol=ROUNDOFF_RTOL,
                               atol=1e-9)
    with pytest.raises(ValueError, match="smoothing"):
        ebm_regression(clean_flight, rec, smoothing="paper")


def test_reconstruct_rejects_bad_weight(clean_flight) -> None:
    with pytest.raises(ValueError, match="rate_weight"):
        reconstruct(clean_flight, rate_weight=0.0)
