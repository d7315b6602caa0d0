"""The sensor-suite simulator in wind and its air group's probe (aeroid.flights._suite_air).

References: the single-file simulator (:func:`aeroid.flights.simulate`) of the same
scenario and seed, whose probe readings are written by the same noise model; the model's
air data evaluated from the suite's own truth and wind (the air-relative velocity plus
``omega x r`` composed by hand); NACA's pitot formulas through
:func:`aeroid.flights.probe_pressures` (tested in test_pitot.py).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aeroid.errors import AirframeError, FlightError
from aeroid.flights import (
    AirProbe,
    GaussianNoise,
    SensorSuite,
    Wind,
    body_to_ned,
    read_suite_log,
    reference_scenario,
    simulate,
    simulate_suite,
    write_suite_log,
)
from aeroid.model import equations

WIND = (3.0, 4.0, -0.5)
#: A noise sd far below rounding of the readings: the single-file simulator logs an
#: airspeed or the pressures only with a positive sd.
TINY = 1e-12
#: Relative agreement of the suite's truth with the single-file record: the same RK4 steps
#: (README: 1000 Hz suite and 500 Hz record, 3e-7 m/s) and float rounding.
IDENTITY_RTOL = 1e-9


@pytest.fixture(scope="module")
def scenario():
    s = reference_scenario()
    return dataclasses.replace(s, manoeuvre=dataclasses.replace(
        s.manoeuvre, wind=Wind(steady_ned_mps=WIND)))


def _suite(scenario, probe, seed=1, **options):
    return simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                          SensorSuite(air_probe=probe, **options), rng=seed)


@pytest.mark.parametrize("pitot", [False, True])
def test_probe_readings_equal_the_single_file_simulators(scenario, pitot) -> None:
    air = ({"total_pressure_sd_pa": TINY, "static_pressure_sd_pa": TINY} if pitot
           else {"airspeed_sd_mps": TINY})
    single = simulate(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                      GaussianNoise(accel_sd_mps2=0.0, rate_sd_radps=0.0, **air), rng=1)
    probe = AirProbe(rate_hz=500.0, alpha_sd_rad=0.0, beta_sd_rad=0.0,
                     **({"airspeed_sd_mps": 0.0, **air} if pitot else air))
    sim = _suite(scenario, probe)
    group = sim.log["air"]
    np.testing.assert_allclose(group.t, single["t"], rtol=0, atol=1e-12)
    channels = ("alpha", "beta", *(("total_pressure", "static_pressure") if pitot
                                   else ("airspeed",)))
    assert sorted(group.channels) == sorted(channels)
    for c in channels:
        np.testing.assert_allclose(group.channels[c], single[c], rtol=IDENTITY_RTOL,
                                   atol=1e-12, err_msg=c)
    # the probe is in the wind: its angles are not the inertial ones (0.3-0.6 deg here)
    assert np.max(np.abs(group.channels["alpha"] - np.arctan2(single["w"], single["u"]))) > 1e-3


def test_readings_are_the_air_relative_truth_at_the_probe_plus_noise(scenario) -> None:
    r = np.array([0.4, 0.03, -0.02])
    probe = AirProbe(position_m=tuple(r))
    sim = _suite(scenario, probe, seed=4)
    tr, group = sim.truth, sim.log["air"]
    k = np.arange(0, tr["t"].size, 10)
    np.testing.assert_array_equal(group.t, tr["t"][k])
    c_nb = body_to_ned(tr["phi"][k], tr["theta"][k], tr["psi"][k])
    v = np.column_stack([tr[c][k] for c in "uvw"]) - np.einsum("kji,j->ki", c_nb, WIND)
    v += np.cross(np.column_stack([tr[c][k] for c in "pqr"]), r)  # by hand
    speed, alpha, beta = equations.air_data(*v.T)
    true = {"alpha": alpha, "beta": beta, "airspeed": speed}
    for c, sd in (("alpha", probe.alpha_sd_rad), ("beta", probe.beta_sd_rad),
                  ("airspeed", probe.airspeed_sd_mps)):
        np.testing.assert_allclose(tr[{"alpha": "air_alpha", "beta": "air_beta"}.get(c, c)][k],
                                   true[c], rtol=1e-12, atol=1e-12)
        z = (group.channels[c] - true[c]) / sd
        # chi-square of 101 samples: 99.9 % interval of the mean square 0.62-1.49
        assert 0.62 < np.mean(z * z) < 1.49, (c, np.mean(z * z))
        assert group.noise_sd[c] == sd
    assert group.probe_position_m == tuple(r)
    # at 50 rad/s of roll, 3 cm across is 1.5 m/s: the position matters
    assert np.max(np.abs(np.cross(np.column_stack([tr[c][k] for c in "pqr"]), r))) > 1.0


def test_the_probe_draws_last_and_the_wind_moves_the_imu(scenario) -> None:
    with_probe = _suite(scenario, AirProbe(), seed=7)
    without = _suite(scenario, None, seed=7)
    for name, group in without.log.groups.items():
        for c, v in group.channels.items():
            np.testing.assert_array_equal(with_probe.log[name].channels[c], v)
    still = reference_scenario()
    calm = simulate_suite(still.airframe, still.coefficient_vector, still.manoeuvre,
                          SensorSuite(), rng=7)
    # the same draws, another flight: the wind's loads move the accelerometers
    gap = np.abs(calm.log["imu"].channels["az1"] - without.log["imu"].channels["az1"])
    assert np.max(gap) > 1.0
    assert "in wind N +3, E +4, D -0.5 m/s" in without.log.metadata["imu_sampling"]
    assert without.log.metadata["wind"]["east_mps"] == 4.0


def test_turbulence_draws_its_gusts_from_the_suites_generator(scenario) -> None:
    gusty = dataclasses.replace(scenario, manoeuvre=dataclasses.replace(
        scenario.manoeuvre, wind=Wind(steady_ned_mps=WIND, turbulence_sd_mps=3.0)))
    a, b = (_suite(gusty, AirProbe(), seed=s) for s in (2, 2))
    c = _suite(gusty, AirProbe(), seed=3)
    np.testing.assert_array_equal(a.log["air"].channels["alpha"], b.log["air"].channels["alpha"])
    gusts = np.column_stack([a.truth[f"wind_{x}"] for x in "ned"]) - np.array(WIND)
    assert 0.5 < np.std(gusts) < 6.0  # sd 3 m/s over 1 s of one path
    assert not np.allclose(a.truth["wind_n"], c.truth["wind_n"])
    assert "latched at the IMU's 1000 Hz" in a.log.metadata["imu_sampling"]


def test_air_probe_options_refused_in_one_line() -> None:
    for kwargs, needle in (({"rate_hz": 0.0}, "rate_hz must be positive"),
                           ({"position_m": (0.1, 0.2)}, "position_m must be [x, y, z]"),
                           ({"alpha_sd_rad": -1.0}, "alpha_sd_rad must be"),
                           ({"total_pressure_sd_pa": 50.0}, "two airspeeds")):
        with pytest.raises(AirframeError) as info:
            AirProbe(**kwargs)
        assert needle in str(info.value) and "\n" not in str(info.value), str(info.value)
    for rate in (300.0, 2000.0):
        with pytest.raises(AirframeError, match="air probe rate_hz = .* must divide"):
            SensorSuite(air_probe=AirProbe(rate_hz=rate))


def _air_log(folder, columns, rows, extra=""):
    (folder / "air.csv").write_text(rows)
    (folder / "imu.csv").write_text("t,p\n0,1\n0.001,2\n")
    (folder / "log.toml").write_text(
        "[groups.imu]\nfile = \"imu.csv\"\ntime = [\"t\", \"s\"]\n[groups.imu.columns]\n"
        "p = [\"p\", \"rad/s\"]\n[groups.air]\nfile = \"air.csv\"\ntime = [\"t\", \"s\"]\n"
        + extra + "[groups.air.columns]\n" + columns)
    return folder / "log.toml"


def test_the_air_groups_pressures_and_probe_position_are_read(tmp_path) -> None:
    path = _air_log(tmp_path, "total_pressure = [\"pt\", \"kPa\"]\n"
                    "static_pressure = [\"ps\", \"hPa\"]\n",
                    "t,pt,ps\n0,109.1,264.4\n0.01,109.2,264.3\n",
                    "probe_position_m = [0.5, 0.0, -0.01]\n")
    group = read_suite_log(path)["air"]
    np.testing.assert_allclose(group.channels["total_pressure"], [109100.0, 109200.0])
    np.testing.assert_allclose(group.channels["static_pressure"], [26440.0, 26430.0])
    assert group.probe_position_m == (0.5, 0.0, -0.01)


@pytest.mark.parametrize(("columns", "rows", "extra", "needle"), [
    ("static_pressure = [\"ps\", \"Pa\"]\n", "t,ps\n0,26000\n", "",
     "'static_pressure' without 'total_pressure'"),
    ("total_pressure = [\"pt\", \"Pa\"]\n", "t,pt\n0,26000\n", "", "Mach needs both"),
    ("total_pressure = [\"pt\", \"Pa\"]\nstatic_pressure = [\"ps\", \"Pa\"]\n",
     "t,pt,ps\n0,26000,27000\n", "", "must be above 'static_pressure'"),
    ("total_pressure = [\"pt\", \"Pa\"]\nstatic_pressure = [\"ps\", \"Pa\"]\n",
     "t,pt,ps\n0,109.1,26.4\n", "", "kPa read as Pa?"),
    ("total_pressure = [\"pt\", \"Pa\"]\nstatic_pressure = [\"ps\", \"Pa\"]\n"
     "airspeed = [\"v\", \"m/s\"]\n", "t,pt,ps,v\n0,109000,26400,500\n", "", "two airspeeds"),
    ("airspeed = [\"v\", \"m/s\"]\n", "t,v\n0,500\n", "probe_position_m = [0.5, 0.0]\n",
     "probe_position_m must be [x, y, z]"),
    ("airspeed = [\"v\", \"m/s\"]\n", "t,v\n0,500\n", "probe_position_m = \"nose\"\n",
     "probe_position_m must be [x, y, z]"),
    ("airspeed = [\"v\", \"psi\"]\n", "t,v\n0,500\n", "", "not a unit of m/s"),
])
def test_the_air_groups_bad_input_refused_in_one_line(tmp_path, columns, rows, extra,
                                                     needle) -> None:
    with pytest.raises(FlightError) as info:
        read_suite_log(_air_log(tmp_path, columns, rows, extra))
    assert needle in str(info.value) and "\n" not in str(info.value), str(info.value)
    assert "air.csv" in str(info.value) or "groups.air" in str(info.value)


def test_probe_position_only_in_the_air_group(tmp_path) -> None:
    path = _air_log(tmp_path, "airspeed = [\"v\", \"m/s\"]\n", "t,v\n0,500\n")
    path.write_text(path.read_text().replace(
        "[groups.imu.columns]", "probe_position_m = [0, 0, 0]\n[groups.imu.columns]"))
    with pytest.raises(FlightError, match="unknown key.*probe_position_m"):
        read_suite_log(path)


def test_a_simulated_air_group_is_written_and_read_back(scenario, tmp_path) -> None:
    probe = AirProbe(airspeed_sd_mps=0.0, total_pressure_sd_pa=50.0, static_pressure_sd_pa=50.0,
                     position_m=(0.45, 0.0, 0.01))
    sim = _suite(scenario, probe, seed=9, offsets_s=(("air", 0.002),))
    write_suite_log(sim.log, tmp_path / "suite.toml")
    back = read_suite_log(tmp_path / "suite.toml")["air"]
    group = sim.log["air"]
    np.testing.assert_allclose(back.t, group.t, rtol=1e-15)
    assert back.offset_s == 0.002 and back.probe_position_m == probe.position_m
    for c in ("alpha", "beta", "total_pressure", "static_pressure"):
        np.testing.assert_allclose(back.channels[c], group.channels[c], rtol=1e-15)
        assert back.noise_sd[c] == group.noise_sd[c]


def test_log_trajectory_probe_in_another_simulators_air() -> None:
    """A crosswind over a level, non-rolling path in a given atmosphere: closed forms."""
    from aeroid.flights import log_trajectory, pitot_ratio
    from aeroid.model import GAMMA, R_AIR, STATE_NAMES

    n, rate = 21, 1000.0
    t = np.arange(n) / rate
    states = np.zeros((n, len(STATE_NAMES)))
    states[:, STATE_NAMES.index("u")] = 500.0
    wind = np.tile([0.0, 5.0, 0.0], (n, 1))  # from the west: the air moves east
    atmosphere = {"pressure": np.full(n, 26_500.0), "temperature": np.full(n, 223.15)}
    probe = AirProbe(rate_hz=rate, alpha_sd_rad=0.0, beta_sd_rad=0.0, airspeed_sd_mps=0.0,
                     total_pressure_sd_pa=TINY, static_pressure_sd_pa=TINY)
    s = reference_scenario()
    sim = log_trajectory(t, states, np.zeros(n), np.zeros((n, 2, 3)), s.airframe,
                         SensorSuite(air_probe=probe, baro_rate_hz=0.0), rng=0,
                         atmosphere=atmosphere, wind=wind)
    air = sim.log["air"].channels
    speed = np.hypot(500.0, 5.0)
    np.testing.assert_allclose(air["beta"], np.arcsin(-5.0 / speed), rtol=1e-13)
    np.testing.assert_allclose(air["alpha"], 0.0, atol=1e-15)
    np.testing.assert_allclose(air["static_pressure"], 26_500.0, rtol=1e-13)
    mach = speed / np.sqrt(GAMMA * R_AIR * 223.15)
    np.testing.assert_allclose(air["total_pressure"], 26_500.0 * pitot_ratio(mach), rtol=1e-13)
    with pytest.raises(AirframeError, match="wind has shape"):
        log_trajectory(t, states, np.zeros(n), np.zeros((n, 2, 3)), s.airframe,
                       SensorSuite(air_probe=probe, baro_rate_hz=0.0), rng=0, wind=wind[1:])
