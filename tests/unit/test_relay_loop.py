"""The simulator's relay switched continuously or at its own clock, with delay and rate limit.

Independent reference: the same equations (:func:`aeroid.model.state_derivative`)
integrated by :func:`scipy.integrate.solve_ivp` (DOP853, rtol 1e-13) as a hybrid system:
a terminal event on the switching function stops the integration at each switch, the
actuator (its own bookkeeping of delays and ramps, not aeroid's) breaks it at every
change of slope, and the integration restarts from there.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from aeroid.flights import read_flight, simulate, simulate_truth
from aeroid.model import N_STATE, FinLaw, Schedule, constants, propagate, state_derivative

#: Switch instants, simulator vs event-located solve_ivp: both locate zeros to ~1e-13 s
#: (the simulator to 1e-12 s by brentq); measured 1.5e-13 s. 1e-11 s leaves room for the
#: trajectories' difference (below).
SWITCH_TOL_S = 1e-11
#: States at the samples relative to each channel's max |value|: the truth's RK4 at
#: 0.25 ms against DOP853 at rtol 1e-13; measured 3.9e-9 (no delay) and 4.4e-9 (1 ms
#: delay, 8000 deg/s), 2.3e-11 at 32 substeps (the RK4 error, h^4).
STATE_RTOL = 1e-8
#: Two integrations of the same step sequence (chunks vs one pass; control at the log
#: clock vs the latched path): rounding only.
SAME_STEPS_RTOL = 1e-12
#: Window of the reference comparisons [s] (from the reference flight's state at 5 s).
WINDOW_S = (0.0, 0.5)


def reference_loop(law: FinLaw, coefficients, const, x0, t_end: float, t_samples,
                   control_rate_hz: float | None = None):
    """The relay loop as a hybrid system for solve_ivp; returns (states, switch instants)."""
    dmax, rate, tau = law.delta_max_rad, law.rate_limit_radps, law.delay_s
    sign = bool(law.switching_function(x0[6], 0.0) >= 0)
    position, slope, target = (dmax if sign else -dmax), 0.0, (dmax if sign else -dmax)
    pending: list[tuple[float, float]] = []  # (time the fin starts to move, target)
    clock = (np.arange(1, int(t_end * control_rate_hz) + 1) / control_rate_hz
             if control_rate_hz else np.array([]))
    t, x = 0.0, np.array(x0, dtype=float)
    out = np.full((len(t_samples), N_STATE), np.nan)
    switches = []

    def rhs(when, state, p0, t0, rate_now):
        return state_derivative(state, p0 + rate_now * (when - t0), coefficients, const)

    def crossing(when, state, *args):
        return law.switching_function(state[6], when)

    while t < t_end:
        reach = t + abs(target - position) / rate if slope else np.inf
        ticks = clock[clock > t + 1e-15]
        stop = min(reach, *(p[0] for p in pending), ticks[0] if ticks.size else np.inf, t_end)
        crossing.terminal, crossing.direction = True, (-1 if sign else 1)
        sol = solve_ivp(rhs, (t, stop), x, method="DOP853", rtol=1e-13, atol=1e-12,
                        events=None if control_rate_hz else crossing,
                        args=(position, t, slope), dense_output=True)
        end = sol.t[-1]
        inside = (t_samples >= t) & (t_samples <= end)
        if inside.any():
            out[inside] = sol.sol(t_samples[inside]).T
        position += slope * (end - t)
        x, t = sol.y[:, -1], end
        if control_rate_hz is None and sol.status == 1:
            x = sol.y_events[0][0]
            sign = not sign
            switches.append(t)
            pending.append((t + tau, dmax if sign else -dmax))
        elif ticks.size and t == ticks[0] and (law.switching_function(x[6], t) >= 0) != sign:
            sign = not sign
            switches.append(t)
            pending.append((t + tau, dmax if sign else -dmax))
        if slope and t >= reach - 1e-15:
            position, slope = target, 0.0
        while pending and pending[0][0] <= t + 1e-15:
            target = pending.pop(0)[1]
            position, slope = ((target, 0.0) if np.isinf(rate)
                               else (position, rate * np.sign(target - position)))
    return out, np.array(switches)


@pytest.fixture(scope="module")
def start(reference_scenario, clean_flight):
    """The reference scenario from the state at t = 5 s, recorded over WINDOW_S."""
    return dataclasses.replace(reference_scenario.manoeuvre, window_s=WINDOW_S,
                               initial_state=tuple(clean_flight.states()[0]))


def _compare(scenario, manoeuvre):
    truth = simulate_truth(scenario.airframe, scenario.coefficient_vector, manoeuvre)
    law = manoeuvre.fin_law(scenario.airframe.delta_max_rad)
    states, switches = reference_loop(
        law, scenario.coefficient_vector, constants(scenario.airframe),
        np.array(manoeuvre.initial_state), WINDOW_S[1], truth.t,
        control_rate_hz=manoeuvre.control_rate_hz)
    scale = np.max(np.abs(states), axis=0)
    error = np.max(np.abs(truth.states - states), axis=0) / np.where(scale > 0, scale, 1.0)
    return truth, switches, error


@pytest.mark.parametrize("actuator", [
    {}, {"delay_s": 0.001, "rate_limit_dps": 8000.0}, {"delay_s": 0.0013},
    {"rate_limit_dps": 600.0},  # 27 ms full swing: ramps reverse before they end
])
def test_continuous_relay_against_event_located_solve_ivp(reference_scenario, start, actuator):
    manoeuvre = dataclasses.replace(start, evaluation="continuous", **actuator)
    truth, switches, error = _compare(reference_scenario, manoeuvre)
    assert switches.size == truth.command_t.size >= 15
    np.testing.assert_allclose(truth.command_t, switches, rtol=0, atol=SWITCH_TOL_S)
    assert error.max() < STATE_RTOL, error
    # the recorded deflection is the schedule at the samples
    np.testing.assert_array_equal(truth.delta, truth.schedule.at(truth.t))
    throw = reference_scenario.airframe.delta_max_rad
    reversed_ramps = np.sum(np.abs(np.abs(truth.schedule.values) - throw) > 1e-12)
    assert (reversed_ramps > 2) == (actuator.get("rate_limit_dps") == 600.0)


def test_control_rate_relay_against_solve_ivp(reference_scenario, start):
    # 1300 Hz: the relay's instants fall between the truth's grid points
    manoeuvre = dataclasses.replace(start, evaluation="control_rate", control_rate_hz=1300.0,
                                    delay_s=0.0005)
    truth, switches, error = _compare(reference_scenario, manoeuvre)
    np.testing.assert_allclose(truth.command_t, switches, rtol=0, atol=1e-15)
    ticks = truth.command_t * 1300.0
    np.testing.assert_allclose(ticks, np.round(ticks), rtol=0, atol=1e-9)
    assert error.max() < STATE_RTOL, error


def test_control_at_the_log_clock_is_the_latched_relay(reference_scenario):
    latched = reference_scenario.manoeuvre
    clocked = dataclasses.replace(latched, evaluation="control_rate", control_rate_hz=500.0)
    args = (reference_scenario.airframe, reference_scenario.coefficient_vector)
    a, b = simulate_truth(*args, latched), simulate_truth(*args, clocked)
    scale = np.max(np.abs(a.states), axis=0)
    assert np.max(np.abs(a.states - b.states) / np.where(scale > 0, scale, 1)) < SAME_STEPS_RTOL
    np.testing.assert_array_equal(a.delta, b.delta)
    np.testing.assert_allclose(a.command_t, b.command_t, rtol=0, atol=1e-12)


def test_the_recorded_knots_reproduce_the_flight(reference_scenario, start):
    manoeuvre = dataclasses.replace(start, window_s=(0.2, 0.5), evaluation="continuous",
                                    delay_s=0.001, rate_limit_dps=8000.0)
    flight = simulate(reference_scenario.airframe, reference_scenario.coefficient_vector,
                      manoeuvre, rng=0)
    knots = flight.metadata["delta_knots"]
    schedule = Schedule(np.array(knots["t"]), np.array(knots["delta"]))
    np.testing.assert_array_equal(schedule.at(flight.t), flight["delta"])
    # the truth's own steps: one RK4 step per piece of every 0.25 ms grid step
    substeps = manoeuvre.truth_substeps
    grid = flight.t[0] + np.arange((flight.n_samples - 1) * substeps + 1) * (flight.dt / substeps)
    states = propagate(flight.states()[0], reference_scenario.coefficient_vector,
                       schedule.segments(grid), flight.dt / substeps,
                       constants(reference_scenario.airframe))[0, ::substeps]
    scale = np.max(np.abs(states), axis=0)
    error = np.max(np.abs(states - flight.states()), axis=0) / np.where(scale > 0, scale, 1)
    assert error.max() < SAME_STEPS_RTOL
    switches = flight.metadata["command_switches"]
    assert len(switches["t"]) > 5 and all(0.2 <= t <= 0.5 for t in switches["t"])


def test_time_varying_law_latched(reference_scenario, start):
    manoeuvre = dataclasses.replace(start, command_amplitude=((0.0, 0.2), (0.5, 1.2)),
                                    command_phase_deg=((0.0, 0.0), (0.5, 90.0)))
    truth = simulate_truth(reference_scenario.airframe, reference_scenario.coefficient_vector,
                           manoeuvre)
    law = manoeuvre.fin_law(reference_scenario.airframe.delta_max_rad)
    np.testing.assert_array_equal(truth.delta, law(truth.states[:, 6], truth.t))


def test_continuous_flight_survives_its_file(reference_scenario, start, tmp_path):
    manoeuvre = dataclasses.replace(start, command_amplitude=((0.0, 0.5), (1.0, 0.7)),
                                    evaluation="continuous", rate_limit_dps=8000.0)
    airframe = reference_scenario.airframe
    airframe = airframe.replace(fin_law=manoeuvre.fin_law(airframe.delta_max_rad))
    flight = simulate(airframe, reference_scenario.coefficient_vector, manoeuvre, rng=0)
    assert flight.metadata["actuator"]["command_amplitude"] == [[0.0, 0.5], [1.0, 0.7]]
    assert "command_amplitude" not in flight.metadata["manoeuvre"]
    flight.write(tmp_path / "f.csv")
    again = read_flight(tmp_path / "f.csv")
    assert again.airframe == flight.airframe and again.airframe.fin_law.time_varying
    assert again.metadata["delta_knots"] == flight.metadata["delta_knots"]
    assert again.metadata["actuator"]["evaluation"] == "continuous"
