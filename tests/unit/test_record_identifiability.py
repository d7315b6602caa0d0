"""Identifiability before the fit (issue 25): what the record cannot determine is named,
and a fit that estimates it freely anyway is not a success.

Known-wrong inputs: a log whose fin never moves (its terms zero in the truth, so the data
are consistent with any Czd, Cmd), pitch and yaw rates replaced by noise alone, a roll
rate held proportional to the speed. Known-right inputs: the reference flight under each
noise model and several seeds, which determines all nine (no false alarm allowed).
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np
import pytest

import aeroid
from aeroid.estimation import CoefficientSpec, record_findings, record_verdict
from aeroid.flights import GaussianNoise, NoNoise, PaperNoise, reference_scenario, simulate
from aeroid.model import NAMES
from baselines.equation_error import EquationErrorEstimator
from baselines.output_error import OutputErrorEstimator

TRUTH = aeroid.nominal()
FIN = [NAMES.index("Czd"), NAMES.index("Cmd")]
#: Output-error's noise-free recovery (tests/unit/test_baselines_output_error.py).
RECOVERY_RTOL = 1e-4


def _no_fin_motion(noise) -> aeroid.Flight:
    scenario = reference_scenario()
    theta = TRUTH.copy()
    theta[FIN] = 0.0  # the fin has no effect in the truth: a still fin is consistent
    flight = simulate(scenario.airframe, theta, scenario.manoeuvre, noise, rng=0)
    meta = {k: v for k, v in flight.metadata.items()
            if k not in ("delta_knots", "command_switches")}
    meta["true_coefficients"] = theta
    return dataclasses.replace(flight, data=flight.data.assign(delta=0.0), metadata=meta,
                               airframe=flight.airframe.replace(fin_law=None))


@pytest.fixture(scope="module")
def still_fin():
    return _no_fin_motion(NoNoise())


def test_no_fin_motion_names_the_fin_terms_and_fails_them(still_fin, caplog):
    assert [f.names for f in record_findings(still_fin)] == [("Czd", "Cmd")]
    for est in (OutputErrorEstimator(equation_error_start=False), EquationErrorEstimator()):
        with caplog.at_level(logging.INFO, logger="aeroid"):
            res = est.fit(still_fin, rng=0)
        said = [r.getMessage() for r in caplog.records if "not identifiable" in r.getMessage()]
        assert said and "Czd, Cmd" in said[0] and "--hold Czd=VALUE" in said[0]
        caplog.clear()
        assert not res.success
        assert set(res.info["not_identifiable"]) == {"Czd", "Cmd"}
        assert "no fin motion" in res.info["not_identifiable"]["Czd"]
        assert "Czd, Cmd" in res.message or any("Czd, Cmd" in w for w in res.warnings)


def test_no_fin_motion_with_the_fin_terms_held_fits(still_fin):
    res = OutputErrorEstimator(equation_error_start=False).fit(
        still_fin, rng=0, holds=CoefficientSpec(held={"Czd": 0.0, "Cmd": 0.0}))
    assert res.success, res.message
    assert "not_identifiable" not in res.info
    free = [j for j in range(len(NAMES)) if j not in FIN]
    np.testing.assert_allclose(res.theta[free], TRUTH[free], rtol=RECOVERY_RTOL)
    # a prior names them determined too
    res = EquationErrorEstimator().fit(still_fin, holds=CoefficientSpec(
        priors={"Czd": (0.3, 0.1), "Cmd": (-0.2, 0.1)}))
    assert res.success, res.message
    # the data say nothing of them: the posterior is the prior itself
    np.testing.assert_allclose(res.theta[FIN], [0.3, -0.2], rtol=1e-9)
    np.testing.assert_allclose(res.stderr[FIN], [0.1, 0.1], rtol=1e-9)


@pytest.mark.parametrize("noise", [NoNoise(), GaussianNoise(), PaperNoise()],
                         ids=["none", "gaussian", "paper"])
def test_reference_flight_never_named(noise):
    # the full 50-seed count: benchmarks/identifiability_false_alarms.py (0 of 101 named)
    scenario = reference_scenario()
    for seed in range(3):
        flight = simulate(scenario.airframe, TRUTH, scenario.manoeuvre, noise, rng=seed)
        assert record_findings(flight) == ()


def test_rates_and_roll_findings_on_known_wrong_records():
    scenario = reference_scenario()
    flight = simulate(scenario.airframe, TRUTH, scenario.manoeuvre, GaussianNoise(), rng=0)
    rng = np.random.default_rng(0)
    n = flight.n_samples
    quiet = dataclasses.replace(flight, data=flight.data.assign(
        q=0.005 * rng.standard_normal(n), r=0.005 * rng.standard_normal(n)))
    assert [f.names for f in record_findings(quiet)] == [("Czq", "Cmq")]
    zero = dataclasses.replace(flight, data=flight.data.assign(q=0.0, r=0.0))
    assert [f.names for f in record_findings(zero)] == [("Czq", "Cmq")]
    speed = np.sqrt(flight["u"] ** 2 + flight["v"] ** 2 + flight["w"] ** 2)
    steady = dataclasses.replace(flight, data=flight.data.assign(p=50.0 * speed / speed[0]))
    found = record_findings(steady)
    assert [f.names for f in found] == [("Cl0", "Clp")]
    assert "Cl0 + Clp p d / (2V)" in found[0].reason


def test_verdict_clears_held_and_prior_coefficients(still_fin):
    found = record_findings(still_fin)
    failure, left = record_verdict(found, {}, {})
    assert set(left) == {"Czd", "Cmd"} and "Czd, Cmd: no fin motion" in failure
    assert record_verdict(found, {"Czd": 0.0}, {"Cmd": (0.0, 1.0)}) == (None, {})
    failure, left = record_verdict(found, {"Czd": 0.0}, {})
    assert set(left) == {"Cmd"} and "Czd" not in failure.split(":")[1]
