"""Output-error, EKF and the floor with the model's inputs in time: a delayed actuator,
switch instants between samples, a density that changes in the window.

The flights are made here with the model integrated at 0.25 ms through the exact inputs
(switches inside the intervals, the density interpolated), and logged as a user's logger
would: the deflection at the sample instants, a density channel.
"""

from __future__ import annotations

import numpy as np
import pytest

import aeroid
from aeroid.flights import make_flight
from aeroid.model import (
    EXOGENOUS,
    ForwardModel,
    Record,
    Schedule,
    constants,
    exogenous_table,
)

#: Noise-free recovery of the coefficients, output-error with the right inputs (2 RK4
#: substeps against the 8 of the flight: the discretisation error, measured <= 3e-5).
RECOVERY_RTOL = 1e-4
#: The same for the EKF: its one 2 ms RK4 step per sample against the flight's 0.25 ms,
#: with no process noise to absorb the difference (measured 1.2e-4).
FILTER_RECOVERY_RTOL = 1e-3
#: The delay [s] from a noise-free flight (the discretisation error again, measured 4e-9).
DELAY_ATOL_S = 1e-7
#: With the wrong inputs some coefficient is off by more than this (measured: Czq 5-60 %).
BIAS_FLOOR = 0.01


def _flight(scenario, schedule: Schedule, *, rho: np.ndarray | None = None,
            logged_delta: np.ndarray | None = None, substeps: int = 8):
    """A noise-free flight of the reference airframe driven by ``schedule``."""
    clean = aeroid.simulate_scenario(scenario, aeroid.NoNoise(), rng=0)
    t = clean.t
    const = constants(scenario.airframe)
    table = None if rho is None else exogenous_table(const, t.size, {"rho": rho})
    record = Record.scheduled(schedule, t, table)
    model = ForwardModel(const, record, scenario.airframe.accel_positions, substeps=substeps)
    theta = scenario.coefficient_vector
    states = model.states(clean.states()[0], theta)[0]
    outputs = model.outputs_of(states[None], theta)[0]
    channels = {"t": t, "delta": record.delta if logged_delta is None else logged_delta}
    for j, name in enumerate(model.output_names):
        channels[name] = outputs[:, j]
    for j, name in enumerate(aeroid.model.STATE_NAMES):
        channels[name] = states[:, j]
    airframe = scenario.airframe
    if rho is not None:
        channels["rho"] = rho
        airframe = airframe.replace(altitude_m=None, given_density_kgm3=None,
                                    atmosphere_channel="rho")
    knots = {"t": schedule.times.tolist(), "delta": schedule.values.tolist()}
    return make_flight(channels, airframe, {"true_coefficients": aeroid.model.as_dict(theta),
                                            "delta_knots": knots, "wind": "still"})


def _worst(result, scenario) -> float:
    return float(np.max(np.abs(result.theta / scenario.coefficient_vector - 1.0)))


@pytest.fixture(scope="module")
def commanded(reference_scenario):
    clean = aeroid.simulate_scenario(reference_scenario, aeroid.NoNoise(), rng=0)
    return clean.t, clean["delta"]


def test_output_error_estimates_an_actuator_delay(reference_scenario, commanded):
    # the logger records the commanded (latched) deflection; the fins follow 0.7 ms later
    t, delta = commanded
    tau = 0.0007
    flight = _flight(reference_scenario, Schedule.hold(t, delta).shifted(tau),
                     logged_delta=delta)
    fit = aeroid.make_estimator("output-error", {"estimate_delay": True}).fit(flight, rng=1)
    assert fit.success, fit.message
    assert abs(fit.info["delay_s"] - tau) < DELAY_ATOL_S
    assert fit.info["delay_stderr_s"] > 0
    assert _worst(fit, reference_scenario) < RECOVERY_RTOL
    known = aeroid.make_estimator("output-error", {"delay_s": tau}).fit(flight, rng=1)
    assert _worst(known, reference_scenario) < RECOVERY_RTOL
    ignored = aeroid.make_estimator("output-error").fit(flight, rng=1)
    assert _worst(ignored, reference_scenario) > BIAS_FLOOR


def test_switches_between_samples_need_the_events_input(reference_scenario, commanded):
    # a relay switching at instants spread uniformly inside the sample intervals
    t, delta = commanded
    rng = np.random.default_rng(4)
    change = np.flatnonzero(np.diff(delta) != 0.0) + 1
    times = t[change] - rng.uniform(0.05, 0.95, change.size) * (t[1] - t[0])
    schedule = Schedule.events(delta[0], times, delta[change])
    flight = _flight(reference_scenario, schedule)
    # measured: output-error events 6e-6, held Czq 80 %; EKF events 1.2e-4, held Clp 600 %
    # (no process noise: nothing absorbs the wrong input, and the fit check flags it)
    for name, tol in (("output-error", RECOVERY_RTOL), ("ekf", FILTER_RECOVERY_RTOL)):
        events = aeroid.make_estimator(name, {"input": "events"}).fit(flight, rng=1)
        held = aeroid.make_estimator(name, {"input": "hold"}).fit(flight, rng=1)
        assert _worst(events, reference_scenario) < tol, name
        assert _worst(held, reference_scenario) > 100 * _worst(events, reference_scenario)
        assert events.success and not held.success, name
    oe_held = aeroid.make_estimator("output-error").fit(flight, rng=1)
    assert _worst(oe_held, reference_scenario) > BIAS_FLOOR
    # ... and the held fit does not pass for a good one: the fit check flags it
    assert not oe_held.success and "does not fit the data" in oe_held.message
    # midpoint sits in between: its switch error is uniform within half an interval
    mid = aeroid.make_estimator("output-error", {"input": "midpoint"}).fit(flight, rng=1)
    assert _worst(mid, reference_scenario) < _worst(oe_held, reference_scenario)


def test_a_changing_density_is_used_from_its_channel(reference_scenario, commanded):
    t, delta = commanded
    const = constants(reference_scenario.airframe)
    rho = const.rho * (1.0 - 0.03 * (t - t[0]))  # a climb: -3 % over the window
    flight = _flight(reference_scenario, Schedule.hold(t, delta), rho=rho)
    for name in ("output-error", "equation-error"):
        fit = aeroid.make_estimator(name).fit(flight, rng=1)
        assert fit.success, fit.message
        tol = RECOVERY_RTOL if name == "output-error" else 2e-3  # equation error: SG bias
        assert _worst(fit, reference_scenario) < tol, name
    # the same flight with one density (the window's mean) is biased
    mean = flight.airframe.replace(atmosphere_channel=None,
                                   given_density_kgm3=float(np.mean(rho)))
    constant = make_flight({c: flight[c] for c in flight.channels if c != "rho"}, mean,
                           {"wind": "still"})  # still air, as flown
    biased = aeroid.make_estimator("output-error").fit(constant, rng=1)
    assert _worst(biased, reference_scenario) > 3e-3


def test_floor_uses_the_inputs(reference_scenario, commanded):
    t, delta = commanded
    rho = constants(reference_scenario.airframe).rho * (1.0 - 0.03 * (t - t[0]))
    flight = _flight(reference_scenario, Schedule.hold(t, delta), rho=rho)
    per_sample = aeroid.cramer_rao_sd(flight, aeroid.GaussianNoise(), positions="estimator")
    assert np.all(np.isfinite(per_sample))
    # lower density, less dynamic pressure, less information: a larger floor than at the
    # density of the window's start held throughout
    start = flight.airframe.replace(atmosphere_channel=None, given_density_kgm3=float(rho[0]))
    held = make_flight({c: flight[c] for c in flight.channels if c != "rho"}, start,
                       flight.metadata)
    fixed = aeroid.cramer_rao_sd(held, aeroid.GaussianNoise(), positions="estimator")
    assert np.all(per_sample > fixed)
    assert "rho" in EXOGENOUS
