"""Output-error with the IMU's errors as parameters (``imu_errors``), on sensor-suite flights.

The reference: :func:`aeroid.flights.simulate_suite` draws each flight's biases and scale
factors and applies ``(1 + s) truth + b`` to the true accelerations and rates; the fit
must return those numbers (and the coefficients) from the raw readings.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from suite_flights import clean_suite_flight, truth_errors

import aeroid
from aeroid.errors import EstimatorError
from aeroid.flights import (
    GaussianNoise,
    reference_scenario,
    simulate_scenario,
)
from aeroid.model import OUTPUT_CHANNELS, STATE_NAMES
from baselines.output_error import OutputErrorEstimator

#: Noise-free recovery of the coefficients: the model (2 RK4 substeps of 0.5 ms) against
#: the 0.25 ms truth; measured largest relative error 5.1e-8 (seed 3).
RECOVERY_RTOL = 1e-6
#: Noise-free recovery of the IMU errors [m/s^2, rad/s, -]: measured largest errors 3.7e-7
#: (accelerometer bias), 8.1e-7 (roll gyro bias: nearly confounded with its scale factor at
#: a roll rate that hardly changes) and 3.4e-8 (scale factor), against drawn values of
#: 0.02-0.2, 0.001-0.005 and 0.001-0.005.
ACCEL_BIAS_ATOL = 1e-5
GYRO_BIAS_ATOL = 1e-5
SCALE_ATOL = 1e-6
#: The filters' noise-free recovery with the IMU errors as states: measured largest
#: relative error 8.9e-6 (EKF, Clp; the filter's measurement sd is floored at 1e-4 of
#: each channel's RMS), 6.4e-6 (UKF).
EKF_RTOL = 1e-4
#: Central differences (relative step 1e-6) against the exact Jacobian.
FD_RTOL = 1e-5


@pytest.fixture(scope="module")
def clean_suite():
    """The reference window logged by the default suite without noise: raw IMU, true states."""
    return clean_suite_flight(seed=3)


@pytest.fixture(scope="module")
def clean_fit(clean_suite):
    _, flight = clean_suite
    return OutputErrorEstimator(imu_errors="bias+scale").fit(flight, rng=0)


def test_noise_free_suite_recovers_coefficients_and_imu_errors(clean_suite, clean_fit):
    sim, flight = clean_suite
    res = clean_fit
    assert res.success, res.message
    np.testing.assert_allclose(res.theta, reference_scenario().coefficient_vector,
                               rtol=RECOVERY_RTOL)
    truth = truth_errors(sim)
    assert list(res.info["imu_errors"]) == list(truth)
    for name, value in truth.items():
        atol = (SCALE_ATOL if name[0] == "s" else
                GYRO_BIAS_ATOL if name[1:] in ("p", "q", "r") else ACCEL_BIAS_ATOL)
        assert res.info["imu_errors"][name] == pytest.approx(value, abs=atol), name
        assert res.info["imu_error_stderr"][name] > 0.0
    # the roll rate hardly changes over the window, so the roll gyro's bias and scale
    # factor move its reading the same way: the fit names the pair
    assert any("bp-sp" in w and "nearly confounded" in w for w in res.warnings)
    assert res.info["parameter_names"][-2 * len(OUTPUT_CHANNELS):] == tuple(truth)
    assert res.info["options"]["imu_errors"] == "bias+scale"


def test_biased_imu_without_the_option_is_refused(clean_suite):
    """A known-wrong input: the same raw readings taken as unbiased fail the fit check."""
    _, flight = clean_suite
    res = OutputErrorEstimator().fit(flight, rng=0)
    assert not res.success
    assert "does not fit the data" in res.message
    assert "imu_errors" not in res.info
    # and the coefficients it returns are off by far more than the noise-free fit's 5e-8
    truth = reference_scenario().coefficient_vector
    assert np.max(np.abs(res.theta / truth - 1.0)) > 0.01


def test_summary_and_json_carry_the_imu_errors(clean_fit):
    text = clean_fit.summary()
    assert "bax1" in text and "sr" in text
    info = clean_fit.to_json_dict()["info"]
    assert set(info["imu_errors"]) == set(info["imu_error_stderr"])
    assert info["imu_errors"]["bq"] == pytest.approx(clean_fit.info["imu_errors"]["bq"])


@pytest.mark.parametrize("options", [{"imu_errors": "bias"},
                                     {"imu_errors": "bias+scale", "estimate_delay": True}])
def test_jacobian_with_imu_errors_equals_finite_differences(options):
    noise = GaussianNoise(accel_sd_mps2=0.5, rate_sd_radps=0.02, position_sd_m=0.0)
    flight = simulate_scenario(reference_scenario(), noise, rng=4)
    est = OutputErrorEstimator(**options, compile_model=False)
    prob = est.problem(flight)
    rng = np.random.default_rng(2)
    p = np.ones(prob.model.scale.size)
    n_c = aeroid.model.N_COEFFICIENTS
    p[:n_c] += 0.05 * rng.standard_normal(n_c)
    p[n_c:] = 0.5 * rng.standard_normal(p.size - n_c)
    _, J = prob.residuals_jacobian(p)
    assert J.shape[-1] == len(est.parameter_names(prob.model.position_free))
    for i in range(p.size):
        h = 1e-6
        dp = np.zeros_like(p)
        dp[i] = h
        fd = -(prob.residuals(p + dp) - prob.residuals(p - dp)).T / (2 * h)
        np.testing.assert_allclose(J[:, :, i], fd, rtol=0, atol=FD_RTOL * np.abs(fd).max())


def test_default_adds_no_parameters():
    est = OutputErrorEstimator()
    assert est.imu_errors == "none"
    names = est.parameter_names()
    assert names[:aeroid.model.N_COEFFICIENTS] == aeroid.NAMES
    assert not any(n.startswith(("b", "s")) for n in names)
    assert len(names) == aeroid.model.N_COEFFICIENTS + len(est.x0_free())
    assert len(STATE_NAMES) > max(est.x0_free())


def test_imu_errors_option_is_checked_and_listed(capsys):
    with pytest.raises(ValueError, match="imu_errors must be one of none, bias, bias"):
        OutputErrorEstimator(imu_errors="scale")
    with pytest.raises(EstimatorError):
        aeroid.make_estimator("output-error", {"imu_errors": "biases"})
    from aeroid.cli import main

    assert main(["methods", "--options", "output-error"]) == 0
    out = capsys.readouterr().out
    assert "imu_errors" in out and "bias+scale" in out


def test_initial_velocity_prior_from_the_flight(clean_suite):
    _, flight = clean_suite
    with pytest.raises(ValueError, match="needs estimate_initial_velocity = true"):
        OutputErrorEstimator(initial_velocity_prior="flight")
    est = OutputErrorEstimator(imu_errors="bias", estimate_initial_velocity=True,
                               initial_velocity_prior="flight", compile_model=False)
    with pytest.raises(aeroid.FlightError, match="needs metadata initial_state_sd") as info:
        est.problem(flight)  # a flight without the sd is refused, in one line
    assert "\n" not in str(info.value)
    sd = {"u": 0.04, "v": 0.1, "w": 0.16}
    given = dataclasses.replace(flight, metadata={**flight.metadata, "initial_state_sd": sd})
    prob = est.problem(given)
    n_c = aeroid.model.N_COEFFICIENTS
    names = est.parameter_names(prob.model.position_free)
    # the prior's information on each velocity offset [m/s] is 1 / sd^2, nothing else
    for j, name in enumerate(names):
        expected = 1.0 / sd[name[0]] ** 2 if name in ("u0", "v0", "w0") else 0.0
        weight = prob.prior_weight[j] / prob.model.scale[j] ** 2
        assert weight == pytest.approx(expected, rel=1e-12), name
    assert names[n_c:n_c + 3] == ("u0", "v0", "w0")


def test_a_reconstructed_velocity_taken_as_exact_is_a_warning(clean_suite):
    """A flight that states the sd of its initial velocity (a reconstruction's), fitted
    with the velocity held: the fit says what that costs and what to do."""
    _, flight = clean_suite
    sd = {"u": 0.04, "v": 0.1, "w": 0.16}
    given = dataclasses.replace(flight, metadata={**flight.metadata, "initial_state_sd": sd})
    held = OutputErrorEstimator(imu_errors="bias+scale").fit(given, rng=0)
    assert any("initial_velocity_prior = flight" in w for w in held.warnings)
    # a free initial speed trades against every coefficient (V^2): on noise-free data
    # Gauss-Newton creeps, 82 iterations measured (9 on the noisy suite flights). The fit
    # from the prior is the one asserted (the best end): the equation-error start, which
    # ran to its 200-iteration limit unconverged and was discarded (9 s of CPU measured on
    # a quiet machine, 25 s under load 12), is left out; the prior's fit is the same
    # numbers either way
    fitted = OutputErrorEstimator(imu_errors="bias+scale", estimate_initial_velocity=True,
                                  initial_velocity_prior="flight", equation_error_start=False,
                                  max_iterations=200).fit(given, rng=0)
    assert fitted.n_iterations < 200  # converged from the prior, not stopped at the limit
    assert fitted.success, fitted.message
    assert not any("initial_velocity_prior" in w for w in fitted.warnings)
    # noise-free, the flight's velocity is the truth: measured 1.2e-7 relative
    np.testing.assert_allclose(fitted.theta, reference_scenario().coefficient_vector,
                               rtol=RECOVERY_RTOL)


# The EKF with the IMU's errors as states (baselines.ekf, imu_errors) ---------------------
def test_sensor_error_states_jacobians_equal_finite_differences(clean_suite):
    from baselines import _common, _kalman

    _, flight = clean_suite
    base = _common.augmented_model(flight, 1)
    m = base.dim_z
    model = _kalman.with_sensor_errors(base, 2 * m)
    rng = np.random.default_rng(5)
    z = np.concatenate([flight.states()[200], aeroid.nominal(),
                        0.05 * rng.standard_normal(m), 0.005 * rng.standard_normal(m)])
    y, H = model.observe(z, 200)
    z_next, F = model.transition(z, 200)
    y0, _ = base.observe(z[:base.dim_x], 200)
    np.testing.assert_allclose(y, (1 + z[-m:]) * y0 + z[-2 * m:-m], rtol=1e-14)  # the law
    np.testing.assert_array_equal(z_next[base.dim_x:], z[base.dim_x:])  # constant
    H_fd, F_fd = np.empty_like(H), np.empty_like(F)
    for j in range(z.size):
        step = 1e-6 * max(abs(z[j]), 1e-2)
        zp, zm = z.copy(), z.copy()
        zp[j] += step
        zm[j] -= step
        H_fd[:, j] = (model.observe(zp, 200)[0] - model.observe(zm, 200)[0]) / (2 * step)
        F_fd[:, j] = (model.transition(zp, 200)[0] - model.transition(zm, 200)[0]) / (2 * step)
    np.testing.assert_allclose(H, H_fd, rtol=FD_RTOL, atol=FD_RTOL * np.abs(H).max())
    np.testing.assert_allclose(F, F_fd, rtol=FD_RTOL, atol=FD_RTOL * np.abs(F).max())
    # the UKF's batched versions: the same numbers for many states at once
    Z = np.stack([z, z * (1 + 1e-3 * rng.standard_normal(z.size))])
    for i in range(len(Z)):
        np.testing.assert_allclose(model.observe_batch(Z, 200)[i], model.observe(Z[i], 200)[0],
                                   rtol=1e-10)
        np.testing.assert_allclose(model.transition_batch(Z, 200)[i],
                                   model.transition(Z[i], 200)[0], rtol=1e-10)
    with pytest.raises(ValueError, match="sensor errors: 5 for 9"):
        _kalman.with_sensor_errors(base, 5)


@pytest.mark.parametrize("method", ["ekf", "ukf"])
def test_filter_recovers_imu_errors_on_noise_free_suite(clean_suite, method):
    sim, flight = clean_suite
    res = aeroid.make_estimator(method, {"imu_errors": "bias+scale"}).fit(flight, rng=0)
    assert res.success, res.message
    truth = reference_scenario().coefficient_vector
    np.testing.assert_allclose(res.theta, truth, rtol=EKF_RTOL)
    assert np.all(np.abs(res.theta - truth) < 3 * res.stderr)
    errors = truth_errors(sim)
    z = {n: (v - errors[n]) / res.info["imu_error_stderr"][n]
         for n, v in res.info["imu_errors"].items()}
    assert list(z) == list(errors)
    assert max(abs(v) for v in z.values()) < 3.0, z
    assert any("nearly confounded" in w and "b" in w for w in res.warnings)


@pytest.mark.parametrize("imu_errors", ["none", "bias"])
def test_ekf_refuses_the_suite_without_its_scale_factors(clean_suite, imu_errors):
    """Known-wrong inputs: the raw IMU taken as unbiased, or its scale factors left out
    (measured: az1 residual 7.8e3x its noise level, q 241x)."""
    from baselines.ekf import ExtendedKalmanEstimator

    _, flight = clean_suite
    res = ExtendedKalmanEstimator(imu_errors=imu_errors).fit(flight, rng=0)
    assert not res.success
    assert "does not fit the data" in res.message


def test_nuisance_findings_name_the_pairs_with_a_nuisance_parameter():
    from aeroid.estimation import nuisance_findings

    names = ("Cx", "Cza", "bax1")
    theta = np.array([-1.0, -11.8, 0.1])
    sd = np.array([0.01, 0.1, 0.05])
    corr = np.array([[1.0, 0.99, -0.995], [0.99, 1.0, 0.5], [-0.995, 0.5, 1.0]])
    found = nuisance_findings(names, theta, corr * np.outer(sd, sd), ("bax1",))
    # Cx-bax1 named with its correlation; Cx-Cza (no nuisance in it) left to the fit check
    assert len(found) == 1 and "Cx-bax1 (-0.99500)" in found[0] and "Cza" not in found[0]
    corr[0, 2] = corr[2, 0] = -0.9
    assert nuisance_findings(names, theta, corr * np.outer(sd, sd), ("bax1",)) == ()
    cov = corr * np.outer(sd, sd)
    cov[2, 2] = np.inf
    assert "no information on bax1" in nuisance_findings(names, theta, cov, ("bax1",))[0]
