"""Scenario files: every table and key checked, types included, sizes bounded."""

from __future__ import annotations

import copy

import pytest

from aeroid.errors import AirframeError
from aeroid.flights import load_scenario, scenario_from_dict
from aeroid.model import dumps_toml, reference_scenario_data


def _error(data) -> str:
    with pytest.raises(AirframeError) as info:
        scenario_from_dict(data, source="s.toml")
    message = str(info.value)
    assert "\n" not in message and message.startswith("s.toml")
    return message


def _with(edit):
    data = copy.deepcopy(reference_scenario_data())
    edit(data)
    return data


def test_reference_scenario_loads_and_round_trips_through_a_file(tmp_path):
    reference = load_scenario(None)
    path = tmp_path / "s.toml"
    path.write_text(dumps_toml({k: v for k, v in reference_scenario_data().items()
                                if k != "noise"}) + "[noise.paper]\naccelerations_xi = 0.05\n")
    again = load_scenario(path)
    assert again.airframe == reference.airframe
    assert again.manoeuvre == reference.manoeuvre
    assert again.coefficients == reference.coefficients and again.noise == reference.noise


@pytest.mark.parametrize(("edit", "message"), [
    (lambda d: d.update(recordings={}), "unknown table(s) recordings"),
    (lambda d: d["recording"].update(rate_Hz=500.0), "[recording] has unknown key(s) rate_Hz"),
    (lambda d: d["actuator"].update(amplitude=0.5), "[actuator] has unknown key(s) amplitude"),
    (lambda d: d["initial_state"].pop("q_radps"), "[initial_state] is missing q_radps"),
    (lambda d: d["initial_state"].update(u_mps=True),
     "[initial_state] u_mps must be a finite number, got True"),
    (lambda d: d["recording"].update(window_s=[5.0]),
     "[recording] window_s must be 2 finite numbers"),
    (lambda d: d["recording"].update(truth_rk4_substeps=8.5),
     "[recording] truth_rk4_substeps must be an integer, got 8.5"),
    (lambda d: d["recording"].update(sample_rate_Hz="500"),
     "[recording] sample_rate_Hz must be a finite number, got '500'"),
    (lambda d: d["coefficients"].update(Cx=False), "[coefficients] Cx must be a finite number"),
    (lambda d: d["coefficients"].update(Cy=1.0), "[coefficients] has unknown key(s) Cy"),
    (lambda d: d.update(noise={"laplace": {}}), "[noise] has unknown key(s) laplace"),
    (lambda d: d["noise"]["paper"].update(rates_xi="x"),
     "noise model 'paper': rates_xi must be a finite number >= 0, got 'x'"),
    (lambda d: d["noise"].update(gaussian={"sigma": 1.0}),
     "noise model 'gaussian': unknown option(s) ['sigma']"),
    (lambda d: d["recording"].update(window_s=[5.0, 1e9]), "RK4 steps (limit 1e+08)"),
    (lambda d: d.pop("atmosphere"), "no [atmosphere] table"),
])
def test_scenario_mistakes_are_one_line(edit, message):
    assert message in _error(_with(edit))


def test_scenario_must_be_a_table():
    assert "s.toml must be a table" in _error(["airframe"])
