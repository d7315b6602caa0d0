"""Coverage of the baselines' 95 % intervals over seeded noisy flights (slow).

Two conditions. 50 flights of the reference scenario with additive Gaussian sensor noise (the
:class:`aeroid.flights.GaussianNoise` defaults, sensor positions known exactly), one
fit per estimator and flight; a coefficient-run is covered when
``|theta - truth| <= 1.96 stderr``. Correct intervals cover 95 %; with 450
coefficient-runs (correlated within a run) the accepted band is 88-99 %. And 30 flights
with the paper's noise and 10 % sensor-position error, every estimator started from a
prior 10-25 % off the truth: output-error and the EKF/UKF against issue 11's accuracy
targets and the same band; equation-error (its intervals considering the position
error) against the band.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import aeroid
from aeroid.flights._noise import GaussianNoise, PaperNoise
from aeroid.flights._scenario import reference_scenario
from aeroid.flights._simulate import simulate_scenario
from baselines.equation_error import EquationErrorEstimator
from baselines.output_error import OutputErrorEstimator

N_FLIGHTS = 50
SEED = 20261122
#: Accepted coverage of nominal 95 % intervals (issue: 88-99 %): the binomial sd of a
#: coverage over 450 independent coefficient-runs is 1 %, and the nine coefficients of
#: one run are correlated, so the effective count is nearer 50-100 (sd 2-3 %).
COVERAGE_BAND = (0.88, 0.99)
Z95 = 1.959963984540054

ESTIMATORS = {
    "output-error": OutputErrorEstimator(),
    "equation-error": EquationErrorEstimator(),
    "equation-error-one-step": EquationErrorEstimator(one_step=True),
    "equation-error-ols": EquationErrorEstimator(covariance="ols"),
}


@pytest.fixture(scope="module")
def coverage():
    scenario = reference_scenario()
    noise = GaussianNoise(position_sd_m=0.0)
    seeds = np.random.SeedSequence(SEED).spawn(N_FLIGHTS)
    truth = aeroid.nominal()
    covered = {name: [] for name in ESTIMATORS}
    failures = {name: 0 for name in ESTIMATORS}
    for seed in seeds:
        flight = simulate_scenario(scenario, noise, rng=np.random.default_rng(seed))
        for name, est in ESTIMATORS.items():
            res = est.fit(flight, rng=0)
            if not res.success:
                failures[name] += 1
                covered[name].append(np.zeros(len(truth), dtype=bool))
                continue
            covered[name].append(np.abs(res.theta - truth) <= Z95 * res.stderr)
    out = {name: (np.array(v), failures[name]) for name, v in covered.items()}
    for name, (cov, fails) in out.items():  # printed with -s: the numbers for the report
        print(f"\n{name}: coverage {cov.mean():.3f} overall, per coefficient "
              f"{np.round(cov.mean(axis=0), 2)}, {fails} failed fits")
    return out


@pytest.mark.slow
def test_output_error_intervals_cover_the_truth(coverage):
    cov, fails = coverage["output-error"]
    assert fails == 0
    assert COVERAGE_BAND[0] <= cov.mean() <= COVERAGE_BAND[1], cov.mean(axis=0)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["equation-error", "equation-error-one-step"])
def test_equation_error_intervals_cover_the_truth(coverage, name):
    """With the default Newey-West covariance (the residuals are coloured)."""
    cov, fails = coverage[name]
    assert fails == 0
    assert COVERAGE_BAND[0] <= cov.mean() <= COVERAGE_BAND[1], cov.mean(axis=0)


@pytest.mark.slow
def test_white_residual_intervals_are_too_narrow(coverage):
    """Why HAC is the default: sigma^2 (X^T X)^-1 covers far less than 95 % here."""
    cov, fails = coverage["equation-error-ols"]
    assert fails == 0
    assert cov.mean() < COVERAGE_BAND[0]


# --------------------------------------------------------------------------------------
# The paper's noise with its 10 % sensor-position error, from a prior off the truth
# --------------------------------------------------------------------------------------
N_PAPER_FLIGHTS = 30
#: Issue 11's targets for this condition: mean |error| over the nine coefficients (None:
#: no accuracy target; equation-error sits at its gyro-only floor on Cl0/Clp, ~44 %).
PAPER_TARGET_PCT = {"output-error": 0.5, "ekf": 1.0, "ukf": 1.0, "equation-error": None}


@pytest.fixture(scope="module")
def paper_condition():
    """Each flight's prior is truth x (1 + s U(0.10, 0.25)) with a random sign s (the
    studies' ``prior_offset``); every estimator starts from it."""
    scenario = reference_scenario()
    truth = aeroid.nominal()
    out = {name: {"err": [], "covered": [], "failed": 0} for name in PAPER_TARGET_PCT}
    for seed in np.random.SeedSequence(SEED + 1).spawn(N_PAPER_FLIGHTS):
        rng = np.random.default_rng(seed)
        flight = simulate_scenario(scenario, PaperNoise(), rng=rng)
        prior = truth * (1 + rng.choice([-1.0, 1.0], truth.size)
                         * rng.uniform(0.10, 0.25, truth.size))
        flight = dataclasses.replace(flight,
                                     airframe=flight.airframe.replace(prior=tuple(prior)))
        for name, rec in out.items():
            res = aeroid.make_estimator(name).fit(flight, rng=0)
            if not res.success:
                rec["failed"] += 1
                continue
            rec["err"].append(np.abs(res.theta / truth - 1.0) * 100)
            rec["covered"].append(np.abs(res.theta - truth) <= Z95 * res.stderr)
    for name, rec in out.items():
        err, cov = np.array(rec["err"]), np.array(rec["covered"])
        print(f"\npaper noise, {name}: mean |error| {err.mean():.3f} %, coverage "
              f"{cov.mean():.3f} (per coefficient {np.round(cov.mean(axis=0), 2)}), "
              f"{rec['failed']} failed fits")
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", list(PAPER_TARGET_PCT))
def test_paper_noise_accuracy_and_coverage(paper_condition, name):
    rec = paper_condition[name]
    assert rec["failed"] == 0
    if PAPER_TARGET_PCT[name] is not None:
        assert np.mean(rec["err"]) <= PAPER_TARGET_PCT[name]
    assert COVERAGE_BAND[0] <= np.mean(rec["covered"]) <= COVERAGE_BAND[1]
