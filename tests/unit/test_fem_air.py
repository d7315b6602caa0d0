"""Filter-error with air data (alpha, beta, airspeed) as measured outputs (issue 26).

References: the EKF/UKF's air-data functions (:mod:`baselines._kalman_air`) and the
probe's readings computed here in numpy from the simulator's states and wind for the
filter's measurement; filterpy's EKF (:func:`baselines._kalman.run_ekf`) on the EKF's
steady-wind model with the air rows for the batched filter; the simulator's truth and a
known vane offset for the fits.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from closeness import assert_close_in_norm

import aeroid
from aeroid.flights import Wind, flight_record, make_noise, simulate
from aeroid.model import N_COEFFICIENTS, N_STATE, OUTPUT_CHANNELS, as_state, constants, equations
from baselines import _common, _fem_setup, _kalman, _kalman_air, _kalman_wind
from baselines._fem_filter import gust_model, run_filters
from baselines._fem_model import N_WIND, gust_functions

WIND = (3.0, 4.0, 0.0)
VANE_SD = float(np.radians(0.1))
AIRSPEED_SD = 0.5
PROBE = (0.3, 0.02, -0.01)
CAL = np.array([0.02, -0.01, 0.002, -0.001])  # alpha, beta factors; offsets [rad]
CHANNELS = ("alpha", "beta", "airspeed")
CALIBRATION = ("alpha_factor", "beta_factor", "alpha_offset_rad", "beta_offset_rad")
#: Two CasADi graphs of the same function (_oe_airdata's probe outputs): rounding only.
SAME_RTOL = 1e-12
#: The CasADi outputs against numpy's evaluation of the same equations at the
#: simulator's state and wind: rounding only (as test_kalman_air's).
PROBE_RTOL = 1e-10
#: filterpy's EKF and the batched one (as test_filter_error's FILTER_RTOL: the order of
#: the covariance algebra and filterpy's rounding clip of P): measured 1.9e-11 of a
#: channel's range at most (innovations, S, wind; the air rows' 0 to 2e-16).
FILTER_RTOL = 1e-9
WITHIN_SE = 3.0
#: The known-wrong probe: an alpha vane offset of 0.5 deg (5x the vane's noise) with the
#: calibration held at zero.
WRONG_OFFSET_RAD = float(np.radians(0.5))


def _probe(flight, wind, *, factor=(0.0, 0.0), offset=(0.0, 0.0), probe=PROBE):
    """``flight`` with a noise-free probe's alpha, beta (``(1 + factor) angle + offset``)
    and airspeed at ``probe`` [m], computed in numpy from the simulator's states and
    ``wind`` (the lever arm ``omega x r`` written out)."""
    x = as_state(flight.states())
    const = constants(flight.airframe)._replace(wind_n=wind[0], wind_e=wind[1],
                                                wind_d=wind[2])
    ua, va, wa = equations.air_velocity(x, const)
    r = np.asarray(probe)
    speed, alpha, beta = equations.air_data(ua + x.q * r[2] - x.r * r[1],
                                            va + x.r * r[0] - x.p * r[2],
                                            wa + x.p * r[1] - x.q * r[0])
    metadata = {**flight.metadata, "air_data_probe": {"position_m": list(probe)}}
    return dataclasses.replace(flight, metadata=metadata, data=flight.data.assign(
        alpha=(1 + factor[0]) * alpha + offset[0], beta=(1 + factor[1]) * beta + offset[1],
        airspeed=speed))


@pytest.fixture(scope="module")
def windy_probe(reference_scenario):
    s = reference_scenario
    man = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND))
    flight = simulate(s.airframe, s.coefficient_vector, man, make_noise("gaussian"), rng=1)
    return _probe(flight, WIND, factor=tuple(CAL[:2]), offset=tuple(CAL[2:]))


@pytest.fixture(scope="module")
def turbulent_probe(reference_scenario):
    """Dryden sd 3 m/s in the 5 m/s wind, the probe drawn by the simulator's noise model
    (0.1 deg vanes, 0.5 m/s airspeed: benchmarks/bench_air_data.py's)."""
    s = reference_scenario
    man = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND,
                                                     turbulence_sd_mps=3.0))
    noise = make_noise("gaussian", alpha_sd_rad=VANE_SD, beta_sd_rad=VANE_SD,
                       airspeed_sd_mps=AIRSPEED_SD)
    return simulate(s.airframe, s.coefficient_vector, man, noise, rng=2)


def test_the_predicted_air_data_are_the_kalman_filters_and_the_probes(
        windy_probe, reference_scenario) -> None:
    """The filter-error measurement's air rows and their Jacobian in ``[x, w]`` equal the
    EKF/UKF's air-data function (:func:`baselines._kalman_air._air_functions`), and at the
    simulator's state and wind the probe's numpy readings (miscalibrated, off the c.g.);
    the IMU rows are filter-error's without air data."""
    flight = windy_probe
    const = constants(flight.airframe)
    f, h = gust_functions(const, flight.dt, 1, 1, False, CHANNELS, CALIBRATION)
    _, h_imu = gust_functions(const, flight.dt, 1, 1, False)
    full, _ = _kalman_air._air_functions(const, False, CHANNELS, CALIBRATION)
    theta = reference_scenario.coefficient_vector
    pos = flight.airframe.accel_positions.ravel()
    m = len(OUTPUT_CHANNELS)
    states = flight.states()
    for k in (0, 137, 400):
        for w in (np.array(WIND), np.array([1.5, -2.0, 0.7])):
            xw = np.concatenate([states[k], w])
            y, H = (np.asarray(v) for v in h(xw, theta, flight["delta"][k], [], pos, CAL,
                                             PROBE))
            y_imu, H_imu = (np.asarray(v) for v in h_imu(xw, theta, flight["delta"][k], [],
                                                         pos))
            ya, dx, dw, _ = (np.asarray(v) for v in full(states[k], w, [], PROBE, CAL))
            assert_close_in_norm(y[m:].ravel(), ya.ravel(), SAME_RTOL)
            assert_close_in_norm(H[m:, :N_STATE], dx, SAME_RTOL)
            assert_close_in_norm(H[m:, N_STATE:], dw, SAME_RTOL)
            np.testing.assert_array_equal(y[:m], y_imu)
            np.testing.assert_array_equal(H[:m], H_imu)
            if np.array_equal(w, WIND):
                np.testing.assert_allclose(y[m:].ravel(), [flight[c][k] for c in CHANNELS],
                                           rtol=PROBE_RTOL)
    assert np.max(np.abs(H[m:, N_STATE:])) > 1e-4  # rad per m/s: the probe sees the wind


def test_the_filter_with_air_data_is_filterpys_ekf(windy_probe, reference_scenario) -> None:
    """The gust filter with the air rows against filterpy's EKF on the EKF's steady-wind
    model with the EKF's air rows (:func:`baselines._kalman_air.air_model`), the gusts'
    decay and process noise in its wind states, the coefficients and calibration known."""
    flight = windy_probe
    zs = _common.measurements(flight)
    noise = _fem_setup.measurement_noise(flight, zs, "metadata", "test")
    x0, P0x = _fem_setup.initial_state(flight, zs, noise.R)
    theta = reference_scenario.coefficient_vector
    sigma, decay = 2.0, 0.99
    wind = slice(N_STATE + N_COEFFICIENTS, N_STATE + N_COEFFICIENTS + N_WIND)
    base = _kalman_wind.wind_model(flight, 1, flight_record(flight, "auto"), ())

    def transition(z, k):
        z_next, F = base.transition(z, k)
        z_next, F = z_next.copy(), F.copy()
        z_next[wind] = decay * z[wind]
        F[wind, wind] = decay * np.eye(N_WIND)
        return z_next, F

    plan = _kalman_air.air_plan(aeroid.make_estimator("ekf", {"air_data": "measured"}),
                                flight)
    assert plan.channels == CHANNELS and plan.calibration == CALIBRATION
    model = _kalman_air.air_model(dataclasses.replace(base, transition=transition), flight,
                                  plan, "auto", 0.0, (wind.start,))
    n_aug = model.dim_x
    P0 = np.zeros((n_aug, n_aug))
    P0[:N_STATE, :N_STATE] = P0x
    P0[wind, wind] = sigma**2 * np.eye(N_WIND)
    known = np.r_[N_STATE:wind.start, wind.stop:n_aug]  # coefficients and calibration
    P0[known, known] = 1e-20  # known: a variance far below anything the data could move
    Q = np.zeros((n_aug, n_aug))
    Q[wind, wind] = sigma**2 * (1 - decay**2) * np.eye(N_WIND)
    R = np.concatenate([noise.R, np.square([VANE_SD, VANE_SD, AIRSPEED_SD])])  # variances
    z_all = np.hstack([zs, plan.z])
    reference = _kalman.run_ekf(model, np.concatenate([x0, theta, np.zeros(N_WIND), CAL]),
                                P0, Q, np.diag(R), z_all)
    assert reference.failed_at is None
    runs = run_filters(gust_model(flight, 1, "auto", 0.0, True, CHANNELS, CALIBRATION,
                                  np.array(PROBE)),
                       theta[None], np.zeros((1, N_WIND)), np.array([sigma]), decay, x0, P0x,
                       R, z_all, CAL[None])
    assert runs.ok[0]
    assert runs.innovation.shape[2] == len(OUTPUT_CHANNELS) + len(CHANNELS)
    assert_close_in_norm(runs.innovation[0], reference.innovation, FILTER_RTOL, axis=0)
    assert_close_in_norm(np.diagonal(runs.S[0], axis1=1, axis2=2), reference.innovation_var,
                         FILTER_RTOL, axis=0)
    assert_close_in_norm(runs.x[0][:, N_STATE:], reference.x[:, wind], FILTER_RTOL)


def test_in_turbulence_the_air_data_fit_is_within_3_se(turbulent_probe,
                                                       reference_scenario) -> None:
    """Dryden sd 3 m/s + the 5 m/s wind, 0.1 deg vanes and a 0.5 m/s airspeed: every
    coefficient and calibration parameter within 3 se of the truth (0), the fit check
    passed, the probe's noise re-estimated within 15 % (500 samples: its sd's se ~3 %),
    and the standard errors below half of filter-error's without the air data (measured:
    the mean relative se 14.4 -> 5.6 %, seed 1)."""
    truth = reference_scenario.coefficient_vector
    result = aeroid.make_estimator("filter-error", {"air_data": "measured"}).fit(
        turbulent_probe, rng=1)
    assert result.success, result.message
    assert np.all(np.abs(result.theta - truth) <= WITHIN_SE * result.stderr)
    air = result.info["air_data"]
    assert air["channels"] == CHANNELS
    for name in CALIBRATION:
        assert abs(air["calibration"][name]) <= WITHIN_SE * air["calibration_stderr"][name]
    np.testing.assert_allclose([air["noise_sd"][c] for c in CHANNELS],
                               [VANE_SD, VANE_SD, AIRSPEED_SD], rtol=0.15)
    assert set(CHANNELS) <= set(result.info["fit_check"]["ratio"])
    names = result.info["parameter_names"]
    assert names[-len(CALIBRATION):] == CALIBRATION
    assert any(w.startswith("filter-error: air data as measured outputs (alpha, beta, "
                            "airspeed") for w in result.warnings)
    without = aeroid.make_estimator("filter-error").fit(turbulent_probe, rng=1)
    assert np.mean(result.stderr / np.abs(truth)) < 0.5 * np.mean(
        without.stderr / np.abs(truth))
    assert any("ignores the flight's logged alpha" in w for w in without.warnings)


@pytest.mark.parametrize(("calibration", "passes"), [("none", False), ("offset", True)])
def test_a_vane_offset_held_at_zero_is_refused(turbulent_probe, reference_scenario,
                                              calibration, passes) -> None:
    """The known-wrong probe: an alpha vane 0.5 deg off with the calibration held at zero
    (``none``) is refused by the fit check (the gusts cannot carry an offset that turns
    with the roll in NED); its twin with the offset estimated passes and finds it."""
    flight = dataclasses.replace(turbulent_probe, data=turbulent_probe.data.assign(
        alpha=turbulent_probe["alpha"] + WRONG_OFFSET_RAD))
    result = aeroid.make_estimator("filter-error", {
        "air_data": "measured", "air_data_calibration": calibration}).fit(flight, rng=1)
    assert result.success is passes, result.message
    if not passes:
        assert "does not fit" in result.message
        assert result.info["fit_check"]["worst"] == "alpha"
    else:
        air = result.info["air_data"]
        assert abs(air["calibration"]["alpha_offset_rad"] - WRONG_OFFSET_RAD) <= (
            WITHIN_SE * air["calibration_stderr"]["alpha_offset_rad"])
        truth = reference_scenario.coefficient_vector
        assert np.all(np.abs(result.theta - truth) <= WITHIN_SE * result.stderr)


def test_air_data_is_used_or_refused_in_one_line(turbulent_probe, clean_flight) -> None:
    """``measured`` on a flight without air data, ``metadata`` noise without the table, a
    bad option: one line each; ``auto`` without air data is the plain filter."""
    def refused(options, flight, kind, match):
        with pytest.raises(kind, match=match) as exc:
            aeroid.make_estimator("filter-error", options).fit(flight, rng=0)
        assert "\n" not in str(exc.value)

    refused({"air_data": "measured"}, clean_flight, aeroid.FlightError,
            "filter-error: air_data = 'measured' but .* has no airspeed channel")
    refused({"air_data": "measured", "air_data_noise": "metadata"}, turbulent_probe,
            aeroid.FlightError, "air_data_probe.noise_sd")
    for option, value in (("air_data", "reconstruction"), ("air_data_calibration", "gain"),
                          ("air_data_noise", "innovations")):
        with pytest.raises(aeroid.EstimatorError, match=option) as exc:
            aeroid.make_estimator("filter-error", {option: value})
        assert "\n" not in str(exc.value)
    auto = aeroid.make_estimator("filter-error", {"air_data": "auto", "max_iterations": 2}
                                 ).fit(clean_flight, rng=0)
    assert "air_data" not in auto.info
    assert set(auto.info["fit_check"]["ratio"]) == set(OUTPUT_CHANNELS)
    used = aeroid.make_estimator("filter-error", {"air_data": "auto", "max_iterations": 2}
                                 ).fit(turbulent_probe, rng=0)
    assert used.info["air_data"]["channels"] == CHANNELS
    assert not any("ignores the flight's" in w for w in used.warnings)


#: Light turbulence in the steady wind: the along-path (north) wind's se from the IMU
#: alone was 42-111 m/s (benchmarks/results/fem_air.md, seeds 1-8), with the airspeed
#: 0.88-1.07 m/s (the gusts' intensity: a record ~L/V long); this bound sits between.
ALONG_PATH_SE_MPS = 2.0


def test_light_turbulence_with_a_steady_wind_is_identified_with_the_airspeed(
        reference_scenario) -> None:
    """Dryden sd 1 m/s in the 5 m/s wind (3 m/s along the path) with the probe: with
    ``estimate_wind`` every coefficient and wind component within 3 se, the along-path
    component's se below ALONG_PATH_SE_MPS, the fit check passed."""
    s = reference_scenario
    man = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND,
                                                     turbulence_sd_mps=1.0))
    noise = make_noise("gaussian", alpha_sd_rad=VANE_SD, beta_sd_rad=VANE_SD,
                       airspeed_sd_mps=AIRSPEED_SD)
    flight = simulate(s.airframe, s.coefficient_vector, man, noise, rng=3)
    result = aeroid.make_estimator("filter-error", {"air_data": "measured",
                                                    "estimate_wind": True}).fit(flight, rng=3)
    assert result.success, result.message
    truth = s.coefficient_vector
    assert np.all(np.abs(result.theta - truth) <= WITHIN_SE * result.stderr)
    wind, se = np.array(result.info["wind_ned_mps"]), np.array(result.info["wind_stderr_mps"])
    assert np.all(np.abs(wind - WIND) <= WITHIN_SE * se)
    assert se[0] < ALONG_PATH_SE_MPS


def test_the_logs_probe_noise_is_held(turbulent_probe) -> None:
    metadata = {**turbulent_probe.metadata, "air_data_probe": {
        "position_m": [0, 0, 0], "noise_sd": {"alpha": 0.002, "beta": 0.0015, "airspeed": 0.4}}}
    flight = dataclasses.replace(turbulent_probe, metadata=metadata)
    result = aeroid.make_estimator("filter-error", {"air_data": "measured",
                                                    "air_data_noise": "metadata",
                                                    "max_iterations": 3}).fit(flight, rng=1)
    assert result.info["air_data"]["noise_sd"] == pytest.approx(
        {"alpha": 0.002, "beta": 0.0015, "airspeed": 0.4}, rel=1e-12)
    assert "the log's (held)" in result.info["air_data"]["noise"]


#: Filter-error and output-error with the same air data, wind and calibration in a steady
#: wind without gusts: the same likelihood once the gust intensity is at its 1 mm/s floor
#: (1 against 2 RK4 substeps apart), measured 0.08-0.11 of output-error's se on the
#: coefficients (seeds 1-3), 0.1 on the wind, 0.01 on the calibration; se within 2.5 %.
AGREE_SE = 0.3
CAL_AGREE_SE = 0.1
SE_RTOL = 0.05


def test_without_gusts_it_is_output_error_with_air_data(reference_scenario) -> None:
    """A second method as the reference: output-error with ``air_data = measured`` and
    ``estimate_wind`` on the same steady-wind flight (0.1 deg vanes, 0.5 m/s airspeed)."""
    s = reference_scenario
    man = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND))
    noise = make_noise("gaussian", alpha_sd_rad=VANE_SD, beta_sd_rad=VANE_SD,
                       airspeed_sd_mps=AIRSPEED_SD)
    flight = simulate(s.airframe, s.coefficient_vector, man, noise, rng=2)
    options = {"air_data": "measured", "estimate_wind": True}
    oe = aeroid.make_estimator("output-error", options).fit(flight, rng=2)
    fe = aeroid.make_estimator("filter-error", options).fit(flight, rng=2)
    assert oe.success and fe.success, (oe.message, fe.message)
    assert fe.info["gust_sd_at_bound"]
    assert np.all(np.abs(fe.theta - oe.theta) <= AGREE_SE * oe.stderr)
    np.testing.assert_allclose(fe.stderr, oe.stderr, rtol=SE_RTOL)
    wind_se = np.array(oe.info["wind_stderr_mps"])
    assert np.all(np.abs(np.array(fe.info["wind_ned_mps"]) - oe.info["wind_ned_mps"])
                  <= AGREE_SE * wind_se)
    ours, theirs = fe.info["air_data"], oe.info["air_data"]
    for name, value in theirs["calibration"].items():
        assert abs(ours["calibration"][name] - value) <= CAL_AGREE_SE * theirs[
            "calibration_stderr"][name], name
