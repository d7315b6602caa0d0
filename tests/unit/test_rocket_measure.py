"""Issue 25's measure study (studies/rocket_measure.toml): a sensor-suite condition with a
constant truth fitted as a Cx table is a valid design; a truth that is itself a table is
still refused with a suite condition (the suite simulator flies constant coefficients)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aeroid.errors import StudyError
from aeroid.study import load_study, loads_study

ROOT = Path(__file__).resolve().parents[2]
STUDIES = ROOT / "studies"


def test_measure_study_loads_and_scores_each_table_point_at_the_constant_truth():
    from aeroid.study._tables import has_tables, parameter_truth

    study = load_study(STUDIES / "rocket_measure.toml")
    assert has_tables(study) and study.noise[0].suite is not None
    scenario = study.scenario
    assert scenario.manoeuvre.mass_scale == 1.0 and scenario.airframe.mass_sd_kg == 0.3
    assert study.mass_rel_sd == scenario.airframe.mass_sd_kg / scenario.airframe.mass_kg
    knots = scenario.airframe.tables.to_table()["Cx"]
    names = [f"Cx@M{k:g}" for k in knots] + ["Clp"]
    np.testing.assert_array_equal(parameter_truth(scenario, names), [-0.45] * 5 + [-8.0])


def test_a_table_truth_with_a_suite_condition_is_still_refused(tmp_path):
    text = (STUDIES / "scenarios" / "rocket_measure.toml").read_text()
    assert "Cx = -0.45 " in text
    scenario = tmp_path / "scenarios" / "table_truth.toml"
    scenario.parent.mkdir()
    scenario.write_text(text.replace("Cx = -0.45 ", "Cx = [[0.2, -0.40], [0.9, -0.50]] "))
    study = (STUDIES / "rocket_measure.toml").read_text().replace(
        "scenarios/rocket_measure_mass_right.toml", "scenarios/table_truth.toml")
    assert "table_truth" in study
    with pytest.raises(StudyError, match="sensor-suite condition.*not available with tables"):
        loads_study(study, base_dir=tmp_path)
