"""The deflection input checked against the logged deflection, and ``auto`` by default.

Calibration: the right law on every relay the simulator makes (continuous, latched,
delayed and rate-limited, a 2 kHz control-rate relay) agrees at every sample; a wrong
law (sign, phase, amplitude) is refused, a law off by less than a sample is a warning.
The counts are checked against closed forms: a law one sample interval late disagrees at
exactly one sample per logged switch, at the sample the log switches.
"""

from __future__ import annotations

import copy
import logging
import math
from pathlib import Path

import numpy as np
import pytest

import aeroid
from aeroid.errors import AeroidWarning, FlightError
from aeroid.flights import (
    REFUSE_PER_SWITCH,
    WARN_PER_SWITCH,
    check_input,
    input_agreement,
    make_flight,
    resolve_input,
    scenario_from_dict,
    simulate,
)
from aeroid.model import read_toml

SCENARIOS = Path(__file__).resolve().parents[2] / "studies" / "scenarios"
#: Switches in the window of the continuous-relay scenario (the simulator's commanded
#: switches; tests/unit/test_fin_law.py).
N_SWITCHES = 32
#: A fit with the right input on the tactical-IMU continuous relay (seed 11): measured
#: 0.41 % (output-error) and 0.36 % (EKF) mean |error|; held, 10.1 % and 10.9 %.
LAW_MEAN_ERROR_PCT = 1.0


def _scenario(name: str = "continuous_relay", **actuator):
    data = copy.deepcopy(read_toml(SCENARIOS / f"{name}.toml"))
    data["actuator"].update(actuator)
    return scenario_from_dict(data, source=f"{name}.toml")


def _fly(scenario, noise=None, seed=0):
    return simulate(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                    noise or aeroid.NoNoise(), rng=seed)


def _with(flight, *, law=None, delta=None, knots=None, airframe=None):
    """The flight with another fin law, logged deflection or switch knots."""
    channels = {c: flight[c] for c in flight.channels}
    if delta is not None:
        channels["delta"] = delta
    frame = airframe or flight.airframe
    if law is not None:
        frame = frame.replace(fin_law=law)
    metadata = dict(flight.metadata)
    if knots is not None:
        metadata["delta_knots"] = knots
    return make_flight(channels, frame, metadata)


@pytest.fixture(scope="module")
def continuous():
    return _fly(_scenario())


CORRECT = {
    "continuous": {},
    "latched": {"evaluation": "latched"},
    "control rate 2 kHz": {"evaluation": "control_rate", "control_rate_Hz": 2000.0},
}


@pytest.mark.parametrize("name", [*CORRECT, "delayed"])
def test_the_right_law_agrees_at_every_sample(name):
    scenario = (_scenario("delayed_relay") if name == "delayed"
                else _scenario(**CORRECT[name]))
    for flight in (_fly(scenario), _fly(scenario, aeroid.GaussianNoise(), seed=11)):
        agreement = input_agreement(flight, "law")
        assert (agreement.n_agree, agreement.n_samples) == (501, 501)
        assert agreement.first_disagreement_s is None
        assert agreement.n_switches >= N_SWITCHES
        assert agreement.throw_ratio == pytest.approx(1.0, abs=1e-12)
        choice = check_input(flight, "auto")
        assert (choice.input, choice.warnings) == ("law", ())
        # the switch knots the simulator wrote agree too
        assert input_agreement(flight, "events").n_agree == 501


def test_a_law_one_sample_late_disagrees_once_per_switch(continuous):
    # closed form: every switch moves exactly one sample interval, so the model's deflection
    # at the sample where the log switches is still the old one, and nowhere else
    law = continuous.airframe.fin_law
    late = _with(continuous, law=law.replace(delay_s=continuous.dt))
    agreement = input_agreement(late, "law")
    logged = continuous["delta"]
    switch_samples = np.flatnonzero(np.diff(logged) != 0) + 1
    assert switch_samples.size == agreement.n_switches == N_SWITCHES
    assert agreement.n_samples - agreement.n_agree == N_SWITCHES
    assert agreement.first_disagreement_s == continuous.t[switch_samples[0]]
    assert agreement.opposite_sign == N_SWITCHES
    assert agreement.per_switch == REFUSE_PER_SWITCH  # at the edge: a warning, not refused
    (warning,) = check_input(late, "law").warnings
    assert "469 of 501 samples" in warning and "as if its switches were 2 ms off" in warning
    # the estimator's own delay_s is added to the law's: the same disagreement
    assert input_agreement(continuous, "law", delay_s=continuous.dt) == agreement


@pytest.mark.parametrize(("change", "expected"), [
    ({"command_phase_deg": 150.0}, "67 disagreeing samples"),    # phase 90 deg off
    ({"command_amplitude": 1.0}, "86 disagreeing samples"),      # A = 1 for 0.5
])
def test_a_wrong_law_is_refused_in_one_line(continuous, change, expected):
    wrong = _with(continuous, law=continuous.airframe.fin_law.replace(**change))
    with pytest.raises(FlightError, match="input 'law' contradicts the log") as info:
        check_input(wrong, "auto", owner="output-error")
    text = str(info.value)
    assert expected in text and "\n" not in text and "first disagreement at t = " in text


def test_a_log_of_the_opposite_sign_is_refused(continuous):
    flipped = _with(continuous, delta=-continuous["delta"])
    agreement = input_agreement(flipped, "law")
    assert (agreement.n_agree, agreement.opposite_sign) == (0, 501)
    assert agreement.first_disagreement_s == continuous.t[0]
    with pytest.raises(FlightError, match="501 of them of the opposite sign"):
        check_input(flipped, "law")


@pytest.mark.parametrize("change", [
    {"delay_s": 0.001},            # a law 1 ms late: 15 samples (0.47 per switch)
    {"command_amplitude": 0.6},    # A = 0.6 for 0.5: 15 samples
    {"command_phase_deg": 70.0},   # the phase 10 deg off: 11 samples
])
def test_a_law_off_by_less_than_a_sample_is_a_warning(continuous, change):
    near = _with(continuous, law=continuous.airframe.fin_law.replace(**change))
    agreement = input_agreement(near, "law")
    assert WARN_PER_SWITCH < agreement.per_switch <= REFUSE_PER_SWITCH
    (warning,) = check_input(near, "law").warnings
    assert "agrees only in part" in warning and f"{agreement.n_agree} of 501" in warning


def test_a_throw_other_than_delta_max_is_a_warning(continuous):
    # the log's fin moves 8 deg, the airframe says 8.4: the law integrates 8.4 deg
    frame = continuous.airframe.replace(delta_max_deg=8.4, fin_law=None)
    law = continuous.airframe.fin_law.replace(delta_max_rad=frame.delta_max_rad)
    wide = _with(continuous, airframe=frame, law=law)
    agreement = input_agreement(wide, "law")
    assert agreement.n_agree == 501
    assert agreement.throw_ratio == pytest.approx(8.0 / 8.4, rel=1e-12)
    (warning,) = check_input(wide, "law").warnings
    assert "the logged throw is 8 deg, the model's 8.4 deg" in warning


def test_switch_knots_of_the_opposite_sign_are_refused(continuous):
    knots = continuous.metadata["delta_knots"]
    flipped = {"t": knots["t"], "delta": [-v for v in knots["delta"]]}
    with pytest.raises(FlightError, match="input 'events' contradicts the log") as info:
        check_input(_with(continuous, knots=flipped), "events", owner="ekf")
    assert "501 of them of the opposite sign" in str(info.value)
    # and the estimators refuse them before fitting (issue 21: Czd, Cmd came out negated)
    for name in ("output-error", "ekf"):
        with pytest.raises(FlightError, match="contradicts"):
            aeroid.make_estimator(name, {"input": "events"}).fit(
                _with(continuous, knots=flipped), rng=0)


def test_switch_knots_a_sample_late_are_a_warning(continuous):
    knots = continuous.metadata["delta_knots"]
    late = {"t": [knots["t"][0]] + [t + continuous.dt for t in knots["t"][1:]],
            "delta": knots["delta"]}
    agreement = input_agreement(_with(continuous, knots=late), "events")
    assert agreement.n_samples - agreement.n_agree == N_SWITCHES
    assert "agrees only in part" in check_input(_with(continuous, knots=late), "events"
                                                ).warnings[0]


def test_auto_is_the_law_when_the_airframe_has_one(continuous, clean_flight):
    assert resolve_input(continuous, "auto") == ("law", "the airframe has a [fin_law]")
    assert resolve_input(clean_flight, "auto") == ("hold", "the airframe has no [fin_law]")
    assert resolve_input(continuous, "hold") == ("hold", "given")
    # inputs made from the log are not compared with it
    assert check_input(continuous, "hold").agreement is None
    with pytest.raises(FlightError, match="unknown input 'nope'"):
        check_input(continuous, "nope")


# Estimators ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def tactical():
    return _fly(_scenario(), aeroid.GaussianNoise(), seed=11)


@pytest.mark.parametrize("name", ["output-error", "ekf"])
def test_a_continuous_relay_is_fitted_with_its_law_by_default(tactical, name, caplog):
    truth = tactical.true_coefficients
    with caplog.at_level(logging.INFO, logger="aeroid"):
        result = aeroid.make_estimator(name).fit(tactical, rng=0)
    assert result.success, result.message
    assert result.info["input"] == "law"
    assert result.info["input_reason"] == "the airframe has a [fin_law]"
    assert result.info["input_agreement"]["n_agree"] == 501
    assert result.info["options"]["input"] == "auto"
    assert np.mean(result.relative_error_pct(truth)) < LAW_MEAN_ERROR_PCT
    notices = [r.getMessage() for r in caplog.records if "input = law" in r.getMessage()]
    assert len(notices) == 1 and notices[0].startswith(f"{name}: input = law (the airframe")
    # the former default, by name: biased beyond the figure above
    held = aeroid.make_estimator(name, {"input": "hold"}).fit(tactical, rng=0)
    assert held.info["input"] == "hold" and held.info["input_agreement"] is None
    assert np.mean(held.relative_error_pct(truth)) > 5 * LAW_MEAN_ERROR_PCT


def test_a_partial_law_is_a_warning_of_the_result(tactical):
    near = _with(tactical, law=tactical.airframe.fin_law.replace(delay_s=0.001))
    result = aeroid.make_estimator("output-error").fit(near, rng=0)
    assert any("agrees only in part" in w for w in result.warnings)
    assert result.info["input_agreement"]["verdict"] == "partial"


def test_a_contradicting_law_is_refused_by_every_integrating_estimator(continuous):
    wrong = _with(continuous, law=continuous.airframe.fin_law.replace(command_phase_deg=150.0))
    for name, options in [("output-error", {}), ("ekf", {}), ("ukf", {}),
                          ("eam-pso", {"n_particles": 10, "n_iterations": 1}),
                          ("pyswarms", {"objective": "eam", "n_particles": 10,
                                        "n_iterations": 1})]:
        with pytest.raises(FlightError, match=f"{name}: input 'law' contradicts"):
            aeroid.make_estimator(name, options).fit(wrong, rng=0)
    # EBM objectives integrate nothing: no input to check
    result = aeroid.make_estimator("pyswarms", {"n_particles": 10, "n_iterations": 1}).fit(
        wrong, rng=0)
    assert "input" not in result.info


def test_the_cramer_rao_floor_takes_the_law_by_default(continuous):
    noise = aeroid.GaussianNoise()
    auto = aeroid.cramer_rao_sd(continuous, noise)
    np.testing.assert_array_equal(auto, aeroid.cramer_rao_sd(continuous, noise, input="law"))
    assert not np.array_equal(auto, aeroid.cramer_rao_sd(continuous, noise, input="hold"))
    wrong = _with(continuous, delta=-continuous["delta"])
    with pytest.raises(FlightError, match="cramer_rao_sd: input 'law' contradicts"):
        aeroid.cramer_rao_sd(wrong, noise)
    near = _with(continuous, law=continuous.airframe.fin_law.replace(delay_s=0.001))
    with pytest.warns(AeroidWarning, match="agrees only in part"):
        aeroid.cramer_rao_sd(near, noise)


def test_every_estimator_documents_the_same_input_option():
    described = {}
    for name, cls in aeroid.available().items():
        for option in cls.describe_options():
            if option.name == "input":
                described[name] = option
    assert set(described) >= {"output-error", "ekf", "ukf", "eam-pso", "pyswarms"}
    for option in described.values():
        assert option.default == "auto"
        assert option.type == "{auto, hold, midpoint, events, law}"
        assert "auto (default) is law when the flight's airframe has a [fin_law], else " \
               "hold" in option.description


@pytest.mark.parametrize(("name", "options"), [
    ("ukf", {"max_passes": 1}),
    ("eam-pso", {"n_particles": 10, "n_iterations": 2}),
    ("pyswarms", {"objective": "eam", "n_particles": 10, "n_iterations": 2}),
])
def test_every_integrating_estimator_takes_the_law_by_default(continuous, name, options):
    result = aeroid.make_estimator(name, options).fit(continuous, rng=0)
    assert (result.info["input"], result.info["options"]["input"]) == ("law", "auto")
    assert result.info["input_agreement"]["verdict"] == "agrees"
    # the law is what the method integrates: the same numbers as naming it, not as hold
    named = aeroid.make_estimator(name, {**options, "input": "law"}).fit(continuous, rng=0)
    np.testing.assert_array_equal(result.theta, named.theta)
    assert result.cost == named.cost or math.isnan(result.cost)
    held = aeroid.make_estimator(name, {**options, "input": "hold"}).fit(continuous, rng=0)
    assert held.info["input"] == "hold"
    assert not (np.array_equal(held.theta, result.theta) and held.cost == result.cost)


def test_the_command_line_refuses_a_contradicting_law_in_one_line(continuous, tmp_path,
                                                                   capsys):
    from aeroid.cli import main

    wrong = _with(continuous, law=continuous.airframe.fin_law.replace(command_phase_deg=150.0))
    path = tmp_path / "wrong.csv"
    wrong.write(path)
    assert main(["estimate", str(path), "--method", "ekf", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith(f"aeroid: error: {path}: ekf: input 'law' contradicts the log")
