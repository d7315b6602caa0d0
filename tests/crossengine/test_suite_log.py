"""A JSBSim flight logged through aeroid's sensor suite, and the reconstruction on it (issue 22).

The JSBSim flight ``climb`` sampled at 1000 Hz (the IMU's rate) is the truth; aeroid's
sensor layer (:func:`aeroid.flights.log_trajectory`, the same one the simulator's
:func:`~aeroid.flights.simulate_suite` uses) draws the default suite's IMU biases and scale
factors, GNSS at 10 Hz, barometer at 50 Hz and a wrapped INS at 100 Hz over it. The
accelerometers' truth is the engine's (eq. 28 from JSBSim's forces and rates), so nothing
of aeroid's model enters the log: the reconstruction's u v w and attitude are compared
with JSBSim's own states.

Measured (``python -m tests.crossengine.suite_measure 1 20``, 1.0-1.4 s CPU per
reconstruction of the 1 s window): over sensor seeds 1-20 every sample of u v w phi theta
psi lies within 3 sd of JSBSim's truth (20/20 pass ``WITHIN_3SD``; mean NIS per dof of
GNSS, baro and INS 0.80-1.32, all consistent); with the INS 2 ms late and undeclared,
0 % of the roll samples lie within 3 sd (20/20 refused).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aeroid.flights import ACCEL_CHANNELS, SensorSuite, log_trajectory, wrap_angle
from aeroid.model import (
    STATE_NAMES,
    density,
    isa_pressure,
    isa_temperature,
    pressure_altitude,
)
from aeroid.reconstruction import reconstruct

from .jsbsim_flight import FlightConfig, make_flight

jsbsim = pytest.importorskip("jsbsim", reason="the cross-engine tests need JSBSim "
                                                  "(the dev or crossengine extra)")

#: The IMU's rate of the default suite [Hz]; the JSBSim flight is sampled at it.
IMU_RATE_HZ = SensorSuite().imu_rate_hz
#: Fraction of samples whose error must lie within 3 sd: the unit test's criterion
#: (tests/unit/test_reconstruction.py: a Gaussian gives 99.7 %; the smoothed errors are
#: correlated in time, so a run of samples may leave together).
WITHIN_3SD = 0.97
#: The flat-Earth position integrated from JSBSim's body velocity and attitude against
#: JSBSim's own altitude (flat planet) [m]: measured 1.1e-5 m over the 1 s window.
ALTITUDE_TOLERANCE_M = 1e-3
#: An INS 2 ms late that the log does not declare: at the 30 rad/s roll, 0.06 rad of roll.
INS_LATE_S = 0.002
#: JSBSim's standard atmosphere against aeroid's ISA at the same geopotential altitude
#: (measured on the window: pressure 4.5e-6, density 7.3e-6, temperature 9e-11 relative;
#: JSBSim states its constants in English units, e.g. R = 1716.56 ft lbf / (slug R)).
ISA_RTOL = 1e-5
ISA_TEMPERATURE_RTOL = 1e-9
#: The U.S. Standard Atmosphere's Earth radius for the geopotential altitude [m].
EARTH_RADIUS_M = 6356766.0
#: The density p / (R T) from one temperature sample against JSBSim's: within this many
#: of the temperature's relative sd (measured on seeds 1-3: 3.7, 2.1 and 2.1).
DENSITY_TEMPERATURE_SD = 5.0
SEED = 1
COMPARED = ("u", "v", "w", "phi", "theta", "psi")


def jsbsim_suite_log(seed, suite=None):
    """Return (SuiteSimulation, JSBSim truth table) of the 1000 Hz JSBSim climb."""
    config = dataclasses.replace(FlightConfig(), name="xe_suite", sample_rate_hz=IMU_RATE_HZ)
    _, truth = make_flight(config)
    data = truth.data
    # the barometer's origin: JSBSim's altitude at the window's first sample; a barometer
    # logging pressure and temperature reads JSBSim's own atmosphere
    airframe = truth.airframe.replace(altitude_m=float(data["altitude"].iloc[0]))
    sim = log_trajectory(data["t"].to_numpy(), data[list(STATE_NAMES)].to_numpy(),
                         data["delta"].to_numpy(),
                         data[list(ACCEL_CHANNELS)].to_numpy().reshape(-1, 2, 3), airframe,
                         suite or SensorSuite(), rng=seed, source="jsbsim suite log",
                         atmosphere={c: data[c].to_numpy() for c in ("pressure", "temperature")},
                         metadata={"wind": "still"})  # JSBSim's climb in still air, declared
    return sim, data


def within_3sd(rec, data):
    """Return {state: fraction of samples within 3 sd of JSBSim's truth}."""
    out = {}
    for name in COMPARED:
        error = rec.table[name].to_numpy() - data[name].to_numpy()
        if name in ("phi", "psi"):
            error = wrap_angle(error)
        out[name] = float(np.mean(np.abs(error) < 3.0 * rec.table[f"sd_{name}"].to_numpy()))
    return out


@pytest.fixture(scope="module")
def jsbsim_suite():
    sim, data = jsbsim_suite_log(SEED)
    return sim, data, reconstruct(sim.log)


def test_log_is_the_suites(jsbsim_suite):
    sim, data, _ = jsbsim_suite
    log = sim.log
    suite = SensorSuite()
    assert len(log["imu"].t) == len(data)
    for name in ("gnss", "baro", "ins"):
        assert log[name].rate_hz == pytest.approx(getattr(suite, f"{name}_rate_hz"))
    # the INS roll is wrapped while JSBSim's (unwrapped) roll passes several turns
    assert np.ptp(data["phi"]) > 4 * np.pi
    assert np.all(np.abs(log["ins"].channels["phi"]) <= np.pi)
    # the drawn errors are in the log's IMU: gyro = (1 + s) p + b + noise
    e = sim.errors
    gyro_p = log["imu"].channels["p"] - (1 + e["gyro_scale"][0]) * data["p"].to_numpy()
    assert abs(gyro_p.mean() - e["gyro_bias"][0]) < 4 * suite.gyro_noise_radps / np.sqrt(
        len(gyro_p))
    # the flat-Earth position from JSBSim's velocity and attitude is JSBSim's altitude
    altitude_error = sim.truth["altitude"] - data["altitude"].to_numpy()
    assert np.max(np.abs(altitude_error)) < ALTITUDE_TOLERANCE_M


def test_reconstruction_within_3_sd_of_jsbsim(jsbsim_suite):
    _, data, rec = jsbsim_suite
    fractions = within_3sd(rec, data)
    assert min(fractions.values()) >= WITHIN_3SD, fractions
    for source in ("gnss", "baro", "ins"):
        assert rec.nis[source]["consistent"], (source, rec.nis[source])
    # informative sd: attitude below the INS's 3 mrad, velocity below the GNSS's 0.1 m/s x 5
    assert rec.table[["sd_phi", "sd_theta", "sd_psi"]].to_numpy().max() < 0.003
    assert rec.table[["sd_u", "sd_v", "sd_w"]].to_numpy().max() < 0.5


def test_an_undeclared_ins_delay_fails_the_comparison(jsbsim_suite):
    """A known-wrong log: the INS 2 ms late without its offset. Its innovations may look
    consistent (it is the roll's only reference); the comparison with JSBSim does not."""
    sim, data, _ = jsbsim_suite
    ins = sim.log["ins"]
    late = dataclasses.replace(ins, t=ins.t - INS_LATE_S)  # stamped 2 ms early: read late
    log = dataclasses.replace(sim.log, groups={**sim.log.groups, "ins": late})
    fractions = within_3sd(reconstruct(log), data)
    assert fractions["phi"] < 0.5, fractions


def test_isa_equals_jsbsims_atmosphere(jsbsim_suite):
    """A second library: JSBSim's pressure, temperature and density along the climb."""
    _, data, _ = jsbsim_suite
    h = data["altitude"].to_numpy()  # geometric
    geopotential = EARTH_RADIUS_M * h / (EARTH_RADIUS_M + h)
    np.testing.assert_allclose(isa_pressure(geopotential), data["pressure"], rtol=ISA_RTOL)
    np.testing.assert_allclose(density(geopotential), data["rho"], rtol=ISA_RTOL)
    np.testing.assert_allclose(isa_temperature(geopotential), data["temperature"],
                               rtol=ISA_TEMPERATURE_RTOL)
    # the geometric altitude would be off by about 1 m: 1.4e-4 in density
    assert np.max(np.abs(density(h) / data["rho"] - 1.0)) > 10 * ISA_RTOL


def test_reconstruction_from_jsbsims_pressure_and_temperature():
    """The barometer logs JSBSim's own pressure and temperature (not aeroid's ISA)."""
    suite = SensorSuite(baro_channels=("pressure", "temperature"))
    sim, data = jsbsim_suite_log(SEED, suite)
    assert set(sim.log["baro"].channels) == {"pressure", "temperature"}
    rec = reconstruct(sim.log)
    assert min(within_3sd(rec, data).values()) >= WITHIN_3SD
    assert rec.nis["baro"]["consistent"], rec.nis["baro"]
    # the pressure altitude of JSBSim's pressure, within 3 sd
    altitude = pressure_altitude(data["pressure"].to_numpy())
    z = (rec.table["altitude"].to_numpy() - altitude) / rec.table["sd_altitude"].to_numpy()
    assert np.mean(np.abs(z) < 3.0) >= WITHIN_3SD
    # rho = p / (R T) against JSBSim's density
    rel = rec.table["rho"].to_numpy() / data["rho"].to_numpy() - 1.0
    bound = DENSITY_TEMPERATURE_SD * suite.baro_temperature_sd_k / data["temperature"].min()
    assert np.max(np.abs(rel)) < bound + ISA_RTOL
