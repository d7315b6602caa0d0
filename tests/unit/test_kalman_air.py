"""Air data (alpha, beta, airspeed) as measured outputs of the EKF and UKF (issue 26).

References: the probe's readings computed here in numpy from the simulator's states and
wind (:func:`aeroid.model.equations.air_velocity`, ``air_data`` on numpy arrays, the
lever arm ``omega x r`` written out) against the filters' CasADi outputs; central
differences for the measurement Jacobian; the simulator's wind and a known
miscalibration for the fits.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import aeroid
from aeroid.flights import GaussianNoise, NoNoise, Wind, flight_record, simulate
from aeroid.model import N_COEFFICIENTS, N_STATE, as_state, constants, equations
from baselines import _augmented, _kalman_air, _kalman_gust, _kalman_wind

WIND = (3.0, 4.0, 0.0)
VANE_SD = float(np.radians(0.1))
AIRSPEED_SD = 0.5
#: The CasADi outputs against numpy's evaluation of the same equations: rounding only.
SAME_RTOL = 1e-10
#: Central differences of 1e-6 (states in m/s, rad/s, rad; calibration ~1e-2): the
#: outputs are smooth, truncation ~1e-12 relative; 1e-6 leaves rounding's 1e-16/1e-6.
FD_STEP = 1e-6
FD_ATOL = 1e-7
WITHIN_SE = 3.0


def _probe(flight, wind, rng, *, factor=(0.0, 0.0), offset=(0.0, 0.0), probe=(0.0, 0.0, 0.0),
           noise=True):
    """``flight`` with a probe's alpha, beta (``(1 + factor) angle + offset``) and airspeed,
    computed in numpy from the simulator's true states and ``wind`` at ``probe`` [m]."""
    x = as_state(flight.states())
    const = constants(flight.airframe)._replace(wind_n=wind[0], wind_e=wind[1],
                                                wind_d=wind[2])
    ua, va, wa = equations.air_velocity(x, const)
    r = np.asarray(probe)
    speed, alpha, beta = equations.air_data(ua + x.q * r[2] - x.r * r[1],
                                            va + x.r * r[0] - x.p * r[2],
                                            wa + x.p * r[1] - x.q * r[0])
    n = flight.n_samples
    e = (rng.standard_normal((3, n)) * np.array([[VANE_SD], [VANE_SD], [AIRSPEED_SD]])
         if noise else np.zeros((3, n)))
    metadata = {**flight.metadata, "air_data_probe": {"position_m": list(probe)}}
    return dataclasses.replace(flight, metadata=metadata, data=flight.data.assign(
        alpha=(1 + factor[0]) * alpha + offset[0] + e[0],
        beta=(1 + factor[1]) * beta + offset[1] + e[1], airspeed=speed + e[2]))


@pytest.fixture(scope="module")
def windy_probe(reference_scenario):
    s = reference_scenario
    man = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND))
    flight = simulate(s.airframe, s.coefficient_vector, man, NoNoise(), rng=0)
    return _probe(flight, WIND, np.random.default_rng(0), noise=False,
                  factor=(0.02, -0.01), offset=(0.002, -0.001), probe=(0.3, 0.02, -0.01))


@pytest.mark.parametrize(("steady", "gusts"), [(False, False), (True, False), (False, True),
                                               (True, True)])
def test_the_air_outputs_are_the_probes_and_their_jacobian_central_differences(
        windy_probe, reference_scenario, steady, gusts) -> None:
    """At the simulator's state and wind (split between the steady and the gust states)
    the filter's air data equal the probe's numpy readings (noise-free, miscalibrated,
    probe off the c.g.); ``H`` equals central differences in every column, transition
    and batched (UKF) forms agree."""
    flight = windy_probe
    est = aeroid.make_estimator("ekf", {"air_data": "measured", "estimate_wind": steady,
                                        "gust_sd_mps": 1.0 if gusts else 0.0})
    plan = _kalman_air.air_plan(est, flight)
    assert plan.channels == ("alpha", "beta", "airspeed")
    assert plan.calibration == ("alpha_factor", "beta_factor", "alpha_offset_rad",
                                "beta_offset_rad")
    record = flight_record(flight)
    if steady or gusts:
        base = _kalman_wind.wind_model(flight, 1, record, ())
        if gusts:
            base = _kalman_gust.with_gusts(base, 0.99, steady=steady)
    else:
        base = _augmented.augmented_model(flight, 1, record, ())
    first = N_STATE + N_COEFFICIENTS
    columns = ((first,) if steady else ()) + ((first + 3 * steady,) if gusts else ())
    model = _kalman_air.air_model(base, flight, plan, "auto", 0.0, columns)
    assert model.dim_x == base.dim_x + 4 and model.dim_z == base.dim_z + 3
    wind = np.array(WIND)
    split = {(False, False): [], (True, False): [wind], (False, True): [wind],
             (True, True): [wind - [0.5, -1.0, 0.3], np.array([0.5, -1.0, 0.3])]}
    cal = np.array([0.02, -0.01, 0.002, -0.001])
    states = flight.states()
    for k in (0, 137, 400):
        z = np.concatenate([states[k], reference_scenario.coefficient_vector,
                            *split[(steady, gusts)], cal])
        y, H = model.observe(z, k)
        truth = [flight[c][k] for c in plan.channels]
        if steady or gusts:
            np.testing.assert_allclose(y[-3:], truth, rtol=SAME_RTOL)
        np.testing.assert_allclose(y[:-3], base.observe(z[:-4], k)[0], rtol=SAME_RTOL)
        for j in range(model.dim_x):
            step = np.zeros(model.dim_x)
            step[j] = FD_STEP * max(1.0, abs(z[j]))
            fd = (model.observe(z + step, k)[0] - model.observe(z - step, k)[0]) / (2 * step[j])
            np.testing.assert_allclose(H[-3:, j], fd[-3:], rtol=1e-6, atol=FD_ATOL,
                                       err_msg=f"column {j}")
        z_next, F = model.transition(z, k)
        np.testing.assert_array_equal(z_next[-4:], cal)
        np.testing.assert_array_equal(F[-4:, -4:], np.eye(4))
        np.testing.assert_allclose(z_next[:-4], base.transition(z[:-4], k)[0], rtol=SAME_RTOL)
        Z = z + np.linspace(-1e-3, 1e-3, 3)[:, None] * np.ones(model.dim_x)
        np.testing.assert_allclose(model.observe_batch(Z, k),
                                   [model.observe(p, k)[0] for p in Z], rtol=1e-12)
        np.testing.assert_allclose(model.transition_batch(Z, k),
                                   [model.transition(p, k)[0] for p in Z], rtol=1e-12)


@pytest.fixture(scope="module")
def windy_noisy(reference_scenario):
    s = reference_scenario
    man = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND))
    flight = simulate(s.airframe, s.coefficient_vector, man, GaussianNoise(), rng=1)
    return _probe(flight, WIND, np.random.default_rng([1, 26]), factor=(0.02, 0.02),
                  offset=(0.002, -0.001))


def test_the_ekf_with_air_data_recovers_the_wind_and_the_coefficients(
        windy_noisy, reference_scenario) -> None:
    """Gaussian IMU, probe 0.1 deg / 0.5 m/s miscalibrated, 5 m/s wind (3 along the path):
    every coefficient, wind component and calibration parameter within 3 se, the
    along-path wind's sd below 0.1 m/s (4.4-4.6 m/s without the airspeed), the probe's
    noise found within 10 % (500 samples: its sd's se ~3 %)."""
    truth = reference_scenario.coefficient_vector
    result = aeroid.make_estimator("ekf", {"estimate_wind": True, "air_data": "measured"}
                                   ).fit(windy_noisy, rng=1)
    assert result.success, result.message
    assert np.all(np.abs(result.theta - truth) <= WITHIN_SE * result.stderr)
    wind, sd = np.array(result.info["wind_ned_mps"]), np.array(result.info["wind_stderr_mps"])
    assert np.all(np.abs(wind - WIND) <= WITHIN_SE * sd)
    assert sd[0] < 0.1
    air = result.info["air_data"]
    for name, value in {"alpha_factor": 0.02, "beta_factor": 0.02, "alpha_offset_rad": 0.002,
                        "beta_offset_rad": -0.001}.items():
        assert abs(air["calibration"][name] - value) <= WITHIN_SE * air[
            "calibration_stderr"][name], name
    np.testing.assert_allclose([air["noise_sd"][c] for c in ("alpha", "beta", "airspeed")],
                               [VANE_SD, VANE_SD, AIRSPEED_SD], rtol=0.1)
    assert {"alpha", "beta", "airspeed"} <= set(result.info["fit_check"]["ratio"])
    assert any(w.startswith("ekf: air data as measured outputs (alpha, beta, airspeed") for w
               in result.warnings)
    said = air["air_data_verdict"]  # the log's air against the inertial angles
    assert said["kind"] == "steady wind"
    assert np.all(np.abs(np.array(said["steady_ned_mps"]) - WIND) < 0.2)  # probe 2 % off
    assert any(w.startswith("ekf: the air data (alpha, beta, airspeed) against the inertial")
               for w in result.warnings)


@pytest.mark.parametrize("method", ["ekf", "ukf"])
def test_a_known_alpha_scale_factor_is_found(reference_scenario, method) -> None:
    """Still air, the logged alpha scaled by 1.05 (beta by 1): the calibration factors
    come out within 3 se of 0.05 and 0, the 0.05 more than 5 se from 0."""
    s = reference_scenario
    flight = _probe(simulate(s.airframe, s.coefficient_vector, s.manoeuvre, GaussianNoise(),
                             rng=2), (0.0, 0.0, 0.0), np.random.default_rng([2, 26]),
                    factor=(0.05, 0.0))
    result = aeroid.make_estimator(method, {"air_data": "measured",
                                            "air_data_calibration": "factor"}).fit(flight, rng=2)
    assert result.success, result.message
    cal, se = result.info["air_data"]["calibration"], result.info["air_data"][
        "calibration_stderr"]
    assert abs(cal["alpha_factor"] - 0.05) <= WITHIN_SE * se["alpha_factor"]
    assert abs(cal["beta_factor"]) <= WITHIN_SE * se["beta_factor"]
    assert cal["alpha_factor"] > 5 * se["alpha_factor"]
    truth = s.coefficient_vector
    assert np.all(np.abs(result.theta - truth) <= WITHIN_SE * result.stderr)


def test_the_logs_probe_noise_is_held(windy_noisy) -> None:
    metadata = {**windy_noisy.metadata, "air_data_probe": {
        "position_m": [0, 0, 0], "noise_sd": {"alpha": 0.002, "beta": 0.0015, "airspeed": 0.4}}}
    flight = dataclasses.replace(windy_noisy, metadata=metadata)
    result = aeroid.make_estimator("ekf", {"estimate_wind": True, "air_data": "measured",
                                           "air_data_noise": "metadata", "max_passes": 2}
                                   ).fit(flight, rng=1)
    assert result.info["air_data"]["noise_sd"] == pytest.approx(
        {"alpha": 0.002, "beta": 0.0015, "airspeed": 0.4}, rel=1e-12)
    assert "the log's (held)" in result.info["air_data"]["noise"]


def test_air_data_is_used_or_refused_in_one_line(windy_noisy, clean_flight) -> None:
    """``measured`` without air data, with imu_errors or several windows; a bad option;
    ``metadata`` noise without the table: one line each. ``inertial`` (the default) says
    the air data are ignored."""
    def refused(options, flight, kind, match):
        with pytest.raises(kind, match=match) as exc:
            aeroid.make_estimator("ekf", options).fit(flight, rng=0)
        assert "\n" not in str(exc.value)

    refused({"air_data": "measured"}, clean_flight, aeroid.FlightError,
            "has no airspeed channel")
    refused({"air_data": "measured", "imu_errors": "bias"}, windy_noisy, aeroid.EstimatorError,
            "with imu_errors = bias is not built")
    refused({"air_data": "measured", "air_data_noise": "metadata"}, windy_noisy,
            aeroid.FlightError, "air_data_probe.noise_sd")
    with pytest.raises(aeroid.EstimatorError, match="air_data_calibration=.gain. not one of"):
        aeroid.make_estimator("ukf", {"air_data_calibration": "gain"})
    with pytest.raises(aeroid.EstimatorError, match="air_data_factor_sd must be > 0"):
        aeroid.make_estimator("ekf", {"air_data_factor_sd": 0.0})
    est = aeroid.make_estimator("ukf", {"air_data": "measured"})
    with pytest.raises(aeroid.EstimatorError, match="air_data = measured with several windows"):
        est.fit(aeroid.flights.Windows((windy_noisy, dataclasses.replace(windy_noisy)),
                                       ("a", "b")), rng=0)
    auto = aeroid.make_estimator("ekf", {"air_data": "auto", "max_passes": 1}).fit(
        clean_flight, rng=0)
    assert "air_data" not in auto.info  # nothing to use: the still-air filter
    ignored = aeroid.make_estimator("ekf", {"max_passes": 1}).fit(windy_noisy, rng=0)
    assert any("ignores the flight's" in w for w in ignored.warnings)


@pytest.mark.parametrize(("given", "passes"), [(False, False), (True, True)])
def test_a_probe_off_the_roll_axis_is_refused_unless_its_position_is_given(
        reference_scenario, given, passes) -> None:
    """A probe 0.1 m off the roll axis at ~51 rad/s sees ~5 m/s of rotation-induced flow
    (0.58 deg of alpha, turning with the roll): with factors only (no offset to absorb
    it) and the position not given, the fit check refuses the fit; given, it passes
    (the known-wrong input and its correct twin, as output-error's test)."""
    s = reference_scenario
    flight = _probe(simulate(s.airframe, s.coefficient_vector, s.manoeuvre, GaussianNoise(),
                             rng=3), (0.0, 0.0, 0.0), np.random.default_rng([3, 26]),
                    probe=(0.0, 0.1, 0.0))
    if not given:
        flight = dataclasses.replace(flight, metadata={
            k: v for k, v in flight.metadata.items() if k != "air_data_probe"})
    result = aeroid.make_estimator("ekf", {"air_data": "measured",
                                           "air_data_calibration": "factor"}).fit(flight, rng=3)
    assert result.success is passes, result.message
    if not passes:
        assert "does not fit" in result.message and result.info["fit_check"]["worst"] in (
            "alpha", "beta", "airspeed")


def test_still_air_states_with_a_windy_probe_are_refused(windy_noisy) -> None:
    """The known-wrong model: no wind states on the 5 m/s windy flight with the probe's
    air data as outputs: the air data's residuals fail the fit check (said: the default,
    auto, carries the wind on this flight, whose metadata declares it)."""
    result = aeroid.make_estimator("ekf", {"air_data": "measured", "max_passes": 1,
                                           "estimate_wind": False}).fit(windy_noisy, rng=1)
    assert not result.success and "does not fit" in result.message


def test_the_walk_warning_of_wind_with_gusts_is_not_said_with_an_airspeed(windy_noisy) -> None:
    """Gust states with ``estimate_wind`` carry the warning that the passes walk along the
    along-path wind; an airspeed output pins it (measured: ``benchmarks/results/
    gust_air.md``, 8/8 passed): not said then, and the air data's notice is."""
    options = {"estimate_wind": True, "gust_sd_mps": 1.0, "max_passes": 1}
    with_air = aeroid.make_estimator("ekf", {**options, "air_data": "measured"}).fit(
        windy_noisy, rng=1)
    assert _kalman_gust.BOTH_WARNING not in with_air.warnings
    assert any(w.startswith("ekf: air data as measured outputs") for w in with_air.warnings)
    without = aeroid.make_estimator("ekf", options).fit(windy_noisy, rng=1)
    assert _kalman_gust.BOTH_WARNING in without.warnings


def test_turbulence_is_named_after_the_filtered_steady_wind(reference_scenario) -> None:
    """Dryden sd 3 m/s plus the 5 m/s wind, the simulator's logged angles with 0.1 deg of
    vane noise: the steady-wind filter (no gust states) with the angles as outputs says
    turbulence (the gusts are what its steady wind leaves), and the fit check refuses
    that model (one pass: with two the passes' verdict refuses it first, Clp moved 17 se);
    the steady flight above is "steady wind"."""
    s = reference_scenario
    man = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND, turbulence_sd_mps=3.0))
    flight = simulate(s.airframe, s.coefficient_vector, man, GaussianNoise(), rng=2)
    gen = np.random.default_rng([2, 26])
    flight = dataclasses.replace(flight, data=flight.data.assign(
        alpha=flight["alpha"] + VANE_SD * gen.standard_normal(flight.n_samples),
        beta=flight["beta"] + VANE_SD * gen.standard_normal(flight.n_samples)))
    result = aeroid.make_estimator("ekf", {"estimate_wind": True, "air_data": "measured",
                                           "max_passes": 1}).fit(flight, rng=2)
    assert result.info["air_data"]["air_data_verdict"]["kind"] == "turbulence"
    assert not result.success and "does not fit" in result.message, result.message


#: The EKF's smoothed passes with air data against output-error with air data on one
#: flight: two estimators of the same MAP/ML (the prior's weight apart), measured 0.17
#: of output-error's se at most on the coefficients (seeds 1-3: 0.17-0.22), 0.13 on the
#: wind, 0.01 on the calibration, standard errors within 3-6 %.
AGREE_SE = 0.3
CAL_AGREE_SE = 0.1
SE_RTOL = 0.1


def test_the_ekf_with_air_data_agrees_with_output_error(windy_noisy) -> None:
    """A second method as the reference: output-error with the same air data, wind and
    calibration on the same flight."""
    options = {"estimate_wind": True, "air_data": "measured"}
    oe = aeroid.make_estimator("output-error", options).fit(windy_noisy, rng=1)
    ekf = aeroid.make_estimator("ekf", options).fit(windy_noisy, rng=1)
    assert oe.success and ekf.success
    assert np.all(np.abs(ekf.theta - oe.theta) <= AGREE_SE * oe.stderr)
    np.testing.assert_allclose(ekf.stderr, oe.stderr, rtol=SE_RTOL)
    wind_se = np.array(oe.info["wind_stderr_mps"])
    assert np.all(np.abs(np.array(ekf.info["wind_ned_mps"]) - oe.info["wind_ned_mps"])
                  <= AGREE_SE * wind_se)
    ours, theirs = ekf.info["air_data"], oe.info["air_data"]
    for name, value in theirs["calibration"].items():
        assert abs(ours["calibration"][name] - value) <= CAL_AGREE_SE * theirs[
            "calibration_stderr"][name], name
