"""The fin law in the files: the airframe's ``[fin_law]`` and the scenario's ``[actuator]``."""

from __future__ import annotations

import copy
import json
import math
import tomllib
from pathlib import Path

import pytest

from aeroid.errors import AirframeError
from aeroid.flights import Manoeuvre, load_scenario, scenario_from_dict
from aeroid.model import (
    Airframe,
    FinLaw,
    dumps_toml,
    load_airframe,
    reference_airframe,
    reference_scenario_data,
    save_airframe,
)
from aeroid.study import load_study

LAW_TABLE = {"command_amplitude": [[0.0, 0.5], [2.0, 0.8]],
             "command_phase_deg": 45.0, "delay_s": 0.001, "rate_limit_dps": 8000.0}


def _airframe_file(tmp_path, law_table) -> str:
    data = reference_airframe().to_dict()
    data["fin_law"] = law_table
    path = tmp_path / "a.toml"
    path.write_text(dumps_toml(data))
    return str(path)


def _error(call, *args) -> str:
    with pytest.raises(AirframeError) as info:
        call(*args)
    message = str(info.value)
    assert "\n" not in message
    return message


# Airframe [fin_law] ----------------------------------------------------------------
def test_fin_law_table_is_read_and_round_trips(tmp_path):
    airframe = load_airframe(_airframe_file(tmp_path, LAW_TABLE))
    law = airframe.fin_law
    assert law == FinLaw(delta_max_rad=math.radians(8.0),
                         command_amplitude=((0.0, 0.5), (2.0, 0.8)), command_phase_deg=45.0,
                         delay_s=0.001, rate_limit_dps=8000.0)
    assert law.amplitude(1.0) == pytest.approx(0.65) and law.rate_limit_radps == pytest.approx(
        math.radians(8000.0))
    save_airframe(airframe, tmp_path / "b.toml")
    assert load_airframe(tmp_path / "b.toml") == airframe
    assert airframe.to_dict()["fin_law"] == LAW_TABLE | {"command_phase_deg": 45.0}


def test_fin_law_defaults_and_no_table():
    assert reference_airframe().fin_law is None
    assert "fin_law" not in reference_airframe().to_dict()
    law = FinLaw.from_table({"command_amplitude": 0.5, "command_phase_deg": 60},
                            delta_max_rad=0.1, where="x")
    assert (law.delay_s, law.rate_limit_dps, law.command_phase_deg) == (0.0, None, 60.0)


@pytest.mark.parametrize(("table", "message"), [
    ({"command_amplitude": 0.5}, "[fin_law] is missing command_phase_deg"),
    (LAW_TABLE | {"gain": 1.0}, "[fin_law] has unknown key(s) gain"),
    (LAW_TABLE | {"delay_s": True}, "[fin_law] delay_s must be a finite number, got True"),
    (LAW_TABLE | {"delay_s": -0.001}, "[fin_law]: delay_s must be in [0, 1) s, got -0.001"),
    (LAW_TABLE | {"delay_s": 5.0}, "milliseconds written as seconds?"),
    (LAW_TABLE | {"rate_limit_dps": 0.0}, "[fin_law]: rate_limit_dps must be positive"),
    (LAW_TABLE | {"command_amplitude": "0.5"},
     "[fin_law] command_amplitude must be a number or a list of [time_s, value] pairs"),
    (LAW_TABLE | {"command_amplitude": []}, "command_amplitude must be a number or a list"),
    (LAW_TABLE | {"command_phase_deg": [[0.0, 1.0, 2.0]]}, "is not two finite numbers"),
    (LAW_TABLE | {"command_phase_deg": [[0.0, True]]}, "is not two finite numbers"),
    (LAW_TABLE | {"command_phase_deg": [[1.0, 0.0], [1.0, 5.0]]},
     "[fin_law] command_phase_deg: the times of the pairs must increase strictly"),
])
def test_fin_law_mistakes_are_one_line(tmp_path, table, message):
    path = _airframe_file(tmp_path, table)
    text = _error(load_airframe, path)
    assert text.startswith(f"{path}: ") and message in text


def test_a_long_path_keeps_the_reason(tmp_path):
    """The message names the whole path and still says what is wrong: the value is cut,
    not the message (cut at 200 characters, the reason went with a path of ~110)."""
    folder = tmp_path / ("d" * 150)
    folder.mkdir()
    long_value = [[0.0, 1.0, 2.0, *range(100)]]
    path = _airframe_file(folder, LAW_TABLE | {"command_phase_deg": long_value})
    text = _error(load_airframe, path)
    assert text.startswith(f"{path}: [fin_law] command_phase_deg must be")
    assert text.endswith("... is not two finite numbers") and len(text) < len(path) + 200


def test_fin_law_not_a_table():
    data = reference_airframe().to_dict() | {"fin_law": 3.0}
    assert _error(Airframe.from_dict, data) == "airframe: [fin_law] must be a table, got 3.0"


def test_fin_law_must_match_the_fin_throw():
    law = FinLaw(delta_max_rad=0.2)
    with pytest.raises(AirframeError, match="fin_law must be a FinLaw with delta_max_rad"):
        reference_airframe().replace(fin_law=law)
    with pytest.raises(AirframeError, match="fin_law must be a FinLaw"):
        reference_airframe().replace(fin_law={"command_amplitude": 0.5})
    assert isinstance(reference_airframe().replace(
        fin_law=FinLaw(delta_max_rad=math.radians(8.0))), Airframe)


# Scenario [actuator] ------------------------------------------------------------------
def _scenario(edit):
    data = copy.deepcopy(reference_scenario_data())
    edit(data)
    return scenario_from_dict(data, source="s.toml")


def test_reference_actuator_is_the_latched_paper_law():
    manoeuvre = load_scenario(None).manoeuvre
    assert manoeuvre == Manoeuvre()
    assert (manoeuvre.evaluation, manoeuvre.delay_s, manoeuvre.rate_limit_dps) == (
        "latched", 0.0, None)
    assert manoeuvre.describe() == {
        "command_amplitude": 0.5, "command_phase_deg": 60.0,
        "initial_state": manoeuvre.initial_state, "sample_rate_hz": 500.0,
        "window_s": (5.0, 6.0), "truth_substeps": 8}


def test_actuator_keys_are_read():
    scenario = _scenario(lambda d: d["actuator"].update(
        LAW_TABLE | {"evaluation": "continuous"}))
    m = scenario.manoeuvre
    assert (m.evaluation, m.delay_s, m.rate_limit_dps) == ("continuous", 0.001, 8000.0)
    assert m.command_amplitude == ((0.0, 0.5), (2.0, 0.8))
    assert m.fin_law(0.1) == FinLaw(delta_max_rad=0.1, **{
        k: v for k, v in m.describe().items() if k in LAW_TABLE})
    assert m.describe()["evaluation"] == "continuous"
    clocked = _scenario(lambda d: d["actuator"].update(control_rate_Hz=2000))
    assert (clocked.manoeuvre.evaluation, clocked.manoeuvre.control_rate_hz) == (
        "control_rate", 2000.0)


def test_scenario_may_tell_the_estimators_a_fin_law():
    scenario = _scenario(lambda d: d.update(fin_law={"command_amplitude": 0.5,
                                                     "command_phase_deg": 60.0}))
    assert scenario.airframe.fin_law == scenario.manoeuvre.fin_law(
        scenario.airframe.delta_max_rad)


@pytest.mark.parametrize(("edit", "message"), [
    ({"evaluation": "analog"}, "evaluation must be one of 'latched', 'continuous', "
                               "'control_rate', got 'analog'"),
    ({"evaluation": 1}, "[actuator] evaluation must be a non-empty string, got 1"),
    ({"evaluation": "control_rate"}, "control_rate_Hz goes with evaluation"),
    ({"evaluation": "continuous", "control_rate_Hz": 1000.0},
     "control_rate_Hz goes with evaluation"),
    ({"control_rate_Hz": -5.0}, "control_rate_Hz must be positive"),
    ({"control_rate_Hz": "fast"}, "[actuator] control_rate_Hz must be a finite number"),
    ({"delay_s": -1.0}, "delay_s must be in [0, 1) s"),
    ({"rate_limit_dps": False}, "[actuator] rate_limit_dps must be a finite number"),
    ({"command_amplitude": [[0, 1], [0, 2]]}, "times of the pairs must increase strictly"),
    ({"gain": 2.0}, "[actuator] has unknown key(s) gain"),
])
def test_actuator_mistakes_are_one_line(edit, message):
    text = _error(_scenario, lambda d: d["actuator"].update(edit))
    assert text.startswith("s.toml") and message in text


def test_manoeuvre_checks_its_fin_law_fields():
    with pytest.raises(AirframeError, match="manoeuvre: delay_s must be in"):
        Manoeuvre(delay_s=2.0)
    with pytest.raises(AirframeError, match="manoeuvre: command_amplitude must be a number"):
        Manoeuvre(command_amplitude="big")


# The scenario and study files of the relay studies ------------------------------------
STUDIES = Path(__file__).resolve().parents[2] / "studies"
#: Estimator options the relay studies use that aeroid does not have yet (issue 10).
NEW_OPTIONS = ("input", "estimate_delay")


@pytest.mark.parametrize("name", ["continuous_relay.toml", "delayed_relay.toml"])
def test_relay_scenarios_tell_the_estimators_the_true_law(name):
    scenario = load_scenario(STUDIES / "scenarios" / name)
    assert scenario.manoeuvre.evaluation == "continuous"
    assert scenario.airframe.fin_law == scenario.manoeuvre.fin_law(
        scenario.airframe.delta_max_rad)
    reference = load_scenario(None)
    assert scenario.coefficients == reference.coefficients
    assert scenario.airframe.replace(fin_law=None) == reference.airframe


def _stripped(path: Path, tmp_path: Path) -> Path:
    """The study file without the options of NEW_OPTIONS (scenario path made absolute)."""
    data = tomllib.loads(path.read_text())
    lines = ["[study]"]
    for key, value in data["study"].items():
        if key == "scenario":
            value = str(path.parent / value)
        lines.append(f"{key} = {json.dumps(value)}")
    for noise in data["noise"]:
        lines += ["[[noise]]", *(f"{k} = {json.dumps(v)}" for k, v in noise.items())]
    for entry in data["estimators"]:
        options = {k: v for k, v in entry.get("options", {}).items() if k not in NEW_OPTIONS}
        lines += ["[[estimators]]", f"label = {json.dumps(entry['label'])}",
                  f"method = {json.dumps(entry['method'])}",
                  "options = {" + ", ".join(f"{k} = {json.dumps(v)}"
                                            for k, v in options.items()) + "}"]
    out = tmp_path / path.name
    out.write_text("\n".join(lines) + "\n")
    return out


@pytest.mark.parametrize("name", ["continuous_relay.toml", "delayed_relay.toml"])
def test_relay_studies_load_but_for_the_planned_options(name, tmp_path):
    study = load_study(_stripped(STUDIES / name, tmp_path))
    assert study.scenario.manoeuvre.evaluation == "continuous"
    assert {e.method for e in study.estimators} >= {"output-error", "ekf", "ukf",
                                                    "equation-error"}


@pytest.mark.parametrize("name", ["continuous_relay.toml", "delayed_relay.toml"])
def test_relay_studies_load_as_they_are(name):
    load_study(STUDIES / name)
