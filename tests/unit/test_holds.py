"""Held, free and prior coefficients (issue 25): the spec, its arithmetic, every estimator.

References: holding a coefficient at the free fit's value gives the free fit (identity);
a prior of sd -> 0 gives the held fit and one of huge sd the free fit (limits); the
Cramér-Rao floor with a prior equals ``inv(F_ff + diag(1/sd^2))`` from sensitivities
computed here; the prior's Gaussian combination equals stacked least squares with the
prior as pseudo-observations; a wrong held value is refused by the fit check.
"""

from __future__ import annotations

import numpy as np
import pytest
from closeness import assert_close_in_norm

import aeroid
from aeroid.errors import EstimatorError
from aeroid.estimation import (
    CoefficientSpec,
    EstimationResult,
    Estimator,
    combine_with_prior,
    cramer_rao_sd,
    floor_with_holds,
)
from aeroid.flights._noise import GaussianNoise, NoNoise
from aeroid.flights._scenario import reference_scenario
from aeroid.flights._simulate import simulate_scenario
from aeroid.model import NAMES
from baselines.ekf import ExtendedKalmanEstimator
from baselines.equation_error import EquationErrorEstimator
from baselines.output_error import OutputErrorEstimator
from baselines.ukf import UnscentedKalmanEstimator

TRUTH = aeroid.nominal()
#: Held at the free fit's own value, a fit returns the free fit: output-error's
#: Gauss-Newton stops on a step below tol (1e-6 sd), so the two optima agree to ~1e-8
#: relative (measured 2.7e-9 on the Gaussian flight).
IDENTITY_RTOL = 1e-7
#: A prior of sd 1e-6 standard errors moves the held fit by ~1e-12 of the se; the solver's
#: stopping rule leaves ~1e-9 relative (measured 1.2e-9).
LIMIT_RTOL = 1e-7
#: Noise-free recovery with two coefficients held at their truth (output-error's own
#: recovery tolerance, tests/unit/test_baselines_output_error.py: RECOVERY_RTOL).
RECOVERY_RTOL = 1e-4
#: Equation-error with a held term: the same linear algebra on one column fewer; OLS's
#: sigma^2 divides by n - k, which changes by one per held column (1/500 of the se).
EE_SE_RTOL = 5e-3
#: The EKF/UKF with a prior of sd 1e-6 of the held value against the held filter: the
#: prior's state still moves by ~1e-6 sd at each update (measured < 1e-5 relative).
FILTER_LIMIT_RTOL = 1e-4


@pytest.fixture(scope="module")
def clean_flight():
    return simulate_scenario(reference_scenario(), NoNoise(), rng=0)


@pytest.fixture(scope="module")
def noisy_flight():
    noise = GaussianNoise(accel_sd_mps2=0.5, rate_sd_radps=0.02, position_sd_m=0.0)
    return simulate_scenario(reference_scenario(), noise, rng=4)


# -- the spec ------------------------------------------------------------------------------
def test_parse_holds_and_priors():
    spec = CoefficientSpec.parse(["Czd=0", "Cmd = 0.5"], ["Cmq=-1500:300"])
    assert spec.held == {"Czd": 0.0, "Cmd": 0.5}
    assert spec.priors == {"Cmq": (-1500.0, 300.0)}
    assert spec.free_names == tuple(n for n in NAMES if n not in ("Czd", "Cmd"))
    full = spec.expand(np.arange(7.0))
    np.testing.assert_array_equal(full[spec.held_index], [0.0, 0.5])
    np.testing.assert_array_equal(full[spec.free_index], np.arange(7.0))
    assert spec.prior_information()[NAMES.index("Cmq")] == 1.0 / 300.0**2
    assert np.count_nonzero(spec.prior_information()) == 1


@pytest.mark.parametrize(("holds", "priors", "words"), [
    (["Cq=0"], [], "unknown coefficient 'Cq'"),
    (["Czd"], [], "expected NAME=VALUE"),
    (["Czd=abc"], [], "expected a number"),
    (["Czd=nan"], [], "finite"),
    ([], ["Cmq=-1500"], "expected NAME=MEAN:SD"),
    ([], ["Cmq=-1500:0"], "sd must be > 0"),
    ([], ["Cmq=-1500:-3"], "sd must be > 0"),
    (["Cmq=1"], ["Cmq=1:2"], "already held"),
    (["Czd=0", "Czd=1"], [], "already held"),
    ([f"{n}=1" for n in NAMES], [], "nothing left to estimate"),
])
def test_bad_specs_are_one_line_errors(holds, priors, words):
    with pytest.raises(EstimatorError, match=words) as info:
        CoefficientSpec.parse(holds, priors)
    assert "\n" not in str(info.value)


def test_held_and_prior_in_one_mapping_is_refused():
    with pytest.raises(EstimatorError, match="both held and given a prior"):
        CoefficientSpec(held={"Cmq": 1.0}, priors={"Cmq": (1.0, 2.0)})
    with pytest.raises(EstimatorError, match="unknown key"):
        CoefficientSpec.from_mapping({"hold": {"Czd": 0}, "fix": {}})


def test_merge_refuses_contradictions():
    a = CoefficientSpec.parse(["Czd=0"])
    assert a.merged(CoefficientSpec.parse(["Czd=0"])).held == {"Czd": 0.0}
    with pytest.raises(EstimatorError, match="declared twice"):
        a.merged(CoefficientSpec.parse([], ["Czd=0:1"]))


def test_combine_with_prior_equals_pseudo_observations():
    # y = A theta + e (sd 1) with priors on theta_1, theta_2 as extra rows
    rng = np.random.default_rng(3)
    A = rng.standard_normal((40, len(NAMES)))
    y = A @ TRUTH + rng.standard_normal(40)
    spec = CoefficientSpec(priors={NAMES[1]: (TRUTH[1] + 0.3, 0.2), NAMES[2]: (TRUTH[2], 5.0)})
    theta, *_ = np.linalg.lstsq(A, y, rcond=None)
    cov = np.linalg.inv(A.T @ A)
    got, got_cov = combine_with_prior(theta, cov, spec)
    mean, sd = spec.prior_mean_sd()
    rows = np.flatnonzero(np.isfinite(sd))
    P = np.zeros((rows.size, len(NAMES)))
    P[np.arange(rows.size), rows] = 1.0 / sd[rows]
    stacked = np.vstack([A, P])
    want, *_ = np.linalg.lstsq(stacked, np.concatenate([y, mean[rows] / sd[rows]]), rcond=None)
    np.testing.assert_allclose(got, want, rtol=1e-10)
    # the covariance's off-diagonal entries can be near zero: compared at the matrix's scale
    assert_close_in_norm(got_cov, np.linalg.inv(stacked.T @ stacked), rtol=1e-10)


def test_floor_with_prior_and_held_equals_independent_inverse(clean_flight):
    from aeroid.estimation import information_from_sensitivities, output_sensitivities
    noise = GaussianNoise()
    spec = CoefficientSpec(held={"Czd": TRUTH[2]}, priors={"Cmq": (TRUTH[8], 300.0)})
    got = cramer_rao_sd(clean_flight, noise, estimate_initial=("p", "q", "r"),
                        holds=spec).to_numpy()
    # independent: the sensitivities' information, the nuisance block removed, the held
    # coefficient's row and column dropped, 1/sd^2 added, inverted
    airframe = clean_flight.airframe
    pos = np.asarray(clean_flight.metadata["true_accel_positions_m"])
    J = output_sensitivities(airframe, TRUTH, clean_flight, positions=pos,
                             estimate_initial=("p", "q", "r"))
    sd = np.broadcast_to(noise.output_sd(np.zeros((1, 9))), (J.shape[0], 9))
    F = information_from_sensitivities(J, sd)
    n = len(NAMES)
    F = F[:n, :n] - F[:n, n:] @ np.linalg.solve(F[n:, n:], F[n:, :n])
    free = [j for j in range(n) if NAMES[j] != "Czd"]
    block = F[np.ix_(free, free)].copy()
    k = free.index(NAMES.index("Cmq"))
    block[k, k] += 1.0 / 300.0**2
    want = np.full(n, np.nan)
    want[free] = np.sqrt(np.diag(np.linalg.inv(block)))
    np.testing.assert_allclose(got, want, rtol=1e-3)  # central differences on both sides
    assert np.isnan(got[NAMES.index("Czd")])
    assert floor_with_holds(F, CoefficientSpec())[0] == pytest.approx(
        np.sqrt(np.linalg.inv(F)[0, 0]), rel=1e-12)


# -- Estimator.fit ---------------------------------------------------------------------------
class _Plain(Estimator):
    name = "plain-test"

    def run(self, flight, rng):
        return EstimationResult(estimator=self.name, theta=TRUTH)


def test_method_without_holds_refuses_them(clean_flight):
    with pytest.raises(EstimatorError, match="cannot hold coefficients"):
        _Plain().fit(clean_flight, holds=CoefficientSpec.parse(["Czd=0"]))
    assert _Plain().fit(clean_flight, holds=CoefficientSpec()).held == {}


# -- output-error ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def oe_fits(noisy_flight):
    est = OutputErrorEstimator(equation_error_start=False, noise_model="channel")
    free = est.fit(noisy_flight, rng=0)
    j = NAMES.index("Cmq")
    value, se = free.theta[j], free.stderr[j]
    held = est.fit(noisy_flight, rng=0, holds={"hold": {"Cmq": value}})
    tight = est.fit(noisy_flight, rng=0, holds={"prior": {"Cmq": (value, 1e-6 * se)}})
    wide = est.fit(noisy_flight, rng=0, holds={"prior": {"Cmq": (TRUTH[j], 1e6 * se)}})
    return free, held, tight, wide


def test_output_error_held_at_free_value_is_the_free_fit(oe_fits):
    free, held, _, _ = oe_fits
    assert free.success and held.success, (free.message, held.message)
    j = NAMES.index("Cmq")
    others = [i for i in range(len(NAMES)) if i != j]
    np.testing.assert_allclose(held.theta, free.theta, rtol=IDENTITY_RTOL)
    assert held.held == {"Cmq": free.theta[j]}
    assert np.isnan(held.stderr[j]) and np.all(held.covariance[j] == 0.0)
    # holding removes Cmq's uncertainty from the others: never larger standard errors
    assert np.all(held.stderr[others] <= free.stderr[others] * (1 + 1e-9))
    assert held.to_json_dict()["held"] == {"Cmq": free.theta[j]}
    assert "held" in held.summary()


def test_output_error_prior_limits(oe_fits):
    free, held, tight, wide = oe_fits
    np.testing.assert_allclose(tight.theta, held.theta, rtol=LIMIT_RTOL)
    finite = np.isfinite(held.stderr)
    np.testing.assert_allclose(tight.stderr[finite], held.stderr[finite], rtol=LIMIT_RTOL)
    np.testing.assert_allclose(wide.theta, free.theta, rtol=LIMIT_RTOL)
    np.testing.assert_allclose(wide.stderr, free.stderr, rtol=LIMIT_RTOL)
    assert "Cmq" in tight.priors and tight.to_json_dict()["priors"]["Cmq"]["sd"] > 0


def test_output_error_recovers_noise_free_with_holds(clean_flight):
    est = OutputErrorEstimator(equation_error_start=False)
    res = est.fit(clean_flight, rng=0, holds=CoefficientSpec(
        held={"Czd": TRUTH[2], "Cmq": TRUTH[8]}))
    assert res.success, res.message
    np.testing.assert_allclose(res.theta, TRUTH, rtol=RECOVERY_RTOL)


def test_output_error_wrong_held_value_is_refused(clean_flight, noisy_flight):
    est = OutputErrorEstimator(equation_error_start=False)
    for flight in (clean_flight, noisy_flight):
        res = est.fit(flight, rng=0, holds=CoefficientSpec(held={"Cmd": 1.2 * TRUTH[7]}))
        assert not res.success
        assert "does not fit" in res.message or "structure" in res.message


# -- equation-error --------------------------------------------------------------------------
@pytest.mark.parametrize("one_step", [False, True])
def test_equation_error_identity_and_limits(clean_flight, noisy_flight, one_step):
    est = EquationErrorEstimator(one_step=one_step, covariance="ols")
    # the one-step form reweights by its own residuals: exact identity on noise-free data
    flight = clean_flight if one_step else noisy_flight
    free = est.fit(flight)
    picks = {"Czd": free.theta[2], "Clp": free.theta[5]}
    held = est.fit(flight, holds=CoefficientSpec(held=picks))
    assert held.success, held.message
    np.testing.assert_allclose(held.theta, free.theta, rtol=1e-9)
    tight = est.fit(flight, holds=CoefficientSpec(priors={
        n: (v, 1e-9 * abs(v)) for n, v in picks.items()}))
    np.testing.assert_allclose(tight.theta, held.theta, rtol=1e-9)
    wide = est.fit(flight, holds=CoefficientSpec(priors={"Czd": (0.0, 1e9)}))
    np.testing.assert_allclose(wide.theta, free.theta, rtol=1e-12)
    np.testing.assert_allclose(wide.stderr, free.stderr, rtol=1e-9)
    if not one_step:
        finite = np.isfinite(held.stderr)
        np.testing.assert_allclose(tight.stderr[finite], held.stderr[finite], rtol=EE_SE_RTOL)


def test_equation_error_wrong_held_value_is_refused(clean_flight, noisy_flight):
    for one_step in (False, True):
        res = EquationErrorEstimator(one_step=one_step).fit(
            clean_flight, holds=CoefficientSpec(held={"Czd": 1.3 * TRUTH[2]}))
        assert not res.success and "does not fit" in res.message
        assert any("contradicts the held value(s) Czd" in w for w in res.warnings)
    # 5 % off under noise: the fit check on the loads does not see it (a success), the
    # check of the held value against the free fit warns (z of ~100)
    j = NAMES.index("Cmd")
    res = EquationErrorEstimator().fit(noisy_flight, holds=CoefficientSpec(
        held={"Cmd": 1.05 * TRUTH[j]}))
    assert abs(res.info["held_check"]["Cmd"]) > 10
    assert any("contradicts the held value(s) Cmd" in w for w in res.warnings)
    # the truth itself is not flagged, noise-free or with the Gaussian IMU
    for flight in (clean_flight, noisy_flight):
        res = EquationErrorEstimator().fit(flight, holds=CoefficientSpec(
            held={"Cmd": TRUTH[j], "Czd": TRUTH[2]}))
        assert res.success, res.message
        assert not any("contradicts" in w for w in res.warnings)


# -- EKF / UKF -------------------------------------------------------------------------------
@pytest.mark.parametrize("cls", [ExtendedKalmanEstimator, UnscentedKalmanEstimator])
def test_filters_hold_and_prior(noisy_flight, cls):
    est = cls()
    j = NAMES.index("Czd")
    held = est.fit(noisy_flight, holds=CoefficientSpec(held={"Czd": TRUTH[j]}))
    assert held.success, held.message
    assert held.theta[j] == TRUTH[j] and np.isnan(held.stderr[j])
    assert held.history["theta"].shape[1] == len(NAMES)
    tight = est.fit(noisy_flight, holds=CoefficientSpec(
        priors={"Czd": (TRUTH[j], 1e-6 * abs(TRUTH[j]))}))
    others = [i for i in range(len(NAMES)) if i != j]
    np.testing.assert_allclose(tight.theta[others], held.theta[others],
                               rtol=FILTER_LIMIT_RTOL)
    assert tight.stderr[j] <= 1e-6 * abs(TRUTH[j])
    wrong = est.fit(noisy_flight, holds=CoefficientSpec(held={"Cmd": 1.3 * TRUTH[7]}))
    assert not wrong.success


# -- the PSO methods -------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["ebm-pso", "sebm-pso", "eam-pso", "pyswarms"])
def test_swarms_search_only_the_free_coefficients(clean_flight, name):
    small = {"ebm-pso": {"n_particles": 40, "n_iterations": 60},
             "sebm-pso": {"n_particles": (20, 20, 20, 20), "n_iterations": 60},
             "eam-pso": {"n_particles": 30, "n_iterations": 30, "warm_start": True},
             "pyswarms": {"n_particles": 30, "n_iterations": 20}}[name]
    est = aeroid.make_estimator(name, small)
    spec = CoefficientSpec(held={"Cx": TRUTH[0], "Czd": TRUTH[2]})
    res = est.fit(clean_flight, rng=1, holds=spec)
    assert res.theta[0] == TRUTH[0] and res.theta[2] == TRUTH[2]
    assert res.held == spec.held
    # the swarm's history moves only the free coefficients
    hist = res.history["theta"]
    assert np.all(hist[:, 0] == TRUTH[0]) and np.all(hist[:, 2] == TRUTH[2])
    assert not any("Cx" in w or "Czd" in w for w in res.warnings)


def test_swarm_prior_penalty_is_the_map_of_the_quadratic_cost(clean_flight):
    # EBM's cost is J = J* + (theta - theta*)^T H (theta - theta*) = (2/N) NLL; with the
    # priors' penalty its minimum is (H + W/N) theta = H theta* + W mu / N (closed form)

    from aeroid.estimation import ebm_cost, free_cost, reconstruct
    cost = ebm_cost(clean_flight, reconstruct(clean_flight))
    j = NAMES.index("Cmq")
    spec = CoefficientSpec(held={"Czd": TRUTH[2]}, priors={"Cmq": (1.3 * TRUTH[j], 50.0)})
    free, reduced, expand = free_cost(cost, spec, cost.n_samples)
    theta = TRUTH[free] * 1.01
    mu = 1.3 * TRUTH[j]
    penalty = ((theta[list(free).index(j)] - mu) / 50.0) ** 2 / cost.n_samples
    assert reduced(theta) == pytest.approx(cost(expand(theta)) + penalty, rel=1e-12)
    H, star = cost.hessian, cost.theta_opt
    w = np.zeros(len(NAMES))
    w[j] = 1.0 / 50.0**2 / cost.n_samples
    A = H + np.diag(w)
    mean = np.where(w > 0, mu, 0.0)
    h = NAMES.index("Czd")  # the held coefficient moves to the right-hand side
    rhs = (H @ star + w * mean)[free] - A[np.ix_(free, [h])] @ [TRUTH[h]]
    want = np.linalg.solve(A[np.ix_(free, free)], rhs)
    # a quadratic with minimum `want` and Hessian A_ff: J(x) - J(want) = d^T A_ff d
    rng = np.random.default_rng(0)
    for _ in range(5):
        d = want * 1e-3 * rng.standard_normal(want.size)
        excess = reduced(want + d) - reduced(want)
        assert excess == pytest.approx(d @ A[np.ix_(free, free)] @ d, rel=1e-6)


def test_swarm_priors_refused_without_a_likelihood(clean_flight):
    far = TRUTH[NAMES.index("Cmq")] * 1.3
    with pytest.raises(EstimatorError, match="weighting = noise"):
        aeroid.make_estimator("ebm-pso", {"weighting": "relative"}).fit(
            clean_flight, holds=CoefficientSpec(priors={"Cmq": (far, 1.0)}))
    with pytest.raises(EstimatorError, match="polish"):
        aeroid.make_estimator("ebm-pso", {"polish": True}).fit(
            clean_flight, holds=CoefficientSpec(held={"Czd": TRUTH[2]}))


# -- the airframe file ---------------------------------------------------------------------
def test_airframe_file_holds_and_priors(tmp_path, clean_flight):
    from aeroid.errors import AirframeError
    from aeroid.estimation import airframe_holds
    from aeroid.model import load_airframe
    from aeroid.model._airframe import save_airframe

    airframe = clean_flight.airframe.replace(prior=tuple(TRUTH), hold={"Czd": TRUTH[2]},
                                             prior_sd={"Cmq": 300.0})
    path = tmp_path / "airframe.toml"
    save_airframe(airframe, path)
    text = path.read_text()
    assert "[hold]" in text and "[prior_sd]" in text
    back = load_airframe(path)
    spec = airframe_holds(back)
    assert spec.held == {"Czd": TRUTH[2]}
    assert spec.priors == {"Cmq": (TRUTH[8], 300.0)}
    assert spec.sources["Czd"] == "airframe [hold]"
    # the flight's airframe is used by every fit, the command line's holds merged in
    flight = clean_flight.__class__(clean_flight.data, back, clean_flight.metadata)
    res = EquationErrorEstimator().fit(flight, holds=CoefficientSpec(held={"Cx": TRUTH[0]}))
    assert res.held == {"Cx": TRUTH[0], "Czd": TRUTH[2]} and "Cmq" in res.priors
    with pytest.raises(EstimatorError, match="declared twice"):
        EquationErrorEstimator().fit(flight, holds=CoefficientSpec(held={"Czd": 0.0}))
    # the sidecar carries them with the flight
    from aeroid.flights import read_flight
    flight.write(tmp_path / "flight.csv")
    again = read_flight(tmp_path / "flight.csv")
    assert airframe_holds(again.airframe) == spec
    for changes, words in (({"prior_sd": {"Cmq": 0.0}}, "must be > 0"),
                           ({"prior_sd": {"Cq": 1.0}}, "Cq"),
                           ({"hold": {"Cmq": 1.0}}, "both in"),
                           ({"prior": None}, "needs \\[prior\\]")):
        with pytest.raises(AirframeError, match=words):
            airframe.replace(**changes)
