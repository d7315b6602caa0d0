"""pyswarms baseline: seeding without global-state leaks, objectives, silence."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.optimize

import aeroid
from aeroid.estimation import _objectives as objectives
from aeroid.estimation import _reconstruct as rc
from aeroid.flights._noise import PaperNoise
from aeroid.flights._scenario import reference_scenario
from aeroid.flights._simulate import simulate_scenario
from baselines.pyswarms_gbest import PyswarmsEstimator, seeded_global_state

#: A cheap budget: the properties tested do not depend on convergence.
CHEAP = {"n_particles": 12, "n_iterations": 8}


@pytest.fixture(scope="module")
def flight():
    fl = simulate_scenario(reference_scenario(), PaperNoise(), rng=3)
    prior = tuple(aeroid.nominal() * np.array([1.2, 0.8, 1.2, 0.8, 1.2, 0.8, 1.2, 0.8, 1.2]))
    return dataclasses.replace(fl, airframe=fl.airframe.replace(prior=prior))


def _global_state_equal(a, b):
    return a[0] == b[0] and np.array_equal(a[1], b[1]) and a[2:] == b[2:]


def test_seeded_context_restores_global_state():
    before = np.random.get_state()  # noqa: NPY002 - the point of the test
    with seeded_global_state(np.random.default_rng(1)):
        inside = np.random.random(3)  # noqa: NPY002
    assert _global_state_equal(before, np.random.get_state())  # noqa: NPY002
    with seeded_global_state(np.random.default_rng(1)):
        again = np.random.random(3)  # noqa: NPY002
    np.testing.assert_array_equal(inside, again)


def test_same_seed_same_result_and_no_global_leak(flight):
    est = PyswarmsEstimator(**CHEAP)
    before = np.random.get_state()  # noqa: NPY002
    a = est.fit(flight, rng=5)
    assert _global_state_equal(before, np.random.get_state())  # noqa: NPY002
    np.random.seed(12345)  # noqa: NPY002 - a caller's global state must not matter
    b = est.fit(flight, rng=5)
    c = est.fit(flight, rng=6)
    assert a.success and b.success
    np.testing.assert_array_equal(a.theta, b.theta)
    assert not np.array_equal(a.theta, c.theta)


def test_ebm_objective_is_aeroids_and_bounded_by_closed_form(flight):
    res = PyswarmsEstimator(n_particles=30, n_iterations=30).fit(flight, rng=0)
    cost = objectives.ebm_cost(flight, rc.reconstruct(flight))
    # the reported cost is aeroid's EBM cost at the answer ...
    np.testing.assert_allclose(res.cost, cost(res.theta), rtol=1e-10)
    # ... no lower than the closed-form minimum, and no worse than the prior (a particle)
    assert cost.cost_min <= res.cost <= cost(flight.airframe.prior_vector())
    bounds = aeroid.prior_bounds(flight.airframe)
    assert np.all((res.theta >= bounds[:, 0]) & (res.theta <= bounds[:, 1]))
    assert res.history["axis"] == "iteration"
    assert np.all(np.diff(res.history["cost"]) <= 0)  # global best never worsens
    assert res.n_evaluations == 30 * 30


#: Polished vs the BVLS optimum (test_polish.py: measured <= 2e-9 of the box's width).
POLISH_THETA_TOL = 1e-8


def test_polish_on_the_ebm_objective_reaches_its_bounded_optimum(flight):
    """From a cheap swarm: the bounded least-squares optimum of aeroid's EBM cost
    (scipy BVLS on the cost's X, y, weights), which the swarm alone misses."""
    cost = objectives.ebm_cost(flight, rc.reconstruct(flight))
    bounds = aeroid.prior_bounds(flight.airframe)
    sw = np.sqrt(cost.weights.reshape(-1) / cost.n_samples)
    scale = np.abs(bounds).max(axis=1)
    best = scipy.optimize.lsq_linear(
        cost.X.reshape(-1, cost.n_params) * sw[:, None] * scale, cost.y.reshape(-1) * sw,
        bounds=(bounds[:, 0] / scale, bounds[:, 1] / scale), method="bvls", tol=1e-14).x * scale
    width = bounds[:, 1] - bounds[:, 0]
    plain = PyswarmsEstimator(**CHEAP).fit(flight, rng=0)
    res = PyswarmsEstimator(polish=True, **CHEAP).fit(flight, rng=0)
    assert np.max(np.abs(plain.theta - best) / width) > 1e-2
    assert np.all(np.abs(res.theta - best) <= POLISH_THETA_TOL * width)
    np.testing.assert_allclose(res.cost, cost.direct(best), rtol=1e-9)
    assert res.info["polish"]["swarm_cost"] == plain.cost > res.cost
    assert "polished" in res.message


def test_polish_on_the_eam_objective_fits_the_initial_rates(flight):
    res = PyswarmsEstimator(objective="eam", polish=True, **CHEAP).fit(flight, rng=0)
    eam = objectives.OutputErrorCost(flight)
    state0 = res.info["polish"]["state0"]
    r = eam.residuals(res.theta, state0)
    np.testing.assert_allclose(res.cost, r @ r, rtol=1e-12)
    assert res.cost < res.info["polish"]["swarm_cost"]
    assert res.success, res.message


def test_eam_objective_runs(flight):
    res = PyswarmsEstimator(objective="eam", **CHEAP).fit(flight, rng=0)
    # a cheap swarm ends short of the optimum: the fit check judges it, from its residuals
    ratio = res.info["fit_check"]["ratio"]
    assert res.success == (max(ratio.values()) <= 3.0)
    eam = objectives.OutputErrorCost(flight)
    np.testing.assert_allclose(res.cost, eam(res.theta), rtol=1e-10)


def test_pyswarms_prints_nothing_and_leaves_logging_alone(flight, capsys, caplog, tmp_path,
                                                         monkeypatch):
    import logging

    monkeypatch.chdir(tmp_path)
    root = logging.getLogger()
    handlers, level = list(root.handlers), root.level
    PyswarmsEstimator(**CHEAP).fit(flight, rng=0)
    out = capsys.readouterr()
    assert out.out == "" and out.err == ""
    assert not [r for r in caplog.records if r.name.startswith("pyswarms")]
    assert root.handlers == handlers and root.level == level
    assert not (tmp_path / "report.log").exists()


def test_options_are_checked():
    with pytest.raises(aeroid.EstimatorError, match="objective"):
        PyswarmsEstimator.from_options({"objective": "xyz"})
    with pytest.raises(aeroid.EstimatorError, match="n_particles"):
        PyswarmsEstimator.from_options({"n_particles": "1"})
