"""A board-mounted log through the reconstruction: mounting, positions, saturated samples."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aeroid.flights import (
    SensorSuite,
    axis_map,
    mounted_group,
    reference_scenario,
    simulate_suite,
    wrap_angle,
)
from aeroid.reconstruction import reconstruct

#: The board's long axis along the sensor's -y.
BOARD = "x=-y, y=x, z=z"
#: Its mounting with two signs flipped: a proper rotation (180 deg about z), but wrong.
WRONG = "x=y, y=-x, z=z"
#: Gyro range below the reference flight's peak roll rate (53 rad/s): ~300 samples clip.
GYRO_RANGE = 52.0


@pytest.fixture(scope="module")
def scenario():
    return reference_scenario()


def _board(scenario, seed=11, **changes):
    return simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                          SensorSuite(imu_mounting=BOARD, **changes), rng=seed)


def _consistent(rec):
    return {name: check["consistent"] for name, check in rec.nis.items()}


def test_right_mounting_consistent_wrong_mounting_refused(scenario):
    sim = _board(scenario)
    rec = reconstruct(sim.log)
    assert all(_consistent(rec).values()), rec.nis
    assert any("mounted: axes x=-y, y=x, z=z" in note for note in rec.notes)
    # the same readings under a proper but wrong mounting: the residual check fails
    imu = sim.log["imu"]
    sd = {c: imu.noise_sd["ay1" if c[0] == "a" else "q"] for c in imu.sensor_channels}
    wrong = mounted_group("imu", imu.t, imu.sensor_channels, sd, 0.0, "wrong imu",
                          axis_map(WRONG), {})
    bad = reconstruct(dataclasses.replace(sim.log, groups={**sim.log.groups, "imu": wrong}))
    assert not bad.nis["ins"]["consistent"] and not bad.nis["gnss"]["consistent"], bad.nis
    assert bad.nis["ins"]["mean_nis_per_dof"] > 100.0


def test_saturated_gyro_samples(scenario):
    sim = _board(scenario, gyro_range_radps=GYRO_RANGE)
    n_clipped = int(np.sum(np.abs(sim.log["imu"].sensor_channels["q"]) >= GYRO_RANGE))
    assert n_clipped > 100
    rec = reconstruct(sim.log)
    assert all(_consistent(rec).values()), rec.nis
    z = (np.abs(wrap_angle(rec.table["phi"].to_numpy() - sim.truth["phi"]))
         / rec.table["sd_phi"].to_numpy())
    assert z.max() < 3.0
    flight = rec.to_flight()
    assert len(flight.metadata["saturated"]["p"]) == n_clipped
    assert set(flight.metadata["saturated"]) == {"p"}
    assert any("saturated IMU samples (p " in note for note in flight.metadata["notes"])


def test_mounting_positions_reach_the_airframe(scenario):
    sim = _board(scenario)
    imu = sim.log["imu"]
    positions = scenario.airframe.accel_positions + [[0.01, 0.0, 0.0], [0.01, 0.0, 0.0]]
    mounting = dataclasses.replace(imu.mounting, positions_m=positions)
    moved = mounted_group("imu", imu.t, imu.sensor_channels, {
        c: imu.noise_sd["ay1" if c[0] == "a" else "q"] for c in imu.sensor_channels},
        0.0, "moved imu", mounting, {})
    rec = reconstruct(dataclasses.replace(sim.log, groups={**sim.log.groups, "imu": moved}))
    np.testing.assert_array_equal(rec.airframe.accel_positions, positions)
    np.testing.assert_array_equal(rec.to_flight().airframe.accel_positions, positions)
    assert any("replace the airframe's" in note for note in rec.notes)


def test_filter_leaves_saturated_samples_out(scenario):
    """The EKF on a raw-IMU flight with ~300 clipped roll samples: masked, a success with
    every coefficient within 3 standard errors; the clipped values taken as readings, the
    fit check refuses (measured: p residual 179x its noise, Clp 25 se off)."""
    from baselines.ekf import ExtendedKalmanEstimator

    sim = _board(scenario, gyro_range_radps=GYRO_RANGE)
    flight = reconstruct(sim.log).to_flight(imu="raw")
    est = ExtendedKalmanEstimator(imu_errors="bias+scale")
    res = est.fit(flight, rng=0)
    assert res.success, res.message
    z = (res.theta - scenario.coefficient_vector) / res.stderr
    assert np.max(np.abs(z)) < 3.0, z
    n_clipped = len(flight.metadata["saturated"]["p"])
    assert res.info["saturated_left_out"] == {"p": n_clipped}
    assert f"saturated samples left out of the likelihood: p {n_clipped}" in res.summary()
    unmarked = dataclasses.replace(flight, metadata={
        k: v for k, v in flight.metadata.items() if k != "saturated"})
    bad = est.fit(unmarked, rng=0)
    assert not bad.success and "p residual" in bad.message, bad.message


def test_ukf_leaves_saturated_samples_out(scenario):
    """The UKF through the same mask (its sigma points' rows): measured z within 1.4."""
    from baselines.ukf import UnscentedKalmanEstimator

    sim = _board(scenario, gyro_range_radps=GYRO_RANGE)
    flight = reconstruct(sim.log).to_flight(imu="raw")
    res = UnscentedKalmanEstimator(imu_errors="bias+scale").fit(flight, rng=0)
    assert res.success, res.message
    z = (res.theta - scenario.coefficient_vector) / res.stderr
    assert np.max(np.abs(z)) < 3.0, z
    assert res.info["saturated_left_out"] == {"p": len(flight.metadata["saturated"]["p"])}
