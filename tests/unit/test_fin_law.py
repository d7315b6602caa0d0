"""The fin law: closed forms of the law and the actuator, and its open-loop schedule.

The schedule's switch instants are checked against closed forms (a roll angle the cubic
interpolation reproduces exactly) and against the true instants of a continuously
switched simulation (the simulator locates them in its RK4 integration to 1e-12 s, and
agrees with an event-driven solve_ivp to 2e-13 s: tests/unit/test_simulate.py).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from aeroid.errors import AirframeError
from aeroid.flights import GaussianNoise, load_scenario, simulate
from aeroid.model import FinLaw, RelayActuator, Schedule
from aeroid.model._law_schedule import SWITCH_TOL_S

DMAX = math.radians(8.0)
#: The scenario files of the studies.
DATA = Path(__file__).resolve().parents[2] / "studies" / "scenarios"
#: Located instants on a roll angle the cubic reproduces exactly: the bisection's width
#: plus rounding of the grid times.
EXACT_TOL_S = 2 * SWITCH_TOL_S
#: The spline's instants against the simulator's true ones on the continuous-relay
#: scenario (500 Hz, roll rate ~50 rad/s): measured 8.4e-10 s at most (32 switches).
#: The interpolated roll angle's error, not the root finding, sets this.
SPLINE_INSTANT_TOL_S = 2e-9
#: The Hermite interpolant with the noise-free Euler roll rate: measured 4.8e-10 s.
HERMITE_INSTANT_TOL_S = 1e-9
#: Knot values: the deflection levels are copied, not computed.
VALUE_TOL = 1e-15


def _law(**changes) -> FinLaw:
    return FinLaw(delta_max_rad=DMAX, **changes)


# The law ------------------------------------------------------------------------------
def test_switching_function_and_command_are_the_papers_law():
    law = _law(command_amplitude=0.5, command_phase_deg=60.0)
    phi = np.linspace(-7.0, 7.0, 1001)
    s = np.sin(2 * phi) + 0.5 * np.sin(phi + math.pi / 3)
    np.testing.assert_allclose(law.switching_function(phi), s, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(law(phi), np.where(s >= 0, DMAX, -DMAX))
    # sign(0) = +1: phi = 0 with A = 0 is a zero of sin(2 phi)
    assert _law(command_amplitude=0.0)(0.0) == DMAX
    assert _law(command_amplitude=0.0)(-1e-9) == -DMAX


def test_time_varying_amplitude_and_phase_are_piecewise_linear_in_time():
    law = _law(command_amplitude=((1.0, 0.2), (3.0, 1.0)),
               command_phase_deg=((0.0, 0.0), (2.0, 90.0)))
    t = np.array([0.0, 1.0, 2.0, 2.5, 3.0, 10.0])
    np.testing.assert_allclose(law.amplitude(t), [0.2, 0.2, 0.6, 0.8, 1.0, 1.0])
    np.testing.assert_allclose(np.degrees(law.phase_rad(t)), [0, 45, 90, 90, 90, 90])
    phi = 0.3
    expected = np.sin(0.6) + 0.6 * np.sin(0.3 + math.pi / 2)
    assert law.switching_function(phi, 2.0) == pytest.approx(expected, abs=1e-15)
    assert law.time_varying and not _law().time_varying
    with pytest.raises(ValueError, match="varies in time; give the time t"):
        law(0.3)


def test_relay_actuator_is_the_constant_fin_law():
    relay = RelayActuator(delta_max_rad=DMAX, command_amplitude=0.3,
                          command_phase_rad=math.radians(20.0))
    assert relay == _law(command_amplitude=0.3, command_phase_deg=20.0)


# The actuator -------------------------------------------------------------------------
def test_delay_shifts_every_switch():
    law = _law(delay_s=0.003)
    sched = law.actuate(0.0, DMAX, np.array([0.01, 0.02]), np.array([-DMAX, DMAX]))
    np.testing.assert_allclose(sched.times, [0.0, 0.013, 0.013, 0.023, 0.023], rtol=0,
                               atol=1e-15)
    np.testing.assert_array_equal(sched.values, [DMAX, DMAX, -DMAX, -DMAX, DMAX])


def test_rate_limit_makes_ramps_and_reverses_a_ramp_in_progress():
    rate_dps = 8000.0
    law = _law(rate_limit_dps=rate_dps)
    rate = math.radians(rate_dps)
    full = 2 * DMAX / rate  # 2 ms for the full swing
    # a full ramp down, then a switch back half-way through the next ramp down
    switch = np.array([0.01, 0.02, 0.03, 0.03 + full / 4])
    values = np.array([-DMAX, DMAX, -DMAX, DMAX])
    sched = law.actuate(0.0, DMAX, switch, values)
    at_reversal = DMAX - rate * full / 4
    expected = [(0.0, DMAX), (0.01, DMAX), (0.01 + full, -DMAX), (0.02, -DMAX),
                (0.02 + full, DMAX), (0.03, DMAX), (0.03 + full / 4, at_reversal),
                (0.03 + full / 4 + (DMAX - at_reversal) / rate, DMAX)]
    np.testing.assert_allclose(sched.times, [e[0] for e in expected], rtol=0, atol=1e-15)
    np.testing.assert_allclose(sched.values, [e[1] for e in expected], rtol=0, atol=1e-15)
    # the deflection is continuous and never faster than the limit
    slopes = np.diff(sched.values) / np.diff(sched.times)
    assert np.max(np.abs(slopes)) == pytest.approx(rate, rel=1e-9)


def test_a_switch_back_at_the_start_of_a_ramp_cancels_it():
    law = _law(rate_limit_dps=1000.0)
    sched = law.actuate(0.0, DMAX, np.array([0.01, 0.01]), np.array([-DMAX, DMAX]))
    np.testing.assert_array_equal(sched.at([0.0, 0.01, 0.02]), [DMAX, DMAX, DMAX])


# Switch instants on a roll angle with closed-form zeros -----------------------------
def test_switches_on_a_uniform_roll_are_the_closed_form_instants():
    # A = 0: sin(2 phi) switches at phi = k pi / 2; phi = w t + c is reproduced exactly
    law = _law(command_amplitude=0.0)
    w, c = 50.0, 0.3
    t = np.arange(0.0, 1.0 + 1e-12, 0.002)
    times, values = law.switches(t, w * t + c)
    k = np.arange(1, 40)
    exact = (k * math.pi / 2 - c) / w
    exact = exact[exact <= t[-1]]
    np.testing.assert_allclose(times, exact, rtol=0, atol=EXACT_TOL_S)
    # after phi = k pi/2 the sign of sin(2 phi) is (-1)^k
    np.testing.assert_array_equal(values, np.where(k[:exact.size] % 2, -DMAX, DMAX))


def test_wrapped_roll_angle_is_unwrapped():
    law = _law()
    t = np.arange(0.0, 0.5, 0.002)
    phi = 50.0 * t + 0.3
    wrapped = (phi + math.pi) % (2 * math.pi) - math.pi
    np.testing.assert_allclose(law.switches(t, wrapped)[0], law.switches(t, phi)[0],
                               rtol=0, atol=1e-12)


def test_two_switches_in_one_sample_interval():
    # phi rises above pi/2 and falls back within one 10 ms interval (a quadratic, which
    # the not-a-knot spline reproduces): sin(2 phi) switches twice, 2 sqrt(e/a) apart
    law = _law(command_amplitude=0.0)
    a, e, peak = 400.0, 0.0025, 0.105
    t = np.arange(0.06, 0.15 + 1e-12, 0.01)  # phi from pi/2 - 0.81 to pi/2 + e
    phi = math.pi / 2 + e - a * (t - peak) ** 2
    times, values = law.switches(t, phi)
    half = math.sqrt(e / a)  # 2.5 ms: both inside [0.10, 0.11]
    np.testing.assert_allclose(times, [peak - half, peak + half], rtol=0, atol=EXACT_TOL_S)
    np.testing.assert_array_equal(values, [-DMAX, DMAX])
    # read too coarsely (subdivisions = 1) the pair is invisible, as documented
    assert law.switches(t, phi, subdivisions=1)[0].size == 0


def test_switches_with_a_time_varying_law_against_brentq():
    law = _law(command_amplitude=((0.0, 0.2), (0.5, 1.5)),
               command_phase_deg=((0.0, 10.0), (0.5, 120.0)))
    w, c = 40.0, 0.1
    t = np.arange(0.0, 0.5 + 1e-12, 0.002)
    times, _ = law.switches(t, w * t + c)

    def s(when: float) -> float:
        return float(law.switching_function(w * when + c, when))

    fine = np.linspace(0.0, 0.5, 200_001)
    values = law.switching_function(w * fine + c, fine)
    k = np.flatnonzero((values[1:] >= 0) != (values[:-1] >= 0))
    exact = [brentq(s, fine[i], fine[i + 1], xtol=1e-14) for i in k]
    np.testing.assert_allclose(times, exact, rtol=0, atol=EXACT_TOL_S)


# The schedule: delay, rate, the start of the record ----------------------------------
def test_schedule_applies_delay_and_rate_limit_to_the_located_switches():
    law = _law(command_amplitude=0.0, delay_s=0.001, rate_limit_dps=8000.0)
    w, c = 50.0, 0.3
    t = np.arange(0.0, 0.2 + 1e-12, 0.002)
    sched = law.schedule(t, w * t + c)
    times, values = law.switches(t, w * t + c)
    expected = law.actuate(0.0, DMAX, times, values)
    np.testing.assert_array_equal(sched.times, expected.times)
    np.testing.assert_array_equal(sched.values, expected.values)
    assert sched.times[1] == pytest.approx((math.pi / 2 - c) / w + 0.001, abs=EXACT_TOL_S)


def test_schedule_before_the_first_delayed_switch():
    law = _law(command_amplitude=0.0, delay_s=0.004)
    t = np.arange(0.0, 0.1 + 1e-12, 0.002)
    phi = 50.0 * t + 0.3  # command +DMAX at t = 0, first switch at 0.02541 s
    # the logged deflection agrees with the law: it holds until the first delayed switch
    agree = law.schedule(t, phi, initial=DMAX)
    assert agree.times[1] == pytest.approx((math.pi / 2 - 0.3) / 50 + 0.004, abs=EXACT_TOL_S)
    np.testing.assert_array_equal(agree.at([0.0, 0.02]), [DMAX, DMAX])
    # it disagrees: a switch commanded within the delay before t[0] is placed half-way
    disagree = law.schedule(t, phi, initial=-DMAX)
    np.testing.assert_array_equal(disagree.times[:3], [0.0, 0.002, 0.002])
    np.testing.assert_array_equal(disagree.values[:3], [-DMAX, -DMAX, DMAX])
    assert law.schedule(t, phi).times.size == agree.times.size  # default: the law at t[0]
    # between the stops: a ramp in progress, heading for the law's command from t[0] on
    ramping = law.replace(rate_limit_dps=1000.0)
    moving = ramping.schedule(t, phi, initial=-0.5 * DMAX)
    reach = 1.5 * DMAX / ramping.rate_limit_radps
    np.testing.assert_allclose(moving.times[:2], [0.0, reach], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(moving.values[:2], [-0.5 * DMAX, DMAX])


def test_schedule_input_errors_are_one_line():
    law = _law()
    t = np.arange(5) * 0.002
    for args, kwargs, message in [
        ((t, t[:3]), {}, "same number"),
        ((t[::-1], t), {}, "increase strictly"),
        ((t, t * np.nan), {}, "finite"),
        ((t, t), {"subdivisions": 0}, "subdivisions must be an integer >= 1"),
        ((t, t), {"phi_rate": t[:2]}, "phi_rate needs one finite value per sample"),
        ((t, t), {"initial": math.inf}, "initial deflection must be finite"),
    ]:
        with pytest.raises(ValueError, match=message) as info:
            law.schedule(*args, **kwargs)
        assert "\n" not in str(info.value)


# Against the simulator's true switch instants ------------------------------------------
@pytest.fixture(scope="module")
def continuous_flights():
    scenario = load_scenario(None)
    manoeuvre = dataclasses.replace(scenario.manoeuvre, evaluation="continuous")
    args = (scenario.airframe, scenario.coefficient_vector, manoeuvre)
    return (manoeuvre.fin_law(scenario.airframe.delta_max_rad), simulate(*args, rng=0),
            simulate(*args, GaussianNoise(), rng=7))


def _euler_roll_rate(flight) -> np.ndarray:
    phi, theta = flight["phi"], flight["theta"]
    return flight["p"] + (flight["q"] * np.sin(phi) + flight["r"] * np.cos(phi)) * np.tan(theta)


def test_located_instants_against_the_simulators_true_instants(continuous_flights):
    law, clean, noisy = continuous_flights
    truth = np.array(clean.metadata["command_switches"]["t"])
    assert truth.size == 32
    for flight in (clean, noisy):  # the Gaussian noise model leaves phi untouched
        np.testing.assert_array_equal(flight["phi"], clean["phi"])
        times, values = law.switches(flight.t, flight["phi"])
        np.testing.assert_allclose(times, truth, rtol=0, atol=SPLINE_INSTANT_TOL_S)
        np.testing.assert_array_equal(values, clean.metadata["command_switches"]["delta"])
    hermite, _ = law.switches(clean.t, clean["phi"], phi_rate=_euler_roll_rate(clean))
    np.testing.assert_allclose(hermite, truth, rtol=0, atol=HERMITE_INSTANT_TOL_S)
    # with the noisy rates the Hermite interpolant is worse than the spline
    noisy_hermite, _ = law.switches(noisy.t, noisy["phi"], phi_rate=_euler_roll_rate(noisy))
    assert np.max(np.abs(noisy_hermite - truth)) > 10 * SPLINE_INSTANT_TOL_S


def test_schedule_equals_the_simulators_deflection(continuous_flights):
    law, clean, _ = continuous_flights
    sched = law.schedule(clean.t, clean["phi"], initial=clean["delta"][0])
    knots = clean.metadata["delta_knots"]
    truth = Schedule(np.array(knots["t"]), np.array(knots["delta"]))
    fine = np.linspace(clean.t[0], clean.t[-1], 200_001)
    # the deflections differ only within SPLINE_INSTANT_TOL_S of a switch
    differ = fine[sched.at(fine) != truth.at(fine)]
    switches = np.array(clean.metadata["command_switches"]["t"])
    assert differ.size <= 2 * switches.size
    assert all(np.min(np.abs(switches - when)) < SPLINE_INSTANT_TOL_S for when in differ)
    np.testing.assert_allclose(sched.at(clean.t), clean["delta"], rtol=0, atol=VALUE_TOL)


def test_fin_law_fields_are_checked():
    for kwargs, message in [
        ({"delta_max_rad": -0.1}, "fin law: delta_max_rad must be positive"),
        ({"delta_max_rad": True}, "fin law: delta_max_rad must be a finite number"),
        ({"delta_max_rad": DMAX, "delay_s": -1e-3}, "fin law: delay_s must be in [0, 1) s"),
        ({"delta_max_rad": DMAX, "rate_limit_dps": -5.0}, "rate_limit_dps must be positive"),
        ({"delta_max_rad": DMAX, "command_phase_deg": ((1.0, 0.0), (0.5, 1.0))},
         "times of the pairs must increase strictly"),
    ]:
        with pytest.raises(AirframeError) as info:
            FinLaw(**kwargs)
        assert message in str(info.value) and "\n" not in str(info.value)


def test_schedule_follows_a_delayed_rate_limited_fin():
    scenario = load_scenario(DATA / "delayed_relay.toml")
    law = scenario.airframe.fin_law
    flight = simulate(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                      rng=0)
    assert abs(flight["delta"][0]) < 0.9 * DMAX  # the window opens on a ramp
    sched = law.schedule(flight.t, flight["phi"], initial=flight["delta"][0])
    knots = flight.metadata["delta_knots"]
    truth = Schedule(np.array(knots["t"]), np.array(knots["delta"]))
    fine = np.linspace(flight.t[0], flight.t[-1], 200_001)
    # a ramp located SPLINE_INSTANT_TOL_S off is rate x that off (measured 3.5e-8 rad)
    tol = law.rate_limit_radps * SPLINE_INSTANT_TOL_S
    np.testing.assert_allclose(sched.at(fine), truth.at(fine), rtol=0, atol=tol)
    np.testing.assert_allclose(sched.at(flight.t), flight["delta"], rtol=0, atol=tol)
