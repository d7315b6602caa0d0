"""The sensor-suite simulator and the multi-rate log files (aeroid.flights._suite*)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from aeroid.errors import AirframeError, FlightError
from aeroid.flights import (
    GROUPS,
    NoNoise,
    SensorSuite,
    body_to_ned,
    log_trajectory,
    read_suite_log,
    reference_scenario,
    simulate,
    simulate_suite,
    wrap_angle,
    write_suite_log,
)
from aeroid.model import STATE_NAMES, accelerometers, constants

#: A noise-free, error-free suite: its IMU must equal the simulator's own record.
IDEAL = SensorSuite(accel_bias_mps2=(0.0, 0.0), gyro_bias_radps=(0.0, 0.0),
                    scale_factor=(0.0, 0.0), accel_noise_mps2=0.0, gyro_noise_radps=0.0,
                    gnss_velocity_sd_mps=0.0, gnss_position_sd_m=0.0, baro_altitude_sd_m=0.0,
                    ins_attitude_sd_rad=0.0)


@pytest.fixture(scope="module")
def scenario():
    return reference_scenario()


@pytest.fixture(scope="module")
def suite_sim(scenario):
    return simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                          rng=np.random.default_rng(5))


def test_groups_at_their_rates(suite_sim):
    log = suite_sim.log
    expected = {"imu": 1001, "gnss": 11, "baro": 51, "ins": 101, "fin": 1001}
    assert {name: len(g.t) for name, g in log.groups.items()} == expected
    channels = {**GROUPS, "baro": SensorSuite().baro_channels}  # altitude by default
    for name, group in log.groups.items():
        assert set(group.channels) == set(channels[name])
        assert np.all(np.diff(group.t) > 0)
    ins = log["ins"].channels
    for angle in ("phi", "psi"):  # wrapped to (-pi, pi]
        assert ins[angle].min() > -math.pi and ins[angle].max() <= math.pi
    truth = suite_sim.truth
    assert truth["phi"][-1] - truth["phi"][0] > 40.0  # the roll goes round many times
    # unwrapping the INS roll gives the truth within 6 sd of its noise (0.003 rad)
    phi = truth["phi"][::10]
    assert np.max(np.abs(wrap_angle(ins["phi"] - phi))) < 6 * 0.003


def test_errors_drawn_in_their_ranges(suite_sim):
    e = suite_sim.errors
    suite = SensorSuite()
    assert e["accel_bias"].shape == (2, 3) and e["gyro_bias"].shape == (3,)
    for key, (low, high) in (("accel_bias", suite.accel_bias_mps2),
                             ("gyro_bias", suite.gyro_bias_radps),
                             ("accel_scale", suite.scale_factor),
                             ("gyro_scale", suite.scale_factor)):
        assert np.all((np.abs(e[key]) >= low) & (np.abs(e[key]) <= high)), key


def test_same_seed_same_log(scenario):
    a, b = (simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                           rng=7) for _ in range(2))
    for name in a.log.groups:
        for c, v in a.log[name].channels.items():
            np.testing.assert_array_equal(v, b.log[name].channels[c])


def test_ideal_imu_equals_the_500_hz_record(scenario):
    """Sampled at 1000 Hz with the relay at its own 500 Hz clock, the flight is the same."""
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         IDEAL, rng=0)
    flight = simulate(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                      NoNoise())
    imu = sim.log["imu"]
    np.testing.assert_allclose(imu.t[::2], flight.t, atol=1e-12)
    for c in GROUPS["imu"]:
        # RK4 at the same 0.25 ms step on two code paths: agreement to 1e-6 of the signal
        scale = np.abs(flight[c]).max()
        np.testing.assert_allclose(imu.channels[c][::2], flight[c], atol=1e-6 * scale, rtol=0)
    np.testing.assert_allclose(sim.log["fin"].channels["delta"][::2], flight["delta"])


def test_ned_kinematics_against_second_library(suite_sim):
    """C_nb equals scipy's 3-2-1 rotation; the position's derivative is the NED velocity."""
    tr = suite_sim.truth
    k = np.arange(0, 1001, 97)
    ours = body_to_ned(tr["phi"][k], tr["theta"][k], tr["psi"][k])
    theirs = Rotation.from_euler("ZYX", np.column_stack(
        [tr["psi"][k], tr["theta"][k], tr["phi"][k]])).as_matrix()
    np.testing.assert_allclose(ours, theirs, atol=1e-12)
    for axis, (pos, vel) in enumerate((("pn", "vn"), ("pe", "ve"), ("pd", "vd"))):
        slope = np.gradient(tr[pos], tr["t"])
        # central differences of a trapezoid integral: error ~ dt^2 |v''| (~1e-3 m/s here)
        np.testing.assert_allclose(slope[1:-1], tr[vel][1:-1], atol=5e-3, err_msg=str(axis))
    assert np.allclose(tr["altitude"], 10000.0 - tr["pd"])


def test_rates_must_divide_the_imu_rate():
    with pytest.raises(AirframeError, match="gnss_rate_hz = 7 must divide"):
        SensorSuite(gnss_rate_hz=7.0)


def test_round_trip_with_offset(tmp_path, suite_sim):
    log = suite_sim.log
    # numpy floats, as a computed sd or offset is: written as TOML numbers, not np.float64(...)
    shifted = dataclasses.replace(log["gnss"], offset_s=np.float64(0.0123), noise_sd={
        c: np.float64(sd) for c, sd in log["gnss"].noise_sd.items()})
    log = dataclasses.replace(log, groups={**log.groups, "gnss": shifted})
    files = write_suite_log(log, tmp_path / "suite.toml")
    assert len(files) == 2 + len(log.groups)
    back = read_suite_log(tmp_path / "suite.toml")
    assert back.airframe == log.airframe
    for name, group in log.groups.items():
        np.testing.assert_array_equal(back[name].t, group.t)  # 17 digits: lossless
        for c, v in group.channels.items():
            np.testing.assert_array_equal(back[name].channels[c], v)
        assert back[name].noise_sd == group.noise_sd
    assert back["gnss"].offset_s == 0.0123
    logged = pd.read_csv(tmp_path / "suite-gnss.csv")["t"].to_numpy()
    np.testing.assert_allclose(logged + 0.0123, log["gnss"].t, atol=1e-12)
    np.testing.assert_allclose(back.metadata["truth"]["gyro_bias"], suite_sim.errors["gyro_bias"])


def _write_log(folder, extra_group="", time="[\"time_ms\", \"ms\"]", unit="deg/s",
               rows="0,1.0\n1,2.0\n2,3.0\n", file="ins.csv"):
    (folder / "ins.csv").write_text("time_ms,roll_rate\n" + rows)
    text = (f"[groups.imu]\nfile = \"{file}\"\ntime = {time}\n"
            f"[groups.imu.columns]\np = [\"roll_rate\", \"{unit}\"]\n" + extra_group)
    (folder / "log.toml").write_text(text)
    return folder / "log.toml"


def test_units_converted(tmp_path):
    log = read_suite_log(_write_log(tmp_path))
    np.testing.assert_allclose(log["imu"].t, [0.0, 0.001, 0.002])
    np.testing.assert_allclose(log["imu"].channels["p"], np.radians([1.0, 2.0, 3.0]))


@pytest.mark.parametrize(("kwargs", "needles"), [
    ({"file": "absent.csv"}, ["absent.csv", "does not exist"]),
    ({"time": "[\"clock\", \"s\"]"}, ["ins.csv", "'clock'"]),
    ({"rows": "0,1\n2,2\n1,3\n"},
     ["ins.csv", "'time_ms'", "not strictly increasing at line 4 of the file"]),
    ({"rows": "0,1\n1,x\n2,3\n"}, ["ins.csv", "'roll_rate'", "not a finite number at line 3"]),
    ({"unit": "furlongs"}, ["ins.csv", "'roll_rate'", "unknown unit 'furlongs'"]),
    ({"unit": "m/s"}, ["ins.csv", "'roll_rate'", "not a unit of rad/s"]),
    ({"time": "[\"time_ms\", \"deg\"]"}, ["ins.csv", "'time_ms'", "not a unit of s"]),
    ({"extra_group": "[groups.lidar]\nfile = \"ins.csv\"\n"},
     ["log.toml", "unknown group 'lidar'"]),
])
def test_reader_errors_are_one_line(tmp_path, kwargs, needles):
    with pytest.raises(FlightError) as info:
        read_suite_log(_write_log(tmp_path, **kwargs))
    message = str(info.value)
    assert "\n" not in message
    for needle in needles:
        assert needle in message, (needle, message)


def test_reader_refuses_unknown_channel(tmp_path):
    path = _write_log(tmp_path)
    path.write_text(path.read_text().replace("p = ", "airspeed = "))
    with pytest.raises(FlightError, match="unknown channel 'airspeed' for group 'imu'"):
        read_suite_log(path)


def _trajectory(n=20, rate=1000.0):
    t = np.arange(n) / rate
    states = np.zeros((n, len(STATE_NAMES)))
    states[:, 0] = 500.0
    return t, states, np.zeros(n), np.zeros((n, 2, 3))


def test_log_trajectory_matches_simulate_suite(scenario, suite_sim):
    """The sensor layer alone, given simulate_suite's truth, draws the same log."""
    truth = suite_sim.truth
    states = np.column_stack([truth[c] for c in STATE_NAMES])
    specific = accelerometers(states, truth["delta"], scenario.coefficient_vector,
                              constants(scenario.airframe),
                              scenario.airframe.accel_positions).reshape(-1, 2, 3)
    position = np.column_stack([truth[c] for c in ("pn", "pe", "pd")])
    again = log_trajectory(truth["t"], states, truth["delta"], specific, scenario.airframe,
                           rng=np.random.default_rng(5), position=position)
    for name, group in suite_sim.log.groups.items():
        for channel, values in group.channels.items():
            np.testing.assert_array_equal(again.log[name].channels[channel], values)


@pytest.mark.parametrize(("change", "needle"), [
    ({"delta": np.zeros(19)}, "delta has shape (19,), expected (20,)"),
    ({"t": np.arange(20) / 500.0}, "uniform at the IMU's 1000 Hz"),
    ({"atmosphere": {"pressure": np.ones(20)}}, "atmosphere must give pressure and temperature"),
    ({"atmosphere": {"pressure": np.ones(20), "temperature": np.ones(3)}},
     "temperature has shape (3,)"),
])
def test_log_trajectory_refuses_bad_input(scenario, change, needle):
    t, states, delta, specific = _trajectory()
    args = {"t": t, "states": states, "delta": delta, "specific_force": specific,
            "airframe": scenario.airframe, **change}
    with pytest.raises(AirframeError) as info:
        log_trajectory(**args, rng=1)
    assert needle in str(info.value) and "\n" not in str(info.value)
