"""Output-error's delay on a relay: a piecewise-smooth parameter (baselines/_oe_record.py).

A sample sees a switch's new deflection when the delayed switch is at or before it, so
the outputs jump where a switch crosses a sample instant. References: the record's own
sample values at the edges of :meth:`RecordModel.smooth_region`, a one-sided finite
difference inside the region, the optimality conditions of the held step, and a
noise-free suite log whose fin clock is skewed by two samples.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from suite_flights import declared_air

from aeroid.flights import SensorSuite, make_flight, reference_scenario, simulate_suite
from aeroid.model import OUTPUT_CHANNELS
from aeroid.reconstruction import reconstruct
from baselines._gauss_newton import SmoothRegion, held_step
from baselines.output_error import OutputErrorEstimator

#: Noise-free recovery of a 2 ms fin skew as the delay [s]: measured 7.8e-11 (seed 3).
DELAY_ATOL_S = 1e-8
#: Noise-free recovery of the coefficients with the delay: measured 7.9e-8 (seed 3).
RECOVERY_RTOL = 1e-6
#: The delay's sensitivity at an edge against a backward difference of 1e-8 s inside the
#: region (the difference's truncation and rounding, relative to the column's largest).
EDGE_FD_RTOL = 1e-4


@pytest.fixture(scope="module")
def delay_problem(clean_flight):
    est = OutputErrorEstimator(estimate_delay=True, compile_model=False)
    prob = est.problem(clean_flight)
    p = np.ones(prob.model.scale.size)
    return prob, p


def _at(model, p, tau):
    q = p.copy()
    q[model.n_graph] = tau / model.delay_scale
    return q


def test_smooth_region_edges_are_where_a_sample_value_changes(delay_problem):
    prob, p = delay_problem
    model, i = prob.model, prob.model.n_graph
    tau = 0.3 * model.delay_scale  # the held schedule's switches 0.3 into an interval
    q = _at(model, p, tau)
    region = model.smooth_region(q)
    inside = model.record(tau).delta
    for edge, across in ((region.lo, region.below), (region.hi, region.above)):
        assert np.array_equal(model.record(edge[i] * model.delay_scale).delta, inside)
        assert not np.array_equal(model.record(across[i] * model.delay_scale).delta, inside)
    # the held schedule switches on sample instants: 0.3 and 0.7 of a sample to the edges
    assert region.lo[i] * model.delay_scale == pytest.approx(0.0, abs=1e-9)
    assert region.hi[i] * model.delay_scale == pytest.approx(model.delay_scale, rel=1e-6)
    others = np.arange(p.size) != i
    assert np.all(np.isinf(region.lo[others])) and np.all(np.isinf(region.hi[others]))


def test_delay_sensitivity_at_an_edge_equals_a_one_sided_difference(delay_problem):
    # tau = 0 on a held schedule: every switch on a sample instant, the upper edge
    prob, p = delay_problem
    model, i = prob.model, prob.model.n_graph
    q = _at(model, p, 0.0)
    assert model.smooth_region(q).hi[i] == q[i]
    y, J = model.outputs_jacobian(q)
    h = 1e-8 / model.delay_scale
    back = q.copy()
    back[i] -= h
    fd = ((y - model.outputs(back)) / h).T
    np.testing.assert_allclose(J[:, :, i], fd, rtol=0,
                               atol=EDGE_FD_RTOL * np.abs(J[:, :, i]).max())


def test_held_step_is_the_quadratic_minimum_with_the_crossing_parameter_at_its_edge():
    rng = np.random.default_rng(5)
    a = rng.standard_normal((4, 4))
    system, g, p = a @ a.T + 4 * np.eye(4), rng.standard_normal(4), np.zeros(4)
    step = np.linalg.solve(system, g)
    inf = np.full(4, np.inf)
    lo, hi = -inf.copy(), inf.copy()
    hi[2] = 0.5 * step[2] if step[2] > 0 else np.inf
    lo[2] = 0.5 * step[2] if step[2] < 0 else -np.inf
    held, out = held_step(system, g, p, step, SmoothRegion(lo, hi, lo, hi))
    assert out.tolist() == [False, False, True, False]
    assert held[2] == pytest.approx(0.5 * step[2])
    free = ~out
    np.testing.assert_allclose((system @ held - g)[free], 0.0, atol=1e-12)
    assert held_step(system, g, p, 0.1 * step, SmoothRegion(lo, hi, lo, hi)) is None


def test_noise_free_suite_with_a_fin_skew_converges_with_the_delay_and_is_refused_without():
    # the fin log claims every switch two samples (2 ms) before it happened (noise-free,
    # this converged before the delay's smooth region too: 23 iterations, same numbers)
    scenario = reference_scenario()
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         SensorSuite(accel_noise_mps2=0.0, gyro_noise_radps=0.0), rng=3)
    imu = sim.log["imu"]
    skew = 0.002
    shift = round(skew / (imu.t[1] - imu.t[0]))
    delta = sim.truth["delta"]
    logged = np.concatenate([delta[shift:], np.repeat(delta[-1], shift)])
    channels = {"t": imu.t, **{c: imu.channels[c] for c in OUTPUT_CHANNELS},
                **{c: sim.truth[c] for c in ("u", "v", "w", "phi", "theta", "psi")},
                "delta": logged}
    flight = make_flight(channels, scenario.airframe, declared_air(sim))  # still air
    options = {"imu_errors": "bias+scale"}
    fit = OutputErrorEstimator(**options, estimate_delay=True).fit(flight, rng=0)
    assert fit.success, fit.message
    assert abs(fit.info["delay_s"] - skew) < DELAY_ATOL_S
    np.testing.assert_allclose(fit.theta, scenario.coefficient_vector, rtol=RECOVERY_RTOL)
    without = OutputErrorEstimator(**options).fit(flight, rng=0)
    assert not without.success
    assert np.max(np.abs(without.theta / scenario.coefficient_vector - 1)) > 0.01


def test_suite_log_with_a_fin_skew_on_the_sample_grid_converges_at_the_edge():
    # sensor seed 1, the fin clock 2 ms early: the delay's optimum sits where the switches
    # cross sample instants; before the smooth region: "max_iterations (150) reached" with
    # the delay at 1.99988 ms (benchmarks/suite_fin_skew.py)
    scenario = reference_scenario()
    log = simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         SensorSuite(), rng=1).log
    fin = log.groups["fin"]
    skew = 0.002
    log = dataclasses.replace(log, groups={**log.groups,
                                           "fin": dataclasses.replace(fin, t=fin.t - skew)})
    flight = reconstruct(log).to_flight(imu="raw")
    fit = OutputErrorEstimator(imu_errors="bias+scale", estimate_initial_velocity=True,
                               initial_velocity_prior="flight", estimate_delay=True,
                               max_iterations=150).fit(flight, rng=0)
    assert fit.success, fit.message
    assert "at an edge" in fit.message
    # at the edge: within the margin of a sample instant, a switch on it
    assert abs(fit.info["delay_s"] - skew) < 1e-8
    assert abs(fit.info["delay_s"] - skew) < 0.01 * fit.info["delay_stderr_s"]
