"""The paper's estimators: noise-free recovery, PSO vs closed form, history and info."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize

from aeroid.errors import EstimatorError
from aeroid.estimation import EDGE_FRACTION, make_estimator, prior_bounds
from aeroid.estimation import _eam as eam
from aeroid.estimation._objectives import ebm_cost, sebm_costs
from aeroid.estimation._reconstruct import reconstruct
from aeroid.model import N_STATE
from aeroid.model._coefficients import NAMES

#: Noise-free EBM-PSO / SEBM-PSO with the paper's relative weighting, |error| in % per
#: coefficient (Cx ... Cmq). (On noise-free data the noise weighting's per-channel sd
#: estimates are round-off artefacts spanning 1e10, which makes the 9-D swarm's answer
#: depend on round-off; it is checked on noisy data below.) The floor is the PSO's
#: convergence (the reconstruction errs by < 1e-3 %, test_objectives): over PSO seeds
#: 1-12 the 9-D EBM-PSO (450 x 200) erred at most 0.05/0.06/0.06/0.61/0.82/1.02/0.19/
#: 0.05/0.79 %; the SEBM sub-problems (1-3-D) reach the closed form (<= 0.006 %).
#: Margin about x3.
EBM_NOISE_FREE_TOL_PCT = np.array([0.15, 0.2, 0.2, 2.0, 2.5, 3.0, 0.6, 0.15, 2.5])
SEBM_NOISE_FREE_TOL_PCT = np.full(len(NAMES), 0.02)
#: Noise-free EAM-PSO at a reduced swarm (100 x 100, random start, no warm start), with
#: the paper's relative weighting (eq. 23): on noise-free data the noise weighting's
#: per-channel sd estimates are round-off-level artefacts (p is smooth to 1e-9), so
#: one channel dominates. The floor is PSO convergence in a 9-D output-error landscape.
#: Measured over PSO seeds 1-3 and two RK4 kernel builds (round-off changes the swarm's
#: path): Cx <= 0.07 %, Cza, Czd, Cma, Cmd <= 2.8 %, Cmq <= 2.9 %, Cl0, Clp <= 6.5 %,
#: Czq <= 16.8 % (its term is 1.6 % of F_AZ: the landscape is flat along it). Margin
#: about x2; the slow test checks the paper configuration.
EAM_REDUCED_TOL_PCT = np.array([0.2, 6.0, 6.0, 35.0, 15.0, 15.0, 6.0, 6.0, 10.0])
EAM_REDUCED = {"n_particles": 100, "n_iterations": 100, "weighting": "relative"}
#: Full paper configuration (450 x 200), relative weighting (slow test): at least as
#: converged as the reduced swarm; measured with noise weighting 0.004-1.7 % except Czq
#: (1.2 % and 27 % for PSO seeds 1, 2: flat along Czq).
EAM_FULL_TOL_PCT = np.array([0.1, 3.0, 5.0, 35.0, 8.0, 8.0, 3.0, 3.0, 5.0])
#: PSO final cost vs the box-constrained least-squares optimum of the same objective.
CLOSED_FORM_RTOL = 1e-3
SEED = 1


def _bounded_solution(cost, bounds: np.ndarray) -> np.ndarray:
    """Minimiser of the weighted least-squares cost over the box (scipy BVLS)."""
    sw = np.sqrt(cost.weights.reshape(-1) / cost.n_samples)
    A = cost.X.reshape(-1, cost.n_params) * sw[:, None]
    b = cost.y.reshape(-1) * sw
    scale = np.abs(bounds).max(axis=1)
    res = scipy.optimize.lsq_linear(A * scale, b, bounds=(bounds[:, 0] / scale,
                                                          bounds[:, 1] / scale),
                                    method="bvls", tol=1e-14)
    return res.x * scale


def _bounded_optimum(cost, bounds: np.ndarray) -> float:
    """Minimum of the weighted least-squares cost over the box."""
    return float(cost.direct(_bounded_solution(cost, bounds)))


@pytest.fixture(scope="module")
def paper_results(paper_flight):
    return {m: make_estimator(m).fit(paper_flight, rng=SEED) for m in ("ebm-pso", "sebm-pso")}


@pytest.mark.parametrize(("method", "tol"), [("ebm-pso", EBM_NOISE_FREE_TOL_PCT),
                                             ("sebm-pso", SEBM_NOISE_FREE_TOL_PCT)])
def test_noise_free_ebm_recovers_truth(clean_flight, method, tol) -> None:
    result = make_estimator(method, {"weighting": "relative"}).fit(clean_flight, rng=SEED)
    assert result.success, result.message
    err = result.relative_error_pct(clean_flight.true_coefficients)
    assert np.all(err < tol), err


def test_noise_free_eam_recovers_truth_reduced_swarm(clean_flight) -> None:
    result = make_estimator("eam-pso", EAM_REDUCED).fit(clean_flight, rng=SEED)
    err = result.relative_error_pct(clean_flight.true_coefficients)
    # noise-free: the reduced swarm's residuals are several times the 0.1 % resolution
    # of the fit check, which says so (issue 11: the PSO does not reach its optimum)
    ratio = result.info["fit_check"]["ratio"]
    assert result.success == (max(ratio.values()) <= 3.0)
    assert np.all(err < EAM_REDUCED_TOL_PCT), err


@pytest.mark.slow
def test_noise_free_eam_recovers_truth_paper_config(clean_flight) -> None:
    result = make_estimator("eam-pso", {"weighting": "relative"}).fit(clean_flight, rng=SEED)
    err = result.relative_error_pct(clean_flight.true_coefficients)
    assert np.all(err < EAM_FULL_TOL_PCT), err


@pytest.mark.parametrize("weighting", ["noise", "relative"])
def test_ebm_pso_reaches_the_closed_form_optimum(paper_flight, weighting) -> None:
    result = make_estimator("ebm-pso", {"weighting": weighting}).fit(paper_flight, rng=SEED)
    cost = ebm_cost(paper_flight, reconstruct(paper_flight), weighting=weighting)
    best = _bounded_optimum(cost, prior_bounds(paper_flight.airframe))
    assert best <= result.cost * (1 + 1e-12)
    assert result.cost <= best * (1 + CLOSED_FORM_RTOL)
    # the unconstrained optimum is the info's yardstick; it can only be lower
    np.testing.assert_allclose(result.info["closed_form_cost"], cost.cost_min)
    assert cost.cost_min <= best * (1 + 1e-12)


@pytest.mark.parametrize("smoothing", ["both", "forces"])
def test_sebm_pso_reaches_each_closed_form_optimum(paper_flight, paper_results, smoothing) -> None:
    """Each sub-problem's PSO cost is within CLOSED_FORM_RTOL above the bounded optimum of
    the same objective (scipy BVLS) and never below it: the option reaches the cost."""
    result = (paper_results["sebm-pso"] if smoothing == "both" else
              make_estimator("sebm-pso", {"smoothing": smoothing}).fit(paper_flight, rng=SEED))
    assert result.info["smoothing"] == smoothing
    bounds = prior_bounds(paper_flight.airframe)
    total = 0.0
    for label, cols, cost in sebm_costs(paper_flight, reconstruct(paper_flight),
                                        smoothing=smoothing):
        best = _bounded_optimum(cost, bounds[list(cols)])
        got = result.info["subproblems"][label]["cost"]
        assert best * (1 - 1e-12) <= got <= best * (1 + CLOSED_FORM_RTOL), label
        total += got
    np.testing.assert_allclose(result.cost, total, rtol=1e-12)


def test_sebm_warns_exactly_where_the_bounded_optimum_is_on_the_box(paper_flight,
                                                                   paper_results) -> None:
    """Under the paper's noise some sub-problems' optima lie outside the default box; the
    coefficients BVLS puts on a wall are the ones the warnings name, and no others."""
    result = paper_results["sebm-pso"]
    bounds = prior_bounds(paper_flight.airframe)
    on_wall = []
    for _, cols, cost in sebm_costs(paper_flight, reconstruct(paper_flight)):
        x = _bounded_solution(cost, bounds[list(cols)])
        box = bounds[list(cols)]
        margin = EDGE_FRACTION * (box[:, 1] - box[:, 0])
        on_wall += [NAMES[c] for c, xj, (lo, hi), m in zip(cols, x, box, margin, strict=True)
                    if xj - lo <= m or hi - xj <= m]
    assert on_wall, "the reference flight no longer has an optimum on the box: pick another"
    text = " ".join(result.warnings)
    flagged = [name for name in NAMES if f"{name} = " in text]
    assert flagged == on_wall
    assert all("edge of the search box" in w and "\n" not in w for w in result.warnings)


def test_no_warning_when_the_optimum_is_inside_the_box(clean_flight) -> None:
    result = make_estimator("sebm-pso", {"weighting": "relative"}).fit(clean_flight, rng=SEED)
    assert result.warnings == ()


def test_noise_free_closed_form_is_inside_the_box_and_matches_lstsq(clean_flight) -> None:
    """Where the optimum is interior, PSO cost ~ scipy.linalg.lstsq optimum (relative)."""
    result = make_estimator("sebm-pso", {"weighting": "relative"}).fit(clean_flight, rng=SEED)
    np.testing.assert_allclose(result.cost, result.info["closed_form_cost"],
                               rtol=CLOSED_FORM_RTOL)


@pytest.mark.parametrize("method", ["ebm-pso", "sebm-pso"])
def test_history_and_info(paper_flight, paper_results, method) -> None:
    result = paper_results[method]
    h = result.history
    n_iter = 200
    assert h["axis"] == "iteration"
    assert h["theta"].shape == (n_iter + 1, len(NAMES))
    assert h["cost"].shape == h["step"].shape == (n_iter + 1,)
    assert np.all(np.diff(h["cost"]) <= 0)
    np.testing.assert_array_equal(h["theta"][-1], result.theta)
    n = paper_flight.n_samples
    assert result.info["fm_raw"].shape == result.info["fm_smooth"].shape == (n, 6)
    np.testing.assert_array_equal(result.info["t"], paper_flight.t)
    assert result.info["weighting"] == "noise"
    assert result.info["smoothing"] == "both"


def test_sebm_keeps_each_subproblem_history(paper_results) -> None:
    sub = paper_results["sebm-pso"].info["subproblems"]
    assert list(sub) == ["FAX", "FAZ", "MX", "MY"]
    assert [s["n_particles"] for s in sub.values()] == [50, 150, 100, 150]
    assert sub["FAZ"]["history_theta"].shape == (201, 3)


@pytest.mark.parametrize(("method", "options", "match"), [
    ("sebm-pso", {"n_particles": "[50, 150]"}, "4 swarm sizes"),
    ("ebm-pso", {"weighting": "ml"}, "weighting"),
    ("eam-pso", {"n_particles": "2"}, "n_particles"),
    ("ebm-pso", {"box": "[1, 2]"}, "18 numbers"),
    ("sebm-pso", {"derivative_window": "8"}, "derivative_window"),
    ("ebm-pso", {"rate_weight": "0"}, "rate_weight"),
    ("eam-pso", {"initial_state": "zero"}, "initial_state"),
    ("eam-pso", {"n_iterations": "0"}, "n_iterations must be in \\[1, 100000\\]"),
    ("sebm-pso", {"n_iterations": "0"}, "n_iterations"),
    ("ebm-pso", {"n_particles": "100000000"}, "n_particles must be in \\[3, 10000\\]"),
    ("sebm-pso", {"n_particles": "[50, 150, 100, 20000]"}, "n_particles"),
    ("eam-pso", {"substeps": "1000"}, "substeps"),
    ("eam-pso", {"stall_iterations": "0"}, "stall_iterations"),
    ("ebm-pso", {"box": "[" + ", ".join(["2, 1"] * len(NAMES)) + "]"}, "low < high"),
])
def test_bad_options_are_one_line_errors(method, options, match) -> None:
    with pytest.raises(EstimatorError, match=match) as info:
        make_estimator(method, options)
    assert "\n" not in str(info.value)


def test_user_box_is_used(paper_flight) -> None:
    prior = paper_flight.airframe.prior_vector()
    box = np.sort(np.stack([prior * 0.9, prior * 1.1], axis=1), axis=1)
    result = make_estimator("sebm-pso", {"box": box.reshape(-1).tolist(),
                                         "n_iterations": 30}).fit(paper_flight, rng=SEED)
    assert np.all(result.theta >= box[:, 0]) and np.all(result.theta <= box[:, 1])
    np.testing.assert_array_equal(result.info["bounds"], box)


def test_eam_refuses_a_swarm_too_large_for_the_flight(paper_flight, monkeypatch) -> None:
    """Checked before the first simulation: one line, not a failed fit or a dead machine."""
    est = make_estimator("eam-pso", {"n_particles": 10, "n_iterations": 1})
    need = 10 * paper_flight.n_samples * N_STATE * 8
    monkeypatch.setattr(eam, "MAX_SWARM_STATE_BYTES", need - 1)
    with pytest.raises(EstimatorError, match="particles x 501 samples need"):
        est.fit(paper_flight, rng=SEED)
    monkeypatch.setattr(eam, "MAX_SWARM_STATE_BYTES", need)
    assert np.all(np.isfinite(est.fit(paper_flight, rng=SEED).theta))


@pytest.mark.parametrize(("method", "options", "stages"), [
    ("ebm-pso", {"n_iterations": 7}, ["PSO"]),
    ("eam-pso", {"n_particles": 5, "n_iterations": 3}, ["PSO"]),
    ("sebm-pso", {"n_iterations": 4, "n_particles": [5, 5, 5, 5]},
     ["FAX 1/4", "FAZ 2/4", "MX 3/4", "MY 4/4"]),
])
def test_pso_methods_report_every_iteration(paper_flight, method, options, stages) -> None:
    events = []
    result = make_estimator(method, options).fit(paper_flight, rng=SEED, progress=events.append)
    n = options["n_iterations"]
    expected = [(stage, k, n) for stage in stages for k in range(n + 1)]
    assert [(e.stage, e.done, e.total) for e in events] == expected
    # the reported cost is the best so far: the history's, iteration by iteration
    if method != "sebm-pso":
        np.testing.assert_array_equal([e.cost for e in events[1:]], result.history["cost"][1:])
