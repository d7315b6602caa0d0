"""Air data as measured outputs of output-error, and the airspeed channel (issue 26).

References: the probe's readings are computed here from the simulator's true states, its
wind and the rigid-body velocity at the probe (``v + omega x r``, written out below in
numpy), then noised; output-error's exact sensitivities are compared with central
differences of its own outputs; the wind, calibration and coefficients against the
simulator's truth within 3 of their own standard errors; known-wrong inputs (a probe off
the roll axis with no offset estimated, an airspeed in knots) must be refused.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import aeroid
from aeroid.errors import EstimatorError, FlightError
from aeroid.flights import NoNoise, Wind, make_noise, simulate
from aeroid.model import as_state, constants, equations
from baselines._oe_airdata_fit import AirDataProblem
from baselines.equation_error import EquationErrorEstimator
from baselines.output_error import OutputErrorEstimator

#: The issue's steady wind: 3 m/s along the northward path, 4 across [m/s, NED].
WIND = (3.0, 4.0, 0.0)
#: A vane's noise [rad] and a pitot's [m/s].
VANE_SD = np.radians(0.1)
AIRSPEED_SD = 0.5
#: A miscalibrated vane: factor and offset [rad] on alpha and beta.
FACTOR = (0.02, 0.02)
OFFSET = (0.002, -0.001)
#: Within this many of its own standard errors (the issue's criterion).
N_SE = 3.0
#: Relative step and agreement of the central differences of the air-data outputs: the
#: sensitivities are exact (AD), the difference's truncation error is ~h^2 of a smooth
#: record and its rounding ~1e-16 / h: 1e-5 steps leave ~1e-7 of the column's scale.
FD_STEP = 1e-5
FD_RTOL = 1e-5
#: Noise-free windy flight, equation-error with the logged angles and airspeed: only
#: the model's rounding and the smoothing's end effects remain (the truth to 0.1 %;
#: without the airspeed, 3 m/s along the path biased every coefficient by ~1.2 %).
EE_RTOL = 1e-3


def with_probe(flight, wind, *, position=(0.0, 0.0, 0.0), vane_sd=VANE_SD,
               airspeed_sd=AIRSPEED_SD, factor=(0.0, 0.0), offset=(0.0, 0.0), rng=0):
    """``flight`` with a probe's alpha, beta and airspeed at ``position`` [m] in ``wind``."""
    gen = np.random.default_rng(rng)
    x = as_state(flight.states())  # the simulator logs the true states (Gaussian IMU noise)
    const = constants(flight.airframe)._replace(wind_n=wind[0], wind_e=wind[1],
                                                wind_d=wind[2])
    ua, va, wa = equations.air_velocity(x, const)
    rx, ry, rz = position
    ua, va, wa = (ua + x.q * rz - x.r * ry, va + x.r * rx - x.p * rz,
                  wa + x.p * ry - x.q * rx)
    speed = np.sqrt(ua * ua + va * va + wa * wa)
    alpha, beta = np.arctan2(wa, ua), np.arcsin(va / speed)
    n = flight.n_samples
    data = flight.data.assign(
        alpha=(1 + factor[0]) * alpha + offset[0] + vane_sd * gen.standard_normal(n),
        beta=(1 + factor[1]) * beta + offset[1] + vane_sd * gen.standard_normal(n),
        airspeed=speed + airspeed_sd * gen.standard_normal(n))
    return dataclasses.replace(flight, data=data)


def windy(reference_scenario, noise, seed):
    s = reference_scenario
    m = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND))
    return simulate(s.airframe, s.coefficient_vector, m, noise, rng=seed)


@pytest.fixture(scope="module")
def windy_probe_flight(reference_scenario):
    f = windy(reference_scenario, make_noise("gaussian"), 1)
    return with_probe(f, WIND, factor=FACTOR, offset=OFFSET, rng=[1, 26])


@pytest.fixture(scope="module")
def clean_windy(reference_scenario):
    return windy(reference_scenario, NoNoise(), 0)


def test_air_data_sensitivities_equal_central_differences(windy_probe_flight,
                                                          reference_scenario) -> None:
    f = dataclasses.replace(windy_probe_flight, metadata={
        **windy_probe_flight.metadata, "air_data_probe": {"position_m": [0.8, 0.05, -0.03]}})
    est = OutputErrorEstimator(estimate_wind=True, air_data="measured")
    prob = est.problem(f)
    assert isinstance(prob, AirDataProblem)
    model = prob.model
    p = np.zeros(model.scale.size)
    n_c = len(aeroid.NAMES)
    p[:n_c] = 1.1 * reference_scenario.coefficient_vector / model.scale[:n_c]
    p[model.n_base:] = [1.5, -2.0, 1.0, -0.5]  # a factor of 1.5 %, an offset of 1 mrad ...
    wind = model.base.n_graph - 3
    p[wind:wind + 3] = [2.0, -3.0, 0.5]
    y, J = model.outputs_jacobian(p)
    m = len(aeroid.model.OUTPUT_CHANNELS)
    air = slice(m, m + len(model.channels))
    for i in range(p.size):
        h = FD_STEP * max(1.0, abs(p[i]))
        up, down = p.copy(), p.copy()
        up[i] += h
        down[i] -= h
        fd = (model.outputs(up) - model.outputs(down))[:, air] / (2 * h)
        scale = np.max(np.abs(J[air, :, :]), axis=(1, 2))  # per channel
        np.testing.assert_array_less(np.max(np.abs(J[air, :, i].T - fd), axis=0),
                                     FD_RTOL * scale, err_msg=f"parameter {i}")
    assert np.allclose(y[:, :m], model.base.outputs(p[:model.n_base]), rtol=0, atol=0)


def test_windy_flight_wind_calibration_and_coefficients_within_3_se(windy_probe_flight,
                                                                    reference_scenario) -> None:
    r = OutputErrorEstimator(estimate_wind=True, air_data="measured").fit(windy_probe_flight)
    assert r.success, r.message
    truth = reference_scenario.coefficient_vector
    assert np.all(np.abs(r.theta - truth) <= N_SE * r.stderr)
    wind, sd = np.array(r.info["wind_ned_mps"]), np.array(r.info["wind_stderr_mps"])
    assert np.all(np.abs(wind - WIND) <= N_SE * sd)
    assert np.all(sd < 0.05)  # the along-path wind is determined (5 m/s sd without air data)
    air = r.info["air_data"]
    assert air["channels"] == ("alpha", "beta", "airspeed")
    expected = {"alpha_factor": FACTOR[0], "beta_factor": FACTOR[1],
                "alpha_offset_rad": OFFSET[0], "beta_offset_rad": OFFSET[1]}
    for name, value in expected.items():
        assert abs(air["calibration"][name] - value) <= N_SE * air["calibration_stderr"][name]
    for name, value in (("alpha", VANE_SD), ("beta", VANE_SD), ("airspeed", AIRSPEED_SD)):
        assert abs(air["noise_sd"][name] - value) <= N_SE * air["noise_sd_stderr"][name]
    notice = [w for w in r.warnings if "air data as measured outputs" in w]
    assert len(notice) == 1 and "\n" not in notice[0] and "probe at the c.g." in notice[0]
    assert not any("ignores" in w for w in r.warnings)
    assert {"alpha", "beta", "airspeed"} <= set(r.info["fit_check"]["ratio"])


def test_a_probe_off_the_roll_axis_without_an_offset_is_flagged(reference_scenario) -> None:
    # 0.1 m off the roll axis at ~51 rad/s: 5 m/s of flow, 0.58 deg of alpha: without the
    # offset estimated (or the position given) the fit check must refuse the fit
    f = with_probe(windy(reference_scenario, make_noise("gaussian"), 2), WIND,
                   position=(0.0, 0.1, 0.0), rng=[2, 26])
    est = OutputErrorEstimator(estimate_wind=True, air_data="measured",
                               air_data_calibration="factor")
    wrong = est.fit(f)
    assert not wrong.success and "alpha" in wrong.message
    told = dataclasses.replace(f, metadata={**f.metadata,
                                            "air_data_probe": {"position_m": [0.0, 0.1, 0.0]}})
    right = est.fit(told)
    assert right.success, right.message
    assert "probe at [0, 0.1, 0] m (metadata)" in right.info["air_data"]["probe"]


def test_equation_error_takes_the_airspeed_channel(clean_windy, reference_scenario) -> None:
    truth = reference_scenario.coefficient_vector
    f = with_probe(clean_windy, WIND, vane_sd=0.0, airspeed_sd=0.0)
    r = EquationErrorEstimator(air_data="measured").fit(f)
    assert r.success, r.message
    assert np.max(np.abs(r.theta / truth - 1.0)) < EE_RTOL
    assert "airspeed from the logged airspeed channel" in r.info["air_data_note"]
    assert not any("airspeed taken as |u, v, w|" in w for w in r.warnings)
    without = dataclasses.replace(f, data=f.data.drop(columns="airspeed"))
    r0 = EquationErrorEstimator(air_data="measured").fit(without)
    assert np.max(np.abs(r0.theta / truth - 1.0)) > 5 * EE_RTOL  # the along-path bias


def test_equation_error_takes_the_probe_position(clean_windy, reference_scenario) -> None:
    # a probe 0.8 m ahead and off the axes reads omega x r too (~2.5 m/s of it at ~51
    # rad/s roll): given in the metadata, equation-error removes it (the wind the air data
    # imply is the simulator's, the truth to EE_RTOL); not given, the probe is taken at
    # the c.g. and said so, and its wind is the rotation's flow
    position = (0.8, 0.05, -0.03)
    truth = reference_scenario.coefficient_vector
    f = with_probe(clean_windy, WIND, position=position, vane_sd=0.0, airspeed_sd=0.0)
    told = dataclasses.replace(f, metadata={**f.metadata,
                                            "air_data_probe": {"position_m": list(position)}})
    implied = aeroid.estimation.air_data_wind(told)
    np.testing.assert_allclose(implied, np.broadcast_to(WIND, implied.shape), atol=1e-9)
    right = EquationErrorEstimator(air_data="measured").fit(told)
    assert right.success, right.message
    assert np.max(np.abs(right.theta / truth - 1.0)) < EE_RTOL
    assert "probe at [0.8, 0.05, -0.03] m (metadata)" in right.info["air_data_note"]
    untold = aeroid.estimation.air_data_wind(f)
    assert np.max(np.abs(untold - WIND)) > 1.0  # the rotation's flow taken for wind
    assert "probe at the c.g." in EquationErrorEstimator(air_data="measured").fit(
        f).info["air_data_note"]


def test_refusals_are_one_line(clean_windy, clean_flight) -> None:
    f = with_probe(clean_windy, WIND, vane_sd=0.0, airspeed_sd=0.0)
    cases = [
        (FlightError, lambda: OutputErrorEstimator(air_data="measured").fit(clean_flight)),
        (EstimatorError, lambda: OutputErrorEstimator(
            air_data="measured", estimate_delay=True).fit(f)),
        (FlightError, lambda: OutputErrorEstimator(air_data="measured").fit(
            dataclasses.replace(f, metadata={**f.metadata, "air_data_probe": [1, 2]}))),
        (ValueError, lambda: OutputErrorEstimator(air_data="vane")),
        (ValueError, lambda: OutputErrorEstimator(air_data_calibration="gain")),
    ]
    for kind, call in cases:
        with pytest.raises(kind) as exc:
            call()
        assert "\n" not in str(exc.value)
    ignored = OutputErrorEstimator(max_iterations=1, equation_error_start=False).fit(f)
    said = [w for w in ignored.warnings if "ignores" in w]
    assert len(said) == 1 and "airspeed" in said[0] and "\n" not in said[0]


def test_the_airspeed_channel_is_read_converted_and_checked(clean_windy, tmp_path) -> None:
    f = with_probe(clean_windy, WIND, vane_sd=0.0, airspeed_sd=0.0)
    assert f.check()[0] == []
    frame = f.data.drop(columns="airspeed").assign(
        tas_kn=f["airspeed"] / (1852.0 / 3600.0))  # a logger's airspeed in knots
    path = tmp_path / "log.csv"
    frame.to_csv(path, index=False, float_format="%.17g")
    airframe = tmp_path / "airframe.toml"
    aeroid.model.save_airframe(f.airframe, airframe)
    columns = tmp_path / "map.toml"
    columns.write_text('tas_kn = {channel = "airspeed", unit = "kn"}\n')
    read = aeroid.flights.read_flight(path, airframe=airframe, columns=columns)
    np.testing.assert_allclose(read["airspeed"], f["airspeed"], rtol=1e-12)
    # the same column mapped without its unit: refused, naming the unit
    columns.write_text('tas_kn = "airspeed"\n')
    with pytest.raises(FlightError, match=r"airspeed in knots\?"):
        aeroid.flights.read_flight(path, airframe=airframe, columns=columns).validate()
    negative = f.data.assign(airspeed=-f["airspeed"])
    with pytest.raises(FlightError, match="'airspeed' must be positive"):
        dataclasses.replace(f, data=negative).validate()


def _turbulent(reference_scenario, sd, seed):
    s = reference_scenario
    m = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND, turbulence_sd_mps=sd,
                                                   scale_length_m=533.4))
    return simulate(s.airframe, s.coefficient_vector, m, make_noise("gaussian"), rng=seed)


def test_the_verdict_tells_steady_wind_from_turbulence(reference_scenario) -> None:
    # the simulator logs the air-relative alpha, beta: a vane's readings with noise added
    def vane(f, seed):
        gen = np.random.default_rng([seed, 26])
        return dataclasses.replace(f, data=f.data.assign(
            alpha=f["alpha"] + VANE_SD * gen.standard_normal(f.n_samples),
            beta=f["beta"] + VANE_SD * gen.standard_normal(f.n_samples)))
    steady = EquationErrorEstimator().fit(vane(windy(reference_scenario,
                                                     make_noise("gaussian"), 3), 3))
    verdict = steady.info["air_data_verdict"]
    assert verdict["kind"] == "steady wind"
    assert verdict["gust_rms_mps"] < verdict["gust_limit_mps"]
    assert abs(verdict["steady_ned_mps"][1] - WIND[1]) < 0.5  # across the path: seen
    line = [w for w in steady.warnings if "against the inertial u, v, w" in w]
    assert len(line) == 1 and "along the path unseen" in line[0] and "\n" not in line[0]
    rough = vane(_turbulent(reference_scenario, 3.0, 3), 3)
    assert EquationErrorEstimator().fit(rough).info["air_data_verdict"]["kind"] == "turbulence"
    # output-error: what its steady wind and calibration leave of the vane's angles
    r = OutputErrorEstimator(estimate_wind=True, air_data="measured").fit(rough)
    assert r.info["air_data"]["channels"] == ("alpha", "beta")
    assert r.info["air_data_verdict"]["kind"] == "turbulence"
    assert not r.success  # a steady wind does not explain the gusts: the fit check says so


def test_still_air_with_a_probe_is_still_air(reference_scenario) -> None:
    s = reference_scenario
    f = simulate(s.airframe, s.coefficient_vector, s.manoeuvre, make_noise("gaussian"), rng=4)
    f = with_probe(f, (0.0, 0.0, 0.0), rng=[4, 26])
    r = OutputErrorEstimator(estimate_wind=True, air_data="measured").fit(f)
    assert r.success, r.message
    assert r.info["air_data_verdict"]["kind"] == "still air"
    wind, sd = np.array(r.info["wind_ned_mps"]), np.array(r.info["wind_stderr_mps"])
    assert np.all(np.abs(wind) <= N_SE * sd)
