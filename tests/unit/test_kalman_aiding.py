"""GNSS velocity as sparse measurements of the EKF and UKF (``aiding = "gnss-velocity"``),
and the INS attitude beside it (``"gnss-velocity+ins-attitude"``).

References: the aided measurement's Jacobian against central differences and its batch
form against the single one; a noise-free suite flight with noise-free GNSS recovered by
the EKF and the UKF; a GNSS log 0.2 s off (undeclared) against the fit check. With the
initial sd a reconstruction gives (:data:`START_SD`) a 50 ms skew is not refused: the
velocity and attitude states absorb it (benchmarks/bench_aiding.py --filters: 0 of 20).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from suite_flights import gnss_aiding, ins_aiding, suite_flight

from aeroid.errors import EstimatorError
from aeroid.estimation import make_estimator
from aeroid.flights import Windows, reference_scenario
from aeroid.model import N_STATE
from baselines._kalman import DiscreteModel
from baselines._kalman_aiding import with_aiding, with_ned_velocity
from baselines._oe_aiding import AidingSamples

#: Central-difference step of the state [m/s, rad] and the agreement of the exact
#: Jacobian with it (rounding of 500 m/s over 1e-6: ~1e-8; measured 4.2e-8).
FD_STEP = 1e-6
FD_ATOL = 1e-6
#: Noise-free suite flight and GNSS (stated sd 1e-3 m/s): the filters' coefficients
#: against the truth, relative (measured: EKF 9.1e-6, UKF 6.3e-6; without GNSS 8.9e-6 and
#: 6.4e-6; with the INS too (stated sd 1e-5 rad) 1.06e-5 and 1.04e-5).
FILTER_RTOL = 1e-4
#: An undeclared GNSS skew the fit check refuses (measured on seed 1: ve innovations 4.2x
#: their sd; 50 ms: 1.3x, accepted; the right times accepted, coefficients within 1.0 se).
REFUSED_SKEW_S = 0.2
#: The filter's initial sd of the velocity [m/s] and attitude [rad] as a reconstruction's
#: (README: 0.04-0.16 m/s, 0.2-0.6 mrad). The flight here carries the true states, whose
#: own noise level would start the filter nearly certain of them: it then refused a 50 ms
#: skew (vd 5.6x), which it cannot do from a reconstruction's start.
START_SD = {"initial_velocity_sd_mps": 0.17, "initial_angle_sd_rad": 5e-4}


def _toy(dim_x: int = N_STATE + 4) -> DiscreteModel:
    """A model whose measurement is two of its states (the aiding rows add to it)."""
    def observe(x, k):
        H = np.zeros((2, dim_x))
        H[0, 3], H[1, 10] = 1.0, 1.0
        return x[[3, 10]], H

    return DiscreteModel(dim_x, 2, lambda x, k: (x, np.eye(dim_x)), observe,
                         lambda X, k: X, lambda X, k: X[:, [3, 10]])


def test_aided_measurement_jacobian_and_batch():
    rng = np.random.default_rng(0)
    model = with_ned_velocity(_toy())
    assert model.dim_z == 5
    X = rng.normal(size=(4, model.dim_x))
    X[:, :3] += [500.0, 10.0, -20.0]
    for x in X:
        z, H = model.observe(x, 0)
        for i in range(model.dim_x):
            step = np.zeros_like(x)
            step[i] = FD_STEP
            fd = (model.observe(x + step, 0)[0] - model.observe(x - step, 0)[0]) / (2 * FD_STEP)
            np.testing.assert_allclose(H[:, i], fd, rtol=0, atol=FD_ATOL, err_msg=str(i))
    np.testing.assert_allclose(model.observe_batch(X, 0),
                               np.array([model.observe(x, 0)[0] for x in X]), rtol=1e-14)


def test_ins_rows_jacobian_batch_and_the_circle():
    eps = 1e-3
    ins = AidingSamples(np.array([0]), np.array([[np.pi - eps, 0.1, -np.pi + eps]]),
                        np.ones(3), "ins")
    gnss = AidingSamples(np.array([0]), np.zeros((1, 3)), np.ones(3), "gnss")
    model = with_aiding(_toy(), (gnss, ins))
    assert model.dim_z == 8
    x = np.zeros(model.dim_x)
    x[:3] = [500.0, 10.0, -20.0]
    x[6:9] = [-np.pi + eps + 8 * np.pi, 0.1 + eps, np.pi - eps]  # across the wrap, 4 turns on
    y, H = model.observe(x, 0)
    np.testing.assert_allclose(ins.z[0] - y[5:], [-2 * eps, -eps, 2 * eps], rtol=0, atol=1e-12)
    for i in range(model.dim_x):
        step = np.zeros_like(x)
        step[i] = FD_STEP
        fd = (model.observe(x + step, 0)[0] - model.observe(x - step, 0)[0]) / (2 * FD_STEP)
        np.testing.assert_allclose(H[:, i], fd, rtol=0, atol=FD_ATOL, err_msg=str(i))
    X = np.vstack([x, x + 1e-3])
    np.testing.assert_allclose(model.observe_batch(X, 0),
                               np.array([model.observe(v, 0)[0] for v in X]), rtol=1e-14)


@pytest.mark.parametrize("name", ["ekf", "ukf"])
def test_noise_free_suite_flight_with_gnss_and_ins_recovers_the_truth(name):
    sim, flight = suite_flight(seed=3, accel_noise_mps2=0.0, gyro_noise_radps=0.0,
                               gnss_velocity_sd_mps=0.0, ins_attitude_sd_rad=0.0)
    fit = make_estimator(name, {"imu_errors": "bias+scale",
                                "aiding": "gnss-velocity+ins-attitude"}).fit(
        ins_aiding(sim, gnss_aiding(sim, flight, sd=1e-3), sd=1e-5), rng=0)
    assert fit.success, fit.message
    np.testing.assert_allclose(fit.theta, reference_scenario().coefficient_vector,
                               rtol=FILTER_RTOL)
    assert fit.info["aiding"]["n_samples_per_source"] == {"gnss": 11, "ins": 101}
    assert {"ins_phi", "ins_theta", "ins_psi"} <= set(fit.info["fit_check"]["ratio"])


@pytest.mark.parametrize("name", ["ekf", "ukf"])
def test_noise_free_suite_flight_with_gnss_recovers_the_truth(name):
    sim, flight = suite_flight(seed=3, accel_noise_mps2=0.0, gyro_noise_radps=0.0,
                               gnss_velocity_sd_mps=0.0)
    fit = make_estimator(name, {"imu_errors": "bias+scale", "aiding": "gnss-velocity"}).fit(
        gnss_aiding(sim, flight, sd=1e-3), rng=0)
    assert fit.success, fit.message
    np.testing.assert_allclose(fit.theta, reference_scenario().coefficient_vector,
                               rtol=FILTER_RTOL)
    assert fit.info["aiding"]["n_samples"] == 11
    assert {"vn", "ve", "vd"} <= set(fit.info["fit_check"]["ratio"])


def test_ekf_refuses_gnss_200_ms_late_and_not_the_right_times():
    sim, flight = suite_flight(seed=1)
    est = make_estimator("ekf", {"imu_errors": "bias+scale", "aiding": "gnss-velocity",
                                 **START_SD})
    right = est.fit(gnss_aiding(sim, flight), rng=0)
    assert right.success, right.message
    truth = reference_scenario().coefficient_vector
    assert np.max(np.abs(right.theta - truth) / right.stderr) < 3.0
    skewed = est.fit(gnss_aiding(sim, flight, shift_s=-REFUSED_SKEW_S), rng=0)
    assert not skewed.success
    plain = make_estimator("ekf", {"imu_errors": "bias+scale"}).fit(gnss_aiding(sim, flight),
                                                                     rng=0)
    assert any("not in this fit's likelihood" in w for w in plain.warnings)
    with pytest.raises(EstimatorError, match="not available for several windows"):
        est.fit(Windows((flight, dataclasses.replace(flight)), ("a", "b")), rng=0)
