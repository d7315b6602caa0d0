"""An airframe without a moving fin (issue 25): declared in the airframe file, a log
without a fin column, the fin terms held at zero with a notice, a moving fin column
refused.

Reference: a flight simulated with the fin terms zero in the truth (so the relay's motion
leaves no trace in the data) logged without its fin column; output-error with the fin
terms held recovers the seven others to its noise-free tolerance.
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np
import pytest

import aeroid
from aeroid.errors import AirframeError, EstimatorError, FlightError
from aeroid.estimation import FIN_TERMS, CoefficientSpec
from aeroid.flights import NoNoise, read_flight, reference_scenario, simulate
from aeroid.model import NAMES, Airframe
from aeroid.model._airframe import save_airframe
from baselines.output_error import OutputErrorEstimator

TRUTH = aeroid.nominal()
FIN = [NAMES.index(n) for n in FIN_TERMS]
#: Output-error's noise-free recovery (tests/unit/test_baselines_output_error.py).
RECOVERY_RTOL = 1e-4


def _passive(airframe: Airframe) -> Airframe:
    return airframe.replace(fin="passive", delta_max_deg=None, fin_law=None)


@pytest.fixture(scope="module")
def passive_log(tmp_path_factory):
    """A log without fin column and its passive-fin airframe file."""
    folder = tmp_path_factory.mktemp("passive")
    scenario = reference_scenario()
    theta = TRUTH.copy()
    theta[FIN] = 0.0
    flight = simulate(scenario.airframe, theta, scenario.manoeuvre, NoNoise(), rng=0)
    csv = folder / "log.csv"
    flight.data.drop(columns="delta").to_csv(csv, index=False)
    with_fin = folder / "with_fin.csv"
    flight.data.to_csv(with_fin, index=False)
    toml = folder / "airframe.toml"
    save_airframe(_passive(flight.airframe), toml)
    return csv, with_fin, toml, theta


def test_airframe_file_declares_the_passive_fin(passive_log):
    _, _, toml, _ = passive_log
    text = toml.read_text()
    assert 'fin = "passive"' in text and "delta_max_deg" not in text
    airframe = aeroid.load_airframe(toml)
    assert airframe.fin == "passive" and airframe.delta_max_deg is None
    with pytest.raises(AirframeError, match="no fin throw"):
        _ = airframe.delta_max_rad


@pytest.mark.parametrize(("changes", "words"), [
    ({"fin": "fixed"}, "fin must be one of relay, passive"),
    ({"fin": "passive"}, "no moving fin, so no delta_max_deg"),
    ({"delta_max_deg": None}, "delta_max_deg is required for a moving fin"),
])
def test_bad_fin_declarations_are_one_line(changes, words):
    airframe = reference_scenario().airframe
    with pytest.raises(AirframeError, match=words) as info:
        airframe.replace(**changes)
    assert "\n" not in str(info.value)


def test_log_without_fin_column_is_read_with_a_notice(passive_log, caplog):
    csv, _, toml, _ = passive_log
    with caplog.at_level(logging.INFO, logger="aeroid"):
        flight = read_flight(csv, airframe=toml)
    assert np.all(flight["delta"] == 0.0)
    assert any("fin is passive" in n for n in flight.notes)
    assert any("fin is passive" in r.getMessage() for r in caplog.records)


def test_moving_fin_column_is_refused(passive_log):
    _, with_fin, toml, _ = passive_log
    with pytest.raises(FlightError, match="moves with a passive fin") as info:
        read_flight(with_fin, airframe=toml)
    assert "\n" not in str(info.value)
    flight = read_flight(passive_log[0], airframe=toml)
    moved = dataclasses.replace(flight, data=flight.data.assign(delta=0.01))
    with pytest.raises(FlightError, match="moves with a passive fin"):
        moved.validate()


def test_fits_hold_the_fin_terms_at_zero(passive_log, caplog):
    csv, _, toml, theta = passive_log
    flight = read_flight(csv, airframe=toml)
    with caplog.at_level(logging.INFO, logger="aeroid"):
        res = OutputErrorEstimator(equation_error_start=False).fit(flight, rng=0)
    assert res.success, res.message
    assert res.held == dict.fromkeys(FIN_TERMS, 0.0)
    said = [r.getMessage() for r in caplog.records]
    assert any("Czd = 0 (passive fin)" in m for m in said)
    assert not any("not identifiable" in m for m in said)  # held: nothing to say
    free = [j for j in range(len(NAMES)) if j not in FIN]
    np.testing.assert_allclose(res.theta[free], theta[free], rtol=RECOVERY_RTOL)
    assert np.all(np.isnan(res.stderr[FIN]))
    # a contradicting hold or prior on a fin term: one line
    with pytest.raises(EstimatorError, match="declared twice"):
        OutputErrorEstimator().fit(flight, holds=CoefficientSpec(priors={"Czd": (0.0, 1.0)}))
    same = OutputErrorEstimator(equation_error_start=False).fit(
        flight, rng=0, holds=CoefficientSpec(held={"Czd": 0.0}))
    np.testing.assert_array_equal(same.theta, res.theta)
