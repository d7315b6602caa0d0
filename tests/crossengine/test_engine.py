"""The JSBSim airframe against aeroid's equations: units, signs, timing, the flight's files.

JSBSim is an independent implementation of the rigid-body motion; the aircraft file
(``rolling_airframe.xml``) writes aeroid's aerodynamic model in JSBSim's function
language and JSBSim's units and axes. These tests compare what the engine computes with
aeroid's own functions (:func:`aeroid.model.aero_forces_moments`,
:func:`aeroid.model.state_derivative`, :func:`aeroid.model.accelerometers`) at the
logged states, and the engine's trajectory with aeroid's equations integrated by RK4.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

import aeroid
from aeroid.model import (
    G0,
    accelerometers,
    aero_forces_moments,
    constants,
    rk4_step,
    state_derivative,
)

from ._aircraft import EARTH_MEAN_RADIUS_M, FT, JSBSIM_SLUGTOLB, LBF, SLUG, FlightConfig
from .jsbsim_flight import make_flight, write_flight

jsbsim = pytest.importorskip("jsbsim", reason="the cross-engine tests need JSBSim "
                                                  "(the dev or crossengine extra)")

#: Two evaluations of the same algebra (JSBSim's functions in lbf and ft, aeroid's numpy
#: in N and m) with exact unit factors: rounding only (measured: 5e-15).
SAME_ALGEBRA_RTOL = 1e-12
#: JSBSim's state derivative against aeroid's: the forces agree to rounding, but JSBSim
#: forms the translational acceleration in its inertial frame and rotates it back to the
#: body (Ti2b, Tec2b), so the body accelerations carry ~1e-12 of the rotation terms
#: p w ~ 1000 m/s^2 (measured: 1.5e-9 m/s^2 absolute, 1e-12 of each channel's range).
DERIVATIVE_RTOL = 1e-10
#: aeroid's equations integrated by RK4 (0.25 ms steps, split at the switches, density
#: and gravity interpolated from the samples) against JSBSim's Adams-Bashforth 3 at
#: 16 kHz, relative to each state's RMS: the median sample agrees to ~2e-6 (measured);
#: a sample within two frames after a switch carries the multistep method's start-up
#: transient, up to J dt with J the jump of the derivative (measured 2.5e-3).
TRAJECTORY_MEDIAN_RTOL = 2e-5
TRAJECTORY_MAX_RTOL = 1e-2


def test_the_engine_uses_the_configured_mass_properties_exactly(climb):
    flight, truth = climb
    config = truth.config
    data = truth.data
    for column, value in (("mass", config.mass_kg), ("ix", config.ix_kgm2),
                          ("iy", config.iy_kgm2), ("iz", config.iz_kgm2)):
        assert data[column].to_numpy() == pytest.approx(value, rel=SAME_ALGEBRA_RTOL)
    # S from the axial force: F_X = qbar S Cx
    area = data["FAX"] / (data["qbar"] * config.coefficients["Cx"])
    assert area.to_numpy() == pytest.approx(config.area_m2, rel=SAME_ALGEBRA_RTOL)
    # thrust: an external force of constant magnitude along body +x
    assert data["FTX"].to_numpy() == pytest.approx(config.thrust_n, rel=SAME_ALGEBRA_RTOL)
    assert np.all(data[["FTY", "FTZ"]].to_numpy() == 0.0)


def test_unit_factors_are_exact():
    foot, pound_force, slug = FT, LBF, SLUG
    assert foot == 0.3048
    assert pound_force == pytest.approx(0.45359237 * G0, rel=1e-15)  # 1 lbf = 1 lb x g0
    assert slug == pytest.approx(LBF / FT, rel=1e-15)
    jsbsim_g0_ftps2 = JSBSIM_SLUGTOLB  # JSBSim's rounded g0 in ft/s^2
    assert jsbsim_g0_ftps2 == pytest.approx(G0 / FT, rel=2e-8)


def test_forces_and_moments_equal_aeroid_equations(climb):
    """Every sign, axis and unit of the aircraft file, at 501 logged states."""
    flight, truth = climb
    const = constants(truth.airframe)._replace(rho=truth.data["rho"].to_numpy())
    fm = aero_forces_moments(flight.states(), flight["delta"], truth.coefficients, const)
    engine = truth.data[["FAX", "FAY", "FAZ", "MX", "MY", "MZ"]].to_numpy()
    scale = np.max(np.abs(engine), axis=0)
    assert np.all(scale > 0)
    np.testing.assert_array_less(np.max(np.abs(fm - engine), axis=0) / scale,
                                 SAME_ALGEBRA_RTOL)


def test_alpha_and_beta_follow_aeroid_definitions(climb):
    _, truth = climb
    data = truth.data
    np.testing.assert_allclose(data["alpha_jsbsim"], np.arctan2(data["w"], data["u"]),
                               rtol=0, atol=1e-15)
    speed = np.sqrt(data["u"] ** 2 + data["v"] ** 2 + data["w"] ** 2)
    np.testing.assert_allclose(data["beta_jsbsim"], np.arcsin(data["v"] / speed), rtol=0,
                               atol=1e-15)


def test_state_derivative_equals_aeroid_equations(climb):
    """u, v, w, p, q, r rates of the engine = eqs. 2-7 with the engine's density and gravity."""
    flight, truth = climb
    data = truth.data
    const = constants(truth.airframe)._replace(rho=data["rho"].to_numpy(),
                                               gravity=data["gravity"].to_numpy())
    xdot = state_derivative(flight.states(), flight["delta"], truth.coefficients, const)
    engine = data[["udot", "vdot", "wdot", "pdot", "qdot", "rdot"]].to_numpy()
    scale = np.max(np.abs(engine), axis=0)
    np.testing.assert_array_less(np.max(np.abs(xdot[:, :6] - engine), axis=0) / scale,
                                 DERIVATIVE_RTOL)


def test_accelerometers_equal_eq_28_at_the_logged_states(climb):
    flight, truth = climb
    const = constants(truth.airframe)._replace(rho=truth.data["rho"].to_numpy())
    expected = accelerometers(flight.states(), flight["delta"], truth.coefficients, const,
                              truth.airframe.accel_positions)
    scale = np.max(np.abs(flight.accelerations()), axis=0)
    np.testing.assert_array_less(
        np.max(np.abs(expected - flight.accelerations()), axis=0) / scale, SAME_ALGEBRA_RTOL)


def test_jsbsim_pilot_acceleration_lags_one_frame():
    """Why the triads are computed from forces: a-pilot is the previous frame's F/m."""
    config = FlightConfig(name="xe_frames", sample_rate_hz=16000.0, frame_rate_hz=16000.0,
                          window_s=(0.3, 0.34))
    _, truth = make_flight(config)
    data = truth.data
    specific = (data[["FAX", "FAY", "FAZ"]].to_numpy()
                + data[["FTX", "FTY", "FTZ"]].to_numpy()) / config.mass_kg
    pilot = data[["a_pilot_x", "a_pilot_y", "a_pilot_z"]].to_numpy()  # eyepoint at the c.g.
    corrected = data["relay_corrected"].to_numpy()
    keep = ~(corrected[1:] | corrected[:-1])  # frames whose forces were not moved
    np.testing.assert_allclose(pilot[1:][keep], specific[:-1][keep], rtol=1e-12, atol=1e-9)
    assert np.max(np.abs(pilot[1:] - specific[1:])) > 1.0  # not the same frame's


def _reference_states(flight, truth, substeps: int = 8) -> np.ndarray:
    """aeroid's equations by RK4 from the first logged state, split at the switches."""
    t = flight.t
    rho, grav = truth.data["rho"].to_numpy(), truth.data["gravity"].to_numpy()
    base = constants(truth.airframe)

    def rhs(time, x, delta):
        const = base._replace(rho=float(np.interp(time, t, rho)),
                              gravity=float(np.interp(time, t, grav)))
        return state_derivative(x, delta, truth.coefficients, const)

    x = flight.states()[0]
    out = [x]
    switches = truth.switch_times
    for k in range(len(t) - 1):
        grid = np.linspace(t[k], t[k + 1], substeps + 1)
        inside = switches[(switches > t[k]) & (switches < t[k + 1])]
        bounds = np.unique(np.concatenate([grid, inside]))
        for a, b in zip(bounds[:-1], bounds[1:], strict=True):
            x = rk4_step(rhs, a, x, b - a, float(truth.delta_at(np.array([a]))[0]))
        out.append(x)
    return np.array(out)


def test_trajectory_equals_aeroid_equations_with_the_true_switch_instants(climb):
    """The engine's motion is aeroid's model with its inputs resolved in time."""
    flight, truth = climb
    states = flight.states()
    error = np.abs(_reference_states(flight, truth) - states)[:, :6]
    rms = np.sqrt(np.mean(states[:, :6] ** 2, axis=0))
    relative = error / rms
    assert np.median(relative.max(axis=1)) < TRAJECTORY_MEDIAN_RTOL
    assert relative.max() < TRAJECTORY_MAX_RTOL


def test_logged_delta_is_the_relay_at_the_log_instant(climb):
    flight, truth = climb
    np.testing.assert_array_equal(flight["delta"], truth.delta_at(flight.t))
    assert set(np.unique(np.abs(flight["delta"]))) == {math.radians(truth.config.delta_max_deg)}


def test_switches_are_at_the_continuous_relay_zeros(climb):
    """Each switch lies where the fin law's switching function, on the logged roll angle
    (cubic interpolation between samples), changes sign: the relay is continuous, not
    latched at the log clock."""
    flight, truth = climb
    from scipy.interpolate import CubicSpline

    relay = aeroid.model.RelayActuator(
        delta_max_rad=math.radians(truth.config.delta_max_deg),
        command_amplitude=truth.config.command_amplitude,
        command_phase_rad=math.radians(truth.config.command_phase_deg))
    phi = CubicSpline(flight.t, flight["phi"])
    times = truth.switch_times[(truth.switch_times > flight.t[0])
                               & (truth.switch_times < flight.t[-1])]
    assert len(times) > 20
    rate = truth.config.sample_rate_hz
    offsets = np.abs(times - np.round(times * rate) / rate)
    assert np.median(offsets) > 2e-4  # switches fall between samples, not on them
    before = relay.switching_function(phi(times - 2e-6))
    after = relay.switching_function(phi(times + 2e-6))
    assert np.all(np.sign(before) != np.sign(after))


def test_actuator_delay_shifts_the_switches_by_exactly_the_delay(climb, climb_delayed):
    """The delayed flight's switches are its own relay zeros plus the delay (JSBSim's
    ``<delay>`` of N frames delays by N - 1: the generator writes N + 1)."""
    from scipy.interpolate import CubicSpline

    flight, truth = climb_delayed
    config = truth.config
    relay = aeroid.model.RelayActuator(
        delta_max_rad=math.radians(config.delta_max_deg),
        command_amplitude=config.command_amplitude,
        command_phase_rad=math.radians(config.command_phase_deg))
    phi = CubicSpline(flight.t, flight["phi"])
    times = truth.switch_times[(truth.switch_times > flight.t[0] + config.fin_delay_s)
                               & (truth.switch_times < flight.t[-1])]
    zeros = times - config.fin_delay_s
    before = relay.switching_function(phi(zeros - 2e-6))
    after = relay.switching_function(phi(zeros + 2e-6))
    assert np.all(np.sign(before) != np.sign(after))


def test_density_changes_and_the_airframe_holds_its_window_mean(climb):
    flight, truth = climb
    rho = truth.data["rho"].to_numpy()
    assert rho[0] / rho[-1] - 1.0 > 0.02  # a climb: a few percent over the window
    assert np.all(np.diff(truth.data["altitude"]) > 0)
    assert flight.airframe.density_kgm3 == pytest.approx(np.mean(rho), rel=1e-9)


@pytest.mark.parametrize("planet", ["flat", "sphere"])
def test_initial_condition_and_gravity_of_the_planet_definitions(planet):
    config = FlightConfig(name=f"xe_{planet}", planet=planet, window_s=(0.0, 0.2))
    _, truth = make_flight(config)
    first = truth.data.iloc[0]  # t = 0: the initial condition as JSBSim holds it
    expected = {"u": config.speed_mps, "v": 0.0, "w": 0.0, "p": config.p_radps, "q": 0.0,
                "r": 0.0, "phi": 0.0, "theta": math.radians(config.theta_deg), "psi": 0.0,
                "altitude": config.altitude_m}
    for name, value in expected.items():
        # the altitude is r - R with r ~ 3e9 ft on the flat planet: ulp 5e-7 ft
        atol = 1e-6 if name == "altitude" else 1e-9
        assert first[name] == pytest.approx(value, rel=1e-12, abs=atol), name
    radius = 1.0e9 if planet == "flat" else EARTH_MEAN_RADIUS_M
    height = truth.data["altitude"].to_numpy()
    expected = G0 * (radius / (radius + height)) ** 2
    np.testing.assert_allclose(truth.data["gravity"], expected, rtol=1e-9)
    np.testing.assert_array_equal(truth.data["p"], truth.data["p_ecef"])  # no rotation


def test_flights_are_deterministic_and_noise_comes_from_the_generator(climb, climb_noisy):
    again, _ = make_flight(FlightConfig())
    assert again.data.equals(climb[0].data)
    noisy, _ = make_flight(FlightConfig(), noise=aeroid.GaussianNoise(), rng=1)
    assert noisy.data.equals(climb_noisy[0].data)
    diff = climb_noisy[0].accelerations() - climb[0].accelerations()
    assert np.std(diff) == pytest.approx(aeroid.GaussianNoise().accel_sd_mps2, rel=0.05)
    np.testing.assert_array_equal(climb_noisy[0]["u"], climb[0]["u"])  # states clean


def test_config_rejects_what_jsbsim_cannot_do():
    with pytest.raises(ValueError, match="integer multiple"):
        FlightConfig(frame_rate_hz=1234.0)
    with pytest.raises(ValueError, match="whole number of frames"):
        FlightConfig(fin_delay_s=1e-5)
    with pytest.raises(ValueError, match="planet"):
        FlightConfig(planet="mars")


def test_written_flight_is_read_by_aeroid_estimate(climb, tmp_path, capsys):
    """CSV + airframe TOML: ``aeroid estimate FILE --airframe A.toml`` reads the flight."""
    from aeroid.cli import main

    flight, truth = climb
    csv, toml = write_flight(flight, tmp_path)
    back = aeroid.read_flight(csv, airframe=aeroid.load_airframe(toml))
    np.testing.assert_array_equal(back.states(), flight.states())
    assert back.airframe == flight.airframe
    # one density for a climbing flight: equation-error's regression misses F_AX by tens
    # of times the (noise-free: 1e-4 of the signal) noise level, and the fit check says so
    # (exit 1, the estimates still printed)
    assert main(["estimate", str(csv), "--airframe", str(toml), "--method", "equation-error",
                 "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert "does not fit the data" in out["message"] and out["coefficients"]["Cx"] < 0


def test_the_window_is_what_was_asked(climb):
    flight, truth = climb
    assert flight.n_samples == 501
    assert flight.t[0] == pytest.approx(truth.config.window_s[0])
    assert flight.validate() is flight
    assert dataclasses.asdict(truth.config)["frame_rate_hz"] == 16000.0
