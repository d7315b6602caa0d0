"""GNSS velocity in output-error's likelihood (``aiding = "gnss-velocity"``).

References: the aiding outputs' Jacobian against central differences of the outputs; the
simulator's GNSS velocity (``C_nb [u v w]`` of its truth, :func:`aeroid.flights.
simulate_suite`) against the fitted model's prediction on a noise-free suite flight; a
GNSS log whose times are 0.5 s off (undeclared) against the fit check. A 50 ms skew is
not refused: over the 1-s window the NED velocity is nearly linear in time, so a skew is
nearly a constant offset, which the free initial velocity absorbs (measured:
benchmarks/bench_aiding.py).
"""

from __future__ import annotations

import numpy as np
import pytest
from suite_flights import gnss_aiding, suite_flight, truth_errors

from aeroid.errors import EstimatorError, FlightError
from aeroid.flights import Windows, reference_scenario
from aeroid.model import N_COEFFICIENTS, OUTPUT_CHANNELS
from baselines._oe_aiding import AIDING_CHANNELS, aiding_samples
from baselines.output_error import POSITION_NAMES, OutputErrorEstimator

#: Options of the aided fits: the raw IMU's errors and the initial velocity free.
AIDED = {"imu_errors": "bias+scale", "estimate_initial_velocity": True,
         "aiding": "gnss-velocity"}
#: Central-difference step in scaled parameters (coefficients over their prior, m/s,
#: rad): the differences of a 500 m/s velocity lose digits to rounding below it (Czq at
#: 1e-6: 1.3e-4 off) and to truncation above (Clp at 1e-3: 1.7e-6 off).
FD_STEP = 1e-4
#: Exact aiding sensitivities against the central differences, relative to each
#: column's largest entry: measured largest 1.5e-6 (Czq, the smallest column).
FD_RTOL = 1e-5
#: Noise-free suite flight and GNSS, GNSS in (stated sd :data:`CLEAN_GNSS_SD`):
#: coefficients (relative), IMU biases [SI] and scale factors against the drawn truth;
#: measured largest 5.0e-8, 8.1e-7 and 3.4e-8 (as without GNSS: README "Fitting the IMU's
#: errors").
COEFFICIENT_RTOL = 1e-6
BIAS_ATOL = 1e-5
SCALE_ATOL = 1e-6
#: The fitted model's NED velocity against the simulator's noise-free GNSS [m/s]
#: (500 m/s): measured largest residual RMS 1.1e-5 (vd).
VELOCITY_ATOL = 1e-4
#: The stated sd of the noise-free GNSS [m/s]: small, so the GNSS weighs against a
#: noise-free IMU (with 0.1 the IMU's vanishing variances leave pitch and heading to it
#: alone and the fit crept: 50 iterations, coefficients 1e-3 off).
CLEAN_GNSS_SD = 1e-3
#: An undeclared GNSS skew the fit check refuses (measured on seed 1: ve residual 4.5x
#: its sd; 0.2 s: 2.8x, passed).
REFUSED_SKEW_S = 0.5


@pytest.fixture(scope="module")
def clean():
    """Noise-free default suite (seed 3): raw IMU, true states, noise-free GNSS velocity."""
    sim, flight = suite_flight(seed=3, accel_noise_mps2=0.0, gyro_noise_radps=0.0,
                               gnss_velocity_sd_mps=0.0)
    return sim, gnss_aiding(sim, flight, sd=CLEAN_GNSS_SD)


def test_aiding_jacobian_equals_central_differences(clean):
    _, flight = clean
    est = OutputErrorEstimator(**AIDED, compile_model=False)
    prob = est.problem(flight)
    model = prob.model
    scale = model.scale
    p = np.zeros(scale.size)
    p[:N_COEFFICIENTS] = reference_scenario().coefficient_vector / scale[:N_COEFFICIENTS]
    names = est.parameter_names(model.position_free)
    for name, value in (("u0", 0.3), ("w0", -0.2), ("theta0", -1e-3),
                        ("psi0", 3e-3), ("bax1", 0.5)):
        p[names.index(name)] = value
    _, J = model.outputs_jacobian(p)
    m = len(OUTPUT_CHANNELS)
    rows = model.samples[0].index
    assert rows.size == 11
    for i, name in enumerate(names):
        step = np.zeros_like(p)
        step[i] = FD_STEP
        fd = (model.outputs(p + step) - model.outputs(p - step))[:, m:] / (2 * FD_STEP)
        exact = J[m:, :, i].T
        if name[0] in "bs" and name[1:] in OUTPUT_CHANNELS or name in POSITION_NAMES:
            assert np.all(exact == 0.0), name  # IMU errors, positions: the states don't move
        peak = max(np.max(np.abs(fd)), 1e-300)
        np.testing.assert_allclose(exact[rows], fd[rows], rtol=0, atol=FD_RTOL * peak,
                                   err_msg=name)
        assert np.all(exact[np.setdiff1d(np.arange(flight.n_samples), rows)] == 0.0)


def test_noise_free_suite_flight_with_gnss_recovers_the_truth(clean):
    sim, flight = clean
    options = {**AIDED, "estimate_initial_velocity": False}  # the flight's true u v w
    fit = OutputErrorEstimator(**options).fit(flight, rng=0)
    assert fit.success, fit.message
    truth = reference_scenario().coefficient_vector
    np.testing.assert_allclose(fit.theta, truth, rtol=COEFFICIENT_RTOL)
    errors = truth_errors(sim)
    for name, value in fit.info["imu_errors"].items():
        atol = BIAS_ATOL if name[0] == "b" else SCALE_ATOL
        assert abs(value - errors[name]) < atol, name
    # the model's NED velocity is the simulator's GNSS (an independent computation)
    for c in AIDING_CHANNELS:
        assert np.max(np.abs(fit.info["fit_check"]["residual_rms"][c])) < VELOCITY_ATOL, c
    assert fit.info["aiding"]["n_samples"] == 11
    assert "psi0" in fit.info["parameter_names"]


@pytest.fixture(scope="module")
def noisy():
    """The default suite with noise (seed 1): raw IMU, true states, noisy GNSS."""
    return suite_flight(seed=1)


def test_gnss_skewed_half_a_second_is_refused_and_the_right_times_are_not(noisy):
    sim, flight = noisy
    right = OutputErrorEstimator(**AIDED).fit(gnss_aiding(sim, flight), rng=0)
    assert right.success, right.message
    truth = reference_scenario().coefficient_vector
    assert np.max(np.abs(right.theta - truth) / right.stderr) < 3.0
    skewed = OutputErrorEstimator(**AIDED).fit(gnss_aiding(sim, flight, shift_s=-REFUSED_SKEW_S),
                                                  rng=0)
    assert not skewed.success
    assert "does not fit" in skewed.message or "structure" in skewed.message, skewed.message


def test_aiding_refusals_are_one_line(clean, noisy):
    sim, flight = clean
    with pytest.raises(FlightError, match="metadata\\['aiding'\\]") as exc:
        OutputErrorEstimator(**AIDED).problem(noisy[1])
    assert "\n" not in str(exc.value)
    off = gnss_aiding(sim, flight, shift_s=0.0004, sd=CLEAN_GNSS_SD)  # between two samples
    with pytest.raises(FlightError, match="ms from the flight's nearest sample") as exc:
        aiding_samples(off)
    assert "\n" not in str(exc.value)
    with pytest.raises(ValueError, match="aiding must be one of"):
        OutputErrorEstimator(aiding="gnss")
    with pytest.raises(EstimatorError, match="not available for several windows"):
        OutputErrorEstimator(**AIDED).fit(Windows((flight, flight), ("a", "b")), rng=0)


def test_option_off_warns_that_the_samples_are_left_out(noisy):
    sim, flight = noisy
    fit = OutputErrorEstimator(imu_errors="bias+scale").fit(gnss_aiding(sim, flight), rng=0)
    assert any("not in this fit's likelihood" in w for w in fit.warnings)
