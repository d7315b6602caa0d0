"""Sensors as mounted: axis maps, angles, ranges, the board-mounted simulator (_mounting)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from aeroid.errors import AirframeError, FlightError
from aeroid.flights import (
    SensorSuite,
    axis_map,
    body_to_ned,
    euler_mounting,
    matrix_mounting,
    read_suite_log,
    reference_scenario,
    simulate_suite,
    used_samples,
    write_suite_log,
)

#: A noise-free, error-free suite: its IMU is the truth, in whatever axes it logs.
IDEAL = SensorSuite(accel_bias_mps2=(0.0, 0.0), gyro_bias_radps=(0.0, 0.0),
                    scale_factor=(0.0, 0.0), accel_noise_mps2=0.0, gyro_noise_radps=0.0)
IMU = ("ax1", "ay1", "az1", "ax2", "ay2", "az2", "p", "q", "r")
#: A board with its long axis along the sensor's -y (body x = sensor -y).
BOARD = "x=-y, y=x, z=z"


@pytest.fixture(scope="module")
def scenario():
    return reference_scenario()


def _sim(scenario, **changes):
    return simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                          dataclasses.replace(IDEAL, **changes), rng=4)


def test_axis_map_forms_agree_and_map_the_axes():
    c = axis_map(BOARD).rotation
    np.testing.assert_array_equal(c, axis_map({"x": "-y", "y": "x", "z": "z"}).rotation)
    # body x reads the sensor's -y: a sensor vector along +y is body -x
    np.testing.assert_array_equal(c @ [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0])
    # the same rotation as yaw +90 deg of the sensor from the body (scipy, a second library)
    np.testing.assert_allclose(c, Rotation.from_euler("z", 90, degrees=True).as_matrix(),
                               atol=1e-15)


def test_angles_are_3_2_1_as_the_attitude():
    angles = [20.0, -35.0, 110.0]  # roll, pitch, yaw [deg]
    c = euler_mounting(angles).rotation
    np.testing.assert_allclose(c, body_to_ned(*np.radians(angles)), atol=1e-15)
    np.testing.assert_allclose(
        c, Rotation.from_euler("ZYX", angles[::-1], degrees=True).as_matrix(), atol=1e-15)
    assert "3-2-1" in euler_mounting(angles).description


@pytest.mark.parametrize(("build", "text", "needle"), [
    (axis_map, "x=-x, y=y, z=z", "determinant -1"),  # one sign flipped: a mirror
    (axis_map, "x=-y, y=-x, z=z", "determinant -1"),
    (axis_map, "x=y, y=y, z=z", "used twice"),
    (axis_map, "x=y, z=z", "each body axis"),
    (axis_map, "x=-w, y=x, z=z", "body=sensor"),
    (matrix_mounting, [[1, 0, 0], [0, 1, 0.01], [0, 0, 1]], "not orthonormal"),
    (matrix_mounting, [[1, 0, 0], [0, 1, 0]], "3 rows"),
    (euler_mounting, [0, 90], "3 finite numbers"),
])
def test_improper_rotations_are_refused(build, text, needle):
    with pytest.raises(FlightError) as info:
        build(text, "log.toml: [groups.imu]")
    message = str(info.value)
    assert "\n" not in message and needle in message and "[groups.imu]" in message, message


@pytest.mark.parametrize("mounting", [{"imu_mounting": BOARD},
                                      {"imu_angles_deg": (15.0, -40.0, 120.0)}])
def test_board_mounted_log_read_back_is_the_body_log(tmp_path, scenario, mounting):
    body = _sim(scenario)
    board = _sim(scenario, **mounting)
    write_suite_log(board.log, tmp_path / "board.toml")
    back = read_suite_log(tmp_path / "board.toml")
    sensor = back["imu"].sensor_channels
    assert back["imu"].mounting is not None
    # the file holds the board's axes, not the body's
    assert not np.allclose(sensor["ax1"], body.log["imu"].channels["ax1"])
    for c in IMU:  # read with the right mounting: the body-axis log to rounding
        np.testing.assert_allclose(back["imu"].channels[c], body.log["imu"].channels[c],
                                   rtol=0.0, atol=1e-12 * np.abs(body.log["imu"].channels[c])
                                   .max())
    assert any("mounted" in note for note in back.metadata["notes"])
    if "imu_mounting" in mounting:  # an axis map moves values without arithmetic
        np.testing.assert_array_equal(back["imu"].channels["ax1"], -sensor["ay1"])
        np.testing.assert_array_equal(back["imu"].channels["p"], -sensor["q"])


def test_mounting_table_forms_and_refusals_in_a_file(tmp_path):
    (tmp_path / "imu.csv").write_text("t,gx,gy,gz\n0,1,2,3\n0.001,1,2,3\n")
    head = ("[groups.imu]\nfile = \"imu.csv\"\ntime = [\"t\", \"s\"]\n"
            "[groups.imu.columns]\np = [\"gx\", \"rad/s\"]\nq = [\"gy\", \"rad/s\"]\n"
            "r = [\"gz\", \"rad/s\"]\n")
    forms = {"axes = \"x=-y, y=x, z=z\"": [-2.0, 1.0, 3.0],
             "axes = { x = \"-y\", y = \"x\", z = \"z\" }": [-2.0, 1.0, 3.0],
             "angles_deg = [0.0, 0.0, 90.0]": [-2.0, 1.0, 3.0],
             "matrix = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]": [-2.0, 1.0, 3.0]}
    for line, want in forms.items():
        (tmp_path / "log.toml").write_text(head + "[groups.imu.mounting]\n" + line + "\n")
        got = read_suite_log(tmp_path / "log.toml")["imu"].channels
        np.testing.assert_allclose([got[c][0] for c in "pqr"], want, atol=1e-15, err_msg=line)
    bad = {"axes = \"x=y, y=x, z=z\"": "determinant -1",
           "axes = \"x=y, y=x, z=z\"\nangles_deg = [0, 0, 0]": "give the rotation once",
           "tilt = 3": "unknown key(s) tilt",
           "axes = \"x=x, y=y, z=z\"\naccel1_position_m = [0.5, 0, 0]": "both"}
    for line, needle in bad.items():
        (tmp_path / "log.toml").write_text(head + "[groups.imu.mounting]\n" + line + "\n")
        with pytest.raises(FlightError) as info:
            read_suite_log(tmp_path / "log.toml")
        message = str(info.value)
        assert "log.toml: [groups.imu]" in message and needle in message, message
        assert "\n" not in message


def test_a_sensor_axis_entering_no_body_axis_is_refused(tmp_path):
    (tmp_path / "imu.csv").write_text("t,gx\n0,1\n0.001,1\n")
    (tmp_path / "log.toml").write_text(
        "[groups.imu]\nfile = \"imu.csv\"\ntime = [\"t\", \"s\"]\n"
        "[groups.imu.columns]\np = [\"gx\", \"rad/s\"]\n"
        "[groups.imu.mounting]\nangles_deg = [0.0, 30.0, 0.0]\n")
    with pytest.raises(FlightError, match="enter no body axis"):
        read_suite_log(tmp_path / "log.toml")
    # an axis map sends the one logged axis to one body axis: used
    (tmp_path / "log.toml").write_text(
        "[groups.imu]\nfile = \"imu.csv\"\ntime = [\"t\", \"s\"]\n"
        "[groups.imu.columns]\nq = [\"gx\", \"rad/s\"]\n"
        "[groups.imu.mounting]\naxes = \"x=-y, y=x, z=z\"\n")
    np.testing.assert_array_equal(read_suite_log(tmp_path / "log.toml")["imu"].channels["p"],
                                  [-1.0, -1.0])


def test_suite_refuses_an_improper_board():
    with pytest.raises(AirframeError, match="determinant -1"):
        SensorSuite(imu_mounting="x=-x, y=y, z=z")
    with pytest.raises(AirframeError, match="not both"):
        SensorSuite(imu_mounting=BOARD, imu_angles_deg=(0.0, 0.0, 90.0))
    with pytest.raises(AirframeError, match="gyro_range_radps"):
        SensorSuite(gyro_range_radps=0.0)


def test_saturated_count_equals_the_clipped_samples(tmp_path, scenario):
    gyro_range, accel_range = 52.0, 20.0  # the reference roll peaks near 53 rad/s
    free = _sim(scenario, imu_mounting=BOARD)
    clipped = _sim(scenario, imu_mounting=BOARD, gyro_range_radps=gyro_range,
                   accel_range_mps2=accel_range)
    sensor = free.log["imu"].sensor_channels
    # independent count: the unclipped readings at or beyond the range, sensor axis by axis
    want = {c: int(np.sum(np.abs(sensor[c]) >= (gyro_range if c in "pqr" else accel_range)))
            for c in IMU}
    assert want["q"] > 0 and sum(want.values()) > want["q"]  # both ranges bite
    write_suite_log(clipped.log, tmp_path / "sat.toml")
    back = read_suite_log(tmp_path / "sat.toml")["imu"]
    assert back.ranges == {"accel_range": accel_range, "gyro_range": gyro_range}
    assert back.n_saturated == sum(want.values())
    # body p draws on the sensor's q only: its mask is q's
    assert int(back.saturated["p"].sum()) == want["q"]
    np.testing.assert_array_equal(np.abs(back.sensor_channels["q"]).max(), gyro_range)
    note = [n for n in read_suite_log(tmp_path / "sat.toml").metadata["notes"]
            if "gyro_range" in n]
    assert note and f"p {want['q']} sample(s) saturated" in note[0]


def test_used_samples_from_flight_metadata():
    mask = used_samples({"saturated": {"q": [1, 3]}}, ("p", "q", "r"), 5)
    assert mask is not None and mask.shape == (5, 3)
    np.testing.assert_array_equal(np.flatnonzero(~mask[:, 1]), [1, 3])
    assert mask[:, [0, 2]].all()
    assert used_samples({}, ("p",), 5) is None
    with pytest.raises(FlightError, match="not sample indices"):
        used_samples({"saturated": {"q": [7]}}, ("p", "q", "r"), 5)
    with pytest.raises(FlightError, match="not one of the channels"):
        used_samples({"saturated": {"vn": [1]}}, ("p", "q", "r"), 5)


def test_axial_accelerometer_alone_is_read_and_its_reconstruction_refused(tmp_path, scenario):
    """A cheap board's log: one accelerometer axis (the board's -y is the body's x)."""
    from aeroid.reconstruction import reconstruct

    board = _sim(scenario, imu_mounting=BOARD)
    write_suite_log(board.log, tmp_path / "full.toml")  # suite-like CSVs beside it
    (tmp_path / "axial.toml").write_text(
        "[log]\nairframe = \"full-airframe.toml\"\n"
        "[groups.imu]\nfile = \"full-imu.csv\"\ntime = [\"t\", \"s\"]\n"
        "[groups.imu.columns]\nay1 = [\"ay1\", \"m/s^2\"]\n"
        "[groups.imu.noise_sd]\nay1 = 0.05\n"
        "[groups.imu.mounting]\naxes = \"x=-y, y=x, z=z\"\n"
        "[groups.ins]\nfile = \"full-ins.csv\"\ntime = [\"t\", \"s\"]\n"
        "[groups.ins.columns]\nphi = [\"phi\", \"rad\"]\ntheta = [\"theta\", \"rad\"]\n"
        "psi = [\"psi\", \"rad\"]\n")
    log = read_suite_log(tmp_path / "axial.toml")
    assert sorted(log["imu"].channels) == ["ax1"]  # body x from the sensor's -y
    assert log["imu"].noise_sd == {"ax1": 0.05}
    np.testing.assert_array_equal(log["imu"].channels["ax1"], board.log["imu"].channels["ax1"])
    with pytest.raises(FlightError) as info:
        reconstruct(log)
    message = str(info.value)
    assert "\n" not in message and "without gyros" in message, message
