"""The gust filters' one-step estimate judged where it is reported (issue 26).

References: filter-error's filter run at the reported estimate and intensity, rebuilt
here from the flight (its innovations' RMS per channel is what the fit check must have
read); a known-wrong reported point (the right one-step point with Cx moved 10 %), which
must be refused where the right one passes on the same flight, and a point moved 3 se
along Cma (which the gust verdict cannot see) refused by the next scoring step; a
coefficient held 10 % off (Cx) refused by the verdicts at the reported point; synthetic
results for which failures are the filter's verdicts'.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import aeroid
from aeroid.estimation import EstimationResult
from aeroid.flights import MIL_SCALE_LENGTH_M, GaussianNoise, Wind, simulate
from aeroid.model import NAMES
from baselines import _kalman_information, _kalman_likelihood, _kalman_verdict
from baselines._kalman_onestep import NEXT_STEP_LIMIT_SE

#: The same filter on the same numbers (a batched run of one row against the fit's centre
#: row of a batch): rounding only.
SAME_RTOL = 1e-9
#: The right one-step point's next scoring step [se]: it lands 0.13 se from filter-error's
#: optimum on this flight (test_kalman_information), measured 0.14 here; the limit is 1.
RIGHT_NEXT_STEP_SE = 0.5
#: The known-wrong move: Cx (the axial force, the best-determined coefficient: se ~1 %)
#: 10 % off, which a gust path takes up as a head wind (README: the gust verdict refuses
#: a Cx held 10 % off 40/40).
WRONG_FACTOR = 1.1
#: A pitch-plane move of the reported point, in the right fit's se of Cma: three times
#: the next-step limit (1 se), well inside what the gust verdict allows.
OFF_SE = 3.0


@pytest.fixture(scope="module")
def turbulent(reference_scenario):
    """Dryden sd 3 m/s, no steady wind, Gaussian IMU noise (filter-error's study), seed 1."""
    s = reference_scenario
    rough = dataclasses.replace(s.manoeuvre, wind=Wind(turbulence_sd_mps=3.0))
    return simulate(s.airframe, s.coefficient_vector, rough, GaussianNoise(), rng=1)


@pytest.fixture(scope="module")
def right(turbulent):
    """The EKF told the true intensity, ``gust_stderr`` by default (one-step)."""
    return aeroid.make_estimator("ekf", {"gust_sd_mps": 3.0}).fit(turbulent, rng=1)


def _innovation_rms(flight, theta, sd):
    """Filter-error's filter at ``theta`` and intensity ``sd``: RMS innovation per channel."""
    problem, noise = _kalman_likelihood.gust_problem(
        flight, theta, scale_length_m=MIL_SCALE_LENGTH_M, substeps=1, input_mode="auto",
        delay_s=0.0)
    runs = problem.run(_kalman_likelihood.point(problem, sd)[None], noise.R)
    return np.sqrt(np.mean(runs.innovation[0] ** 2, axis=0))


def test_the_default_is_one_step_and_its_checks_read_the_reported_estimate(turbulent,
                                                                           right) -> None:
    """``auto`` is ``one-step``: the estimate is not the filter's, and the fit check's
    residuals are filter-error's innovations at the reported estimate and intensity
    (the whole record), not the filter's; its intervals are said calibrated."""
    assert right.success, right.message
    assert right.info["intervals"] == {"source": "one-step", "calibrated": True,
                                       "measured_coverage_turbulence": "0.96-0.97"}
    assert not np.array_equal(right.theta, right.info["theta_filtered"])
    sd = right.info["gust_information"]["gust_sd_mps"]
    rms = _innovation_rms(turbulent, right.theta, sd)
    checked = right.info["fit_check"]["residual_rms"]
    np.testing.assert_allclose([checked[c] for c in aeroid.model.OUTPUT_CHANNELS], rms,
                               rtol=SAME_RTOL)
    moves = right.info["one_step"]["next_step_se"]
    assert set(moves) == {*NAMES, "gust_sd_mps"}
    assert max(moves.values()) < RIGHT_NEXT_STEP_SE
    assert right.info["one_step"]["filter_success"]


def test_a_wrong_reported_estimate_is_refused(turbulent, right, monkeypatch) -> None:
    """The reported point moved to a known-wrong one (Cx 10 % off the right one-step's):
    refused by the verdicts at that point, whose fit check read that point's innovations;
    the filter's own estimate (unchanged) passed its verdicts."""
    right_point = _kalman_likelihood.one_step_point

    def wrong(problem, found):
        p, length = right_point(problem, found)
        p = p.copy()
        p[int(np.flatnonzero(problem.free == NAMES.index("Cx"))[0])] *= WRONG_FACTOR
        return p, length

    monkeypatch.setattr(_kalman_information, "one_step_point", wrong)
    result = aeroid.make_estimator("ekf", {"gust_sd_mps": 3.0}).fit(turbulent, rng=1)
    cx = NAMES.index("Cx")
    assert result.theta[cx] == pytest.approx(WRONG_FACTOR * right.theta[cx], rel=1e-12)
    assert result.info["one_step"]["filter_success"]  # the filter's estimate passed
    assert not result.success
    assert result.message.startswith("ekf: "), result.message
    assert any(k in result.message for k in ("not at the likelihood's optimum",
                                              "model error fixed in the body",
                                              "steady")), result.message
    sd = result.info["gust_information"]["gust_sd_mps"]
    rms = _innovation_rms(turbulent, result.theta, sd)
    checked = result.info["fit_check"]["residual_rms"]
    np.testing.assert_allclose([checked[c] for c in aeroid.model.OUTPUT_CHANNELS], rms,
                               rtol=SAME_RTOL)
    assert max(result.info["one_step"]["next_step_se"].values()) > NEXT_STEP_LIMIT_SE


def test_a_reported_estimate_off_the_optimum_along_the_pitch_plane_is_refused(
        turbulent, right, monkeypatch) -> None:
    """The right one-step point with Cma moved 3 of its se (a pitch-plane error: the gust
    states take it up, the gust verdict does not see it): refused by the next scoring
    step, which would move it back by about that much."""
    right_point = _kalman_likelihood.one_step_point
    cma = NAMES.index("Cma")

    def off(problem, found):
        p, length = right_point(problem, found)
        p = p.copy()
        i = int(np.flatnonzero(problem.free == cma)[0])
        p[i] += OFF_SE * right.stderr[cma] / problem.scale[i]
        return p, length

    monkeypatch.setattr(_kalman_information, "one_step_point", off)
    result = aeroid.make_estimator("ekf", {"gust_sd_mps": 3.0}).fit(turbulent, rng=1)
    assert not result.success
    assert "not at the likelihood's optimum" in result.message, result.message
    moves = result.info["one_step"]["next_step_se"]
    assert max(moves.values()) > NEXT_STEP_LIMIT_SE
    assert result.info["gust_verdict_refusal"] == ""  # the gust verdict passed it


def test_a_coefficient_held_wrong_is_refused_at_the_reported_point(turbulent,
                                                                   reference_scenario) -> None:
    """Cx held 10 % off (the gust verdict's known-wrong model): refused, by a verdict at
    the one-step estimate."""
    truth = reference_scenario.coefficient_vector
    result = aeroid.make_estimator("ekf", {"gust_sd_mps": 3.0}).fit(
        turbulent, rng=1, holds={"hold": {"Cx": WRONG_FACTOR * float(truth[NAMES.index("Cx")])}})
    assert not result.success
    assert "one_step" in result.info and result.info["intervals"]["source"] == "one-step"
    assert (result.message == result.info["gust_verdict_refusal"]
            or "not at the likelihood's optimum" in result.message
            or "refuse the user's Cx" in result.message), result.message


def _result(success: bool, message: str = "", **info) -> EstimationResult:
    return EstimationResult(estimator="ekf", theta=np.zeros(len(NAMES)), success=success,
                            message=message, info=info)


def test_which_failures_are_the_filters_verdicts() -> None:
    """The one-step re-judges a failure only when it was a verdict on the filter's estimate
    (its passes' settling, its gust verdict), never a diverged filter."""
    assert not _kalman_verdict.refused_by_verdict(_result(True))
    assert _kalman_verdict.refused_by_verdict(_result(False, "walked", settle_refused=True))
    gust = "ekf: the estimated gust carries a model error fixed in the body"
    assert _kalman_verdict.refused_by_verdict(_result(False, gust, gust_verdict_refusal=gust))
    assert not _kalman_verdict.refused_by_verdict(
        _result(False, "filter diverged at t = 0.1 s", gust_verdict_refusal=""))
    assert not _kalman_verdict.refused_by_verdict(_result(False, "filter diverged"))


def test_innovations_and_filtered_intervals_in_turbulence_are_said_not_calibrated(
        turbulent) -> None:
    """Known to undercover in Dryden turbulence (0.85-0.87, 0.76-0.82): said in the result
    (``info['intervals']['calibrated']`` False) and in one line each."""
    for mode, words in (("innovations", "these intervals are not calibrated"),
                        ("filtered", "final filtered covariance's (gust_stderr = filtered)")):
        result = aeroid.make_estimator("ekf", {"gust_sd_mps": 3.0, "gust_stderr": mode,
                                               "max_passes": 2}).fit(turbulent, rng=1)
        assert result.info["intervals"]["source"] == mode
        assert result.info["intervals"]["calibrated"] is False
        assert sum(words in w for w in result.warnings) == 1, result.warnings
        assert math.isfinite(result.info["gust_sd_mps"])
