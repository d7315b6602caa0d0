"""INS attitude beside GNSS velocity in output-error's likelihood
(``aiding = "gnss-velocity+ins-attitude"``).

References: the INS outputs' Jacobian against central differences of the outputs; the
simulator's INS (its truth's Euler angles, wrapped) against the fitted model on a
noise-free suite flight; the circle's identity (a residual across +-pi is the short way
round); an INS log whose times are 50 ms off (undeclared) against the fit check.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from suite_flights import gnss_aiding, ins_aiding, suite_flight, truth_errors

from aeroid.errors import FlightError
from aeroid.flights import reference_scenario
from aeroid.model import N_COEFFICIENTS, OUTPUT_CHANNELS
from baselines._oe_aiding import RESIDUAL_NAMES, AidingSamples, aiding_samples, on_circle
from baselines.ekf import ExtendedKalmanEstimator
from baselines.output_error import POSITION_NAMES, OutputErrorEstimator

#: Options of the aided fits: the raw IMU's errors, the initial velocity free, both sources.
AIDED = {"imu_errors": "bias+scale", "estimate_initial_velocity": True,
         "aiding": "gnss-velocity+ins-attitude"}
#: Central-difference step in scaled parameters (as test_output_error_aiding's).
FD_STEP = 1e-4
#: Exact INS sensitivities against the central differences, relative to each column's
#: largest entry (the GNSS rows' bound; the attitude is the states themselves).
FD_RTOL = 1e-5
#: Plus this absolute bound: the central difference of a roll angle that reaches ~50 rad
#: over the record's RK4 steps resolves no better (measured: Czq's column, peak 2.6e-5,
#: ins_phi's differences quantised at 4e-10 and off by up to 3.8e-9, while ins_theta and
#: ins_psi agree to 1e-5 of the peak).
FD_ROUNDING_ATOL = 1e-8
#: Noise-free suite, GNSS and INS: coefficients (relative), biases [SI], scale factors
#: against the drawn truth (the GNSS-only bounds of test_output_error_aiding); measured
#: largest 9.4e-8, 8.5e-7 and 2.9e-8.
COEFFICIENT_RTOL = 1e-6
BIAS_ATOL = 1e-5
SCALE_ATOL = 1e-6
#: The fitted model's attitude against the simulator's noise-free, wrapped INS [rad]:
#: measured largest residual RMS 7.1e-8 (ins_theta).
ANGLE_ATOL = 1e-6
#: Stated sd of the noise-free GNSS [m/s] and INS [rad] (small, so they weigh against a
#: noise-free IMU; test_output_error_aiding's CLEAN_GNSS_SD).
CLEAN_GNSS_SD = 1e-3
CLEAN_INS_SD = 1e-5
#: The undeclared INS skew tested: 50 ms at the reference flight's ~50 rad/s roll rate
#: is ~2.5 rad of roll angle.
SKEW_S = 0.05


@pytest.fixture(scope="module")
def clean():
    """Noise-free default suite (seed 3): raw IMU, true states, noise-free GNSS and INS."""
    sim, flight = suite_flight(seed=3, accel_noise_mps2=0.0, gyro_noise_radps=0.0,
                               gnss_velocity_sd_mps=0.0, ins_attitude_sd_rad=0.0)
    return sim, ins_aiding(sim, gnss_aiding(sim, flight, sd=CLEAN_GNSS_SD), sd=CLEAN_INS_SD)


def test_ins_jacobian_equals_central_differences(clean):
    _, flight = clean
    est = OutputErrorEstimator(**AIDED, compile_model=False)
    model = est.problem(flight).model
    scale = model.scale
    p = np.zeros(scale.size)
    p[:N_COEFFICIENTS] = reference_scenario().coefficient_vector / scale[:N_COEFFICIENTS]
    names = est.parameter_names(model.position_free)
    assert {"phi0", "theta0", "psi0"} <= set(names)
    for name, value in (("u0", 0.3), ("phi0", 2e-3), ("theta0", -1e-3), ("psi0", 3e-3),
                        ("bax1", 0.5)):
        p[names.index(name)] = value
    _, J = model.outputs_jacobian(p)
    ins = [s.source for s in model.samples].index("ins")
    cols = len(OUTPUT_CHANNELS) + 3 * ins + np.arange(3)
    rows = model.samples[ins].index
    assert rows.size == 101  # 100 Hz over 5-6 s
    others = np.setdiff1d(np.arange(flight.n_samples), rows)
    for i, name in enumerate(names):
        step = np.zeros_like(p)
        step[i] = FD_STEP
        fd = (model.outputs(p + step) - model.outputs(p - step))[:, cols] / (2 * FD_STEP)
        exact = J[cols, :, i].T
        if name[0] in "bs" and name[1:] in OUTPUT_CHANNELS or name in POSITION_NAMES:
            assert np.all(exact == 0.0), name
        peak = max(np.max(np.abs(fd)), 1e-300)
        np.testing.assert_allclose(exact[rows], fd[rows], rtol=0,
                                   atol=FD_RTOL * peak + FD_ROUNDING_ATOL,
                                   err_msg=name)
        assert np.all(exact[others] == 0.0)
    j = names.index("phi0")  # d phi / d phi0 at the first sample: 1 (scale 1 rad)
    assert J[cols[0], rows[0], j] == pytest.approx(1.0, abs=1e-12)


def test_noise_free_suite_flight_with_gnss_and_ins_recovers_the_truth(clean):
    sim, flight = clean
    logged = flight.metadata["aiding"]["ins"]["phi"]
    assert np.max(np.abs(logged)) <= math.pi and np.ptp(np.unwrap(logged)) > 4 * math.pi
    fit = OutputErrorEstimator(**{**AIDED, "estimate_initial_velocity": False}).fit(flight,
                                                                                     rng=0)
    assert fit.success, fit.message
    np.testing.assert_allclose(fit.theta, reference_scenario().coefficient_vector,
                               rtol=COEFFICIENT_RTOL)
    errors = truth_errors(sim)
    for name, value in fit.info["imu_errors"].items():
        assert abs(value - errors[name]) < (BIAS_ATOL if name[0] == "b" else SCALE_ATOL), name
    rms = fit.info["fit_check"]["residual_rms"]
    for c in RESIDUAL_NAMES["ins"]:  # the model's attitude is the simulator's (wrapped) INS
        assert rms[c] < ANGLE_ATOL, (c, rms[c])
    assert fit.info["aiding"]["sources"]["ins"]["n_samples"] == 101
    assert fit.info["aiding"]["n_samples"] == 101 + 11


def test_a_roll_residual_across_pi_is_the_short_way_round():
    eps = 1e-3
    z = np.array([[math.pi - eps, 0.1, -math.pi + eps]])
    s = AidingSamples(np.array([0]), z, np.ones(3), "ins")
    y = np.array([[-math.pi + eps, 0.1 + eps, math.pi - eps]])  # the model across the wrap
    np.testing.assert_allclose(z - on_circle(s, y), [[-2 * eps, -eps, 2 * eps]],
                               rtol=0, atol=1e-12)
    y_turns = y + 2 * math.pi * np.array([[3, 0, -5]])  # whole turns change nothing
    np.testing.assert_allclose(z - on_circle(s, y_turns), z - on_circle(s, y), atol=1e-9)
    gnss = s._replace(source="gnss")  # a velocity is not on the circle
    np.testing.assert_array_equal(on_circle(gnss, y), y)


@pytest.fixture(scope="module")
def noisy():
    """The default suite with noise (seed 1): raw IMU, true states, noisy GNSS."""
    sim, flight = suite_flight(seed=1)
    return sim, gnss_aiding(sim, flight)


def test_ins_skewed_50_ms_is_refused_and_the_right_times_are_not(noisy):
    sim, flight = noisy
    right = OutputErrorEstimator(**AIDED).fit(ins_aiding(sim, flight), rng=0)
    assert right.success, right.message
    truth = reference_scenario().coefficient_vector
    assert np.max(np.abs(right.theta - truth) / right.stderr) < 3.0
    errors = truth_errors(sim)
    stderr = right.info["imu_error_stderr"]
    assert max(abs(v - errors[n]) / stderr[n] for n, v in right.info["imu_errors"].items()
               if n[0] == "b") < 3.0
    skewed = OutputErrorEstimator(**AIDED).fit(ins_aiding(sim, flight, shift_s=-SKEW_S), rng=0)
    assert not skewed.success
    assert "does not fit" in skewed.message or "structure" in skewed.message, skewed.message


def test_ins_refusals_and_warnings(clean, noisy):
    sim, flight = noisy
    with pytest.raises(FlightError, match="INS attitude samples in metadata") as exc:
        OutputErrorEstimator(**AIDED).problem(flight)  # GNSS only
    assert "\n" not in str(exc.value)
    off = ins_aiding(sim, flight, shift_s=0.0004)
    with pytest.raises(FlightError, match="INS sample at t = .* ms from the flight's"):
        aiding_samples(off, "ins")
    with pytest.raises(ValueError, match="gnss-velocity\\+ins-attitude"):
        OutputErrorEstimator(aiding="ins-attitude")
    with pytest.raises(ValueError, match="aiding must be one of"):
        ExtendedKalmanEstimator(imu_errors="bias+scale", aiding="ins-attitude+gnss-velocity")
    # the note is the flight's and the option's, whatever the fit's end: one Gauss-Newton
    # step from the prior (the converged fit took 48 iterations and the equation-error
    # start ran to its 50-iteration limit: 19 s of CPU measured, for this line alone)
    gnss_only = OutputErrorEstimator(**{**AIDED, "aiding": "gnss-velocity"},
                                     equation_error_start=False, max_iterations=1)
    fit = gnss_only.fit(clean[1], rng=0)
    assert fit.n_iterations == 1  # the fit ran: the note is a result's, not a refusal's
    assert any("carries INS attitude samples" in w for w in fit.warnings), fit.warnings
