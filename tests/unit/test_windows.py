"""Several windows in one fit: the Windows type, cutting a log, refusals, identities.

References: the log's own samples (cutting), exact identities of the stacked fits (two
copies of one window halve the information; the stacked information is the sum of the
windows'; one window is the single-flight fit), noise-free recovery of the coefficients.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import aeroid
from aeroid.errors import EstimatorError, FlightError
from aeroid.flights import (
    GaussianNoise,
    NoNoise,
    Windows,
    cut_windows,
    parse_window_spec,
    reference_scenario,
    simulate_scenario,
)
from baselines import _oe_windows, output_error
from baselines._gauss_newton import fisher_information
from baselines._oe_windows import windows_problem
from baselines.equation_error import EquationErrorEstimator
from baselines.output_error import OutputErrorEstimator

#: Noise-free recovery over two windows, output-error: as the single flight's
#: (tests/unit/test_baselines_output_error.py RECOVERY_RTOL; measured <= 2.6e-6 here).
RECOVERY_RTOL = 1e-4
#: Noise-free recovery, EKF/UKF over two windows (one flight's filters reach ~1e-5 there):
#: measured <= 4.2e-5 (Clp), tolerance 5x.
FILTER_RTOL = 2e-4
#: Equation-error one-step, noise-free: the single flight's ONE_STEP_RTOL
#: (tests/unit/test_baselines_equation_error.py; measured 5.1e-9 over two windows).
ONE_STEP_RTOL = 1e-8
#: Identities that hold to rounding (sums and products of ~1e3-sized terms; converged
#: fits whose last steps differ only by rounding: measured <= 2e-11 on the standard
#: errors of two copies against one window's / sqrt(2)).
IDENTITY_RTOL = 1e-9
PRIOR_FACTOR = np.array([1.2, 0.8, 1.2, 0.8, 1.2, 0.8, 1.2, 0.8, 1.2])
NOISE = GaussianNoise(accel_sd_mps2=0.5, rate_sd_radps=0.02, position_sd_m=0.0)


def _long(noise, rng):
    """The reference scenario recorded over 5.0-6.6 s (801 samples)."""
    sc = reference_scenario()
    sc = dataclasses.replace(sc, manoeuvre=dataclasses.replace(sc.manoeuvre,
                                                               window_s=(5.0, 6.6)))
    return simulate_scenario(sc, noise, rng=rng)


@pytest.fixture(scope="module")
def clean_log():
    flight = _long(NoNoise(), 0)
    prior = tuple(aeroid.nominal() * PRIOR_FACTOR)
    return dataclasses.replace(flight, airframe=flight.airframe.replace(prior=prior))


@pytest.fixture(scope="module")
def clean_windows(clean_log):
    return cut_windows(clean_log, "5-5.5,6-6.5")


@pytest.fixture(scope="module")
def noisy_window():
    return simulate_scenario(reference_scenario(), NOISE, rng=4)


# the type and the cutting ---------------------------------------------------------------
def test_parse_window_spec_reads_ranges_in_order():
    assert parse_window_spec("8-9, 5-6.5") == [(8.0, 9.0), (5.0, 6.5)]
    assert parse_window_spec(".5-1e1") == [(0.5, 10.0)]


@pytest.mark.parametrize(("spec", "says"), [
    ("", "no time range"), ("5", "not START-END"), ("a-b", "not START-END"),
    ("5-6,", "not START-END"), ("6-5", "ends before it starts"),
    ("5-5", "ends before it starts")])
def test_bad_window_specs_are_refused_in_one_line(clean_log, spec, says):
    with pytest.raises(FlightError, match=says) as err:
        cut_windows(clean_log, spec)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(("spec", "says"), [
    ("4-5.2", "outside the log"), ("6-7", "outside the log"),
    ("5-5.5,5.4-6", "overlap"), ("6-6.5,5-6", "overlap"), ("5-5.001", "1 sample")])
def test_windows_outside_overlapping_or_empty_are_refused(clean_log, spec, says):
    with pytest.raises(FlightError, match=says) as err:
        cut_windows(clean_log, spec)
    assert "\n" not in str(err.value)


def test_cut_windows_hold_the_logs_samples_in_each_range(clean_log):
    windows = cut_windows(clean_log, "6-6.5,5-5.5")
    assert windows.names == ("6-6.5", "5-5.5")
    t = clean_log.t
    for (start, stop), flight in zip([(6.0, 6.5), (5.0, 5.5)], windows, strict=True):
        rows = np.flatnonzero((t >= start) & (t <= stop))
        assert flight.n_samples == rows.size == 251
        np.testing.assert_array_equal(flight.data.to_numpy(),
                                      clean_log.data.to_numpy()[rows])
        assert flight.metadata["window_s"] == [start, stop]
        assert flight.metadata["source"].endswith(f"[{start:g}-{stop:g} s]")
    assert windows.bounds() == [(0, 251), (251, 502)]
    joined = windows.joined()
    assert joined.n_samples == 502 and np.all(np.diff(joined.t) > 0)


def test_windows_refuse_other_airframes_and_repeated_names(clean_log):
    other = dataclasses.replace(clean_log, airframe=clean_log.airframe.replace(
        accel1_position_m=(0.5, 0.0, 0.0)))
    with pytest.raises(FlightError, match="accel1_position_m"):
        Windows.of([clean_log, other])
    with pytest.raises(FlightError, match="given twice"):
        Windows((clean_log, clean_log), ("a", "a"))
    with pytest.raises(FlightError, match="no window"):
        Windows((), ())
    # mass and atmosphere may differ (per-window density and inputs)
    heavier = dataclasses.replace(clean_log, airframe=clean_log.airframe.replace(mass_kg=80.0))
    assert len(Windows.of([clean_log, heavier])) == 2


@pytest.mark.parametrize("method", ["sebm-pso", "eam-pso", "ebm-pso", "pyswarms"])
def test_methods_that_cannot_fit_windows_refuse_in_one_line(clean_windows, method):
    if method not in aeroid.estimation.available():
        pytest.skip(f"{method} not installed")
    with pytest.raises(EstimatorError, match="cannot fit several windows") as err:
        aeroid.make_estimator(method, {}).fit(clean_windows, rng=0)
    assert "\n" not in str(err.value)


# output-error -----------------------------------------------------------------------------
def test_output_error_recovers_coefficients_from_two_noise_free_windows(clean_windows):
    res = OutputErrorEstimator().fit(clean_windows, rng=0)
    assert res.success, res.message
    np.testing.assert_allclose(res.theta, aeroid.nominal(), rtol=RECOVERY_RTOL)
    names = res.info["parameter_names"]
    assert names[:len(aeroid.NAMES)] == aeroid.NAMES
    assert "5-5.5:p0" in names and "6-6.5:r0" in names
    # each window's own initial rates: the truth's at its first sample (noise-free)
    for name, flight in clean_windows.items():
        start = np.array(res.info["window_parameters"][name]["initial_state"])
        np.testing.assert_allclose(start[3:6], flight.states()[0, 3:6], atol=1e-3)


def test_stacked_information_is_the_sum_of_the_windows(clean_windows):
    est = OutputErrorEstimator(estimate_delay=True, imu_errors="bias")
    prob, model = windows_problem(est, clean_windows)
    p = np.zeros(model.layout.size)
    p[:len(aeroid.NAMES)] = 1.1 / PRIOR_FACTOR  # off the optimum: residuals not zero
    e, J = prob.residuals_jacobian(p)
    var = np.mean(e * e, axis=0)
    M, g = fisher_information(J, e, var)
    M_sum, g_sum = np.zeros_like(M), np.zeros_like(g)
    for w, (flight, (a, b)) in enumerate(zip(clean_windows, model.rows, strict=True)):
        alone = est.problem(flight, model.models[0].position_free)  # a separate model
        idx = model.layout.index[w]
        e_w, J_w = alone.residuals_jacobian(p[idx])
        np.testing.assert_allclose(e_w, e[a:b], rtol=0, atol=1e-12 * np.abs(e).max())
        M_w, g_w = fisher_information(J_w, e_w, var)
        M_sum[np.ix_(idx, idx)] += M_w
        g_sum[idx] += g_w
    np.testing.assert_allclose(M, M_sum, rtol=IDENTITY_RTOL, atol=0)
    np.testing.assert_allclose(g, g_sum, rtol=IDENTITY_RTOL, atol=1e-12 * np.abs(g).max())
    # the block-sparse pattern: window 1's rows do not see window 2's own parameters
    a, b = model.rows[0]
    assert not np.any(J[:, a:b, model.layout.own(1)])


@pytest.mark.parametrize("noise_model", ["channel", "signal"])
def test_two_copies_of_a_window_give_standard_errors_over_sqrt2(noisy_window, noise_model):
    # per-window nuisances (p0, q0, r0) are separate per copy, yet the coefficients'
    # information (a Schur complement) doubles exactly
    est = OutputErrorEstimator(noise_model=noise_model)
    one = est.fit(noisy_window, rng=0)
    two = est.fit(Windows.of([noisy_window, noisy_window]), rng=0)
    # (the fit check may fail the copies: their residuals repeat at a lag of one window,
    # which its autocorrelation test rightly sees; the fit itself converged)
    assert one.success, one.message
    assert two.success or "structure in the residuals" in two.message, two.message
    np.testing.assert_allclose(two.stderr, one.stderr / np.sqrt(2.0), rtol=IDENTITY_RTOL)
    np.testing.assert_allclose(two.theta, one.theta, rtol=0, atol=IDENTITY_RTOL * np.abs(
        one.theta).max())


def test_the_windows_sample_limit_is_output_errors():
    assert _oe_windows.MAX_SAMPLES == output_error.MAX_SAMPLES


def test_output_error_refuses_options_it_cannot_apply_to_windows(clean_windows):
    for options in ({"pso_warm_start": True}, {"positions": "consider"}, {"staged_start": True}):
        with pytest.raises(EstimatorError, match="not available for several windows"):
            OutputErrorEstimator(**options).fit(clean_windows, rng=0)


# equation-error ---------------------------------------------------------------------------
@pytest.mark.parametrize("one_step", [False, True])
def test_equation_error_of_two_copies_is_that_of_one(noisy_window, one_step):
    est = EquationErrorEstimator(one_step=one_step, covariance="ols")
    one = est.fit(noisy_window)
    two = est.fit(Windows.of([noisy_window, noisy_window]))
    # duplicated rows: the same least-squares solution
    np.testing.assert_allclose(two.theta, one.theta, rtol=1e-7)


def test_equation_error_one_step_recovers_two_noise_free_windows(clean_windows):
    res = EquationErrorEstimator(one_step=True).fit(clean_windows)
    assert res.success, res.message
    np.testing.assert_allclose(res.theta, aeroid.nominal(), rtol=ONE_STEP_RTOL)
    assert set(res.info["window_gyro_only_floor"]) == set(clean_windows.names)


# EKF / UKF --------------------------------------------------------------------------------
@pytest.mark.parametrize("method", ["ekf", "ukf"])
def test_filter_over_one_window_is_the_single_flight_filter(noisy_window, method):
    est = aeroid.make_estimator(method, {})
    alone = est.fit(noisy_window)
    windows = est.fit(Windows.of([noisy_window]))
    np.testing.assert_array_equal(windows.theta, alone.theta)
    np.testing.assert_array_equal(windows.stderr, alone.stderr)
    # the passes' settle verdict (baselines._kalman_verdict) judges windows as one flight
    assert "last_pass_moves_se" in alone.info
    assert windows.info["last_pass_moves_se"] == alone.info["last_pass_moves_se"]
    assert windows.success == alone.success


@pytest.mark.parametrize("method", ["ekf", "ukf"])
def test_filter_carries_the_coefficients_into_the_second_window(clean_windows, method):
    one_pass = aeroid.make_estimator(method, {"max_passes": 1})
    first = one_pass.fit(clean_windows.flights[0])
    both = one_pass.fit(clean_windows)
    n = clean_windows.flights[0].n_samples
    # the first window's filter is untouched by the second
    np.testing.assert_array_equal(both.history["theta"][:n], first.history["theta"])
    # the second window starts at the first's end, no wider
    assert np.all(both.history["theta_sd"][n] <= first.stderr * (1 + 1e-9))
    res = aeroid.make_estimator(method, {}).fit(clean_windows)
    assert res.success, res.message
    np.testing.assert_allclose(res.theta, aeroid.nominal(), rtol=FILTER_RTOL)


def test_windows_at_different_densities_and_masses_share_the_coefficients():
    # each window its own atmosphere and mass (per-window constants): the shared
    # coefficients are recovered only if each window's density and mass are used
    sc = reference_scenario()
    low = dataclasses.replace(sc, airframe=sc.airframe.replace(altitude_m=7000.0,
                                                               mass_kg=75.0))
    flights = [simulate_scenario(s, NoNoise(), rng=0) for s in (sc, low)]
    prior = tuple(aeroid.nominal() * PRIOR_FACTOR)
    flights = [dataclasses.replace(f, airframe=f.airframe.replace(prior=prior))
               for f in flights]
    windows = Windows.of(flights, ["10 km", "7 km"])
    res = OutputErrorEstimator().fit(windows, rng=0)
    assert res.success, res.message
    np.testing.assert_allclose(res.theta, aeroid.nominal(), rtol=RECOVERY_RTOL)
    res = EquationErrorEstimator(one_step=True).fit(windows)
    np.testing.assert_allclose(res.theta, aeroid.nominal(), rtol=ONE_STEP_RTOL)
    # the same windows with the 7 km one's airframe said to be at 10 km: refused
    wrong = Windows.of([flights[0], dataclasses.replace(
        flights[1], airframe=flights[1].airframe.replace(altitude_m=10000.0, mass_kg=75.0))])
    assert not OutputErrorEstimator().fit(wrong, rng=0).success


@pytest.mark.parametrize("method", ["output-error", "ekf", "equation-error"])
def test_a_windows_fit_repeats_with_its_seed_and_leaves_the_windows_alone(noisy_window,
                                                                          method):
    other = simulate_scenario(reference_scenario(), NOISE, rng=5)
    windows = Windows.of([noisy_window, other])
    before = [f.data.copy() for f in windows]
    options = {"n_starts": 2} if method == "output-error" else {}  # a random start
    est = aeroid.make_estimator(method, options)
    first, second = est.fit(windows, rng=3), est.fit(windows, rng=3)
    np.testing.assert_array_equal(first.theta, second.theta)
    for frame, flight in zip(before, windows, strict=True):
        assert frame.equals(flight.data)
    assert first.info["windows"] == ["w1", "w2"]


def _delayed_flight(scenario, tau):
    """A noise-free flight whose fins follow the logged (latched) deflection ``tau`` late:
    the model integrated at 0.25 ms through the delayed schedule (as
    tests/unit/test_output_error_inputs.py makes its delayed flight)."""
    from aeroid.flights import make_flight
    from aeroid.model import ForwardModel, Record, Schedule, constants

    clean = simulate_scenario(scenario, NoNoise(), rng=0)
    t, delta = clean.t, clean["delta"]
    schedule = Schedule.hold(t, delta).shifted(tau)
    record = Record.scheduled(schedule, t, None)
    model = ForwardModel(constants(scenario.airframe), record,
                         scenario.airframe.accel_positions, substeps=8)
    theta = scenario.coefficient_vector
    states = model.states(clean.states()[0], theta)[0]
    outputs = model.outputs_of(states[None], theta)[0]
    channels = {"t": t, "delta": delta}
    channels.update({name: outputs[:, j] for j, name in enumerate(model.output_names)})
    channels.update({name: states[:, j] for j, name in enumerate(aeroid.model.STATE_NAMES)})
    return make_flight(channels, scenario.airframe,  # the model's outputs in still air
                       {"true_coefficients": aeroid.model.as_dict(theta), "wind": "still"})


def test_each_window_gets_its_own_fin_delay():
    # two windows whose actuators lag by different delays: one shared delay cannot fit
    # both; a delay per window recovers each (the single flight's DELAY_ATOL_S, 1e-7 s)
    sc = reference_scenario()
    later = dataclasses.replace(sc, manoeuvre=dataclasses.replace(sc.manoeuvre,
                                                                  window_s=(6.0, 7.0)))
    taus = (0.0007, 0.0013)
    windows = Windows.of([_delayed_flight(sc, taus[0]), _delayed_flight(later, taus[1])])
    res = OutputErrorEstimator(estimate_delay=True).fit(windows, rng=1)
    assert res.success, res.message
    for name, tau in zip(windows.names, taus, strict=True):
        assert abs(res.info["window_parameters"][name]["delay_s"] - tau) < 1e-7
        assert res.info["window_parameter_stderr"][name]["delay_s"] > 0
    np.testing.assert_allclose(res.theta, aeroid.nominal(), rtol=RECOVERY_RTOL)
