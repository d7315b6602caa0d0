"""The study's Cramér-Rao floors: stored once by the runner, shown by the report.

Independent references: ``aeroid.cramer_rao_sd`` (the per-channel floor with known
positions is exactly its homoscedastic floor with the initial rates estimated) and the
output-error estimator's own information matrix at the truth (CasADi's exact
sensitivities and its own Gaussian prior on the uncertain positions), which must give
the same floors with uncertain positions.
"""

import json

import numpy as np
import pytest
from study_fakes import Echo

from aeroid.estimation import cramer_rao_sd
from aeroid.flights import GaussianNoise, PaperNoise
from aeroid.study import _floors, loads_study, run_study, write_report

REGISTRY = {"echo": Echo}

STUDY = """
[study]
name = "floors"
runs = 2
seed = 7

[[noise]]
label = "paper"
model = "paper"

[[noise]]
label = "tactical"
model = "gaussian"

[[noise]]
label = "clean"
model = "none"

[[estimators]]
label = "A"
method = "echo"
"""
#: Agreement of the floors with the output-error estimator's information at the truth
#: (started from the true rates): its sensitivities are exact (CasADi) where the floor's
#: are central differences, error <= 4e-7 of a column (aeroid/estimation/_floor.py);
#: measured 1.7e-7 at most.
OE_AGREEMENT_RTOL = 1e-6
#: The same computation by two paths (a truth integrated once and cached, or per call;
#: the sensitivity columns in another order): rounding only (measured 2.6e-11).
SAME_FLOOR_RTOL = 1e-9


@pytest.fixture(scope="module")
def study():
    return loads_study(STUDY, registry=REGISTRY)


@pytest.fixture(scope="module")
def floors(study):
    return _floors.study_floors(study)


def test_per_channel_floor_with_known_positions_is_cramer_rao_sd(study, floors):
    tactical = floors["conditions"][1]
    expected = cramer_rao_sd(study.scenario, GaussianNoise(), noise_form="homoscedastic",
                             estimate_initial=("p", "q", "r"))
    np.testing.assert_allclose(tactical["per_channel"], expected, rtol=SAME_FLOOR_RTOL)
    np.testing.assert_allclose(tactical["per_sample"], expected, rtol=SAME_FLOOR_RTOL)  # b=0
    assert tactical["position_sd_m"] == [[0.0] * 3] * 2


def test_uncertain_positions_raise_the_floor_and_per_sample_is_lower(study, floors):
    paper = floors["conditions"][0]
    known = np.asarray(cramer_rao_sd(study.scenario, PaperNoise(), noise_form="homoscedastic",
                                     estimate_initial=("p", "q", "r")))
    assert np.all(np.array(paper["per_channel"]) >= known * (1 - 1e-9))
    assert np.array(paper["per_channel"])[2] > 10 * known[2]  # Czd: the positions' lever
    assert np.all(np.array(paper["per_sample"]) <= np.array(paper["per_channel"]))
    assert floors["conditions"][2]["reason"].startswith("ValueError: fisher: no Cram")


@pytest.mark.parametrize("noise_model, key", [("channel", "per_channel"),
                                              ("signal", "per_sample")])
def test_floors_equal_the_output_error_information_at_the_truth(study, floors, noise_model,
                                                                key, monkeypatch):
    """Output-error's own information matrix, prior on the positions included.

    Its model starts from smoothed measured rates; here from the true ones, the floor's
    linearisation point (the per-sample floor moves by ~1 % with a 1e-3 relative change
    of the initial q, r: the weights of samples near zero crossings are that sensitive).
    """
    pytest.importorskip("casadi")
    from baselines import _common
    from baselines._gauss_newton import fisher_information
    from baselines.output_error import OutputErrorEstimator

    monkeypatch.setattr(_common, "smoothed_start", lambda rates: rates[0].copy())
    flight = _floors.noise_free_flight(study)
    truth = np.asarray(flight.true_coefficients)
    positions = np.asarray(flight.metadata["true_accel_positions_m"])
    sd = PaperNoise().position_sd(positions)
    flight = type(flight)(flight.data, flight.airframe.replace(
        prior=tuple(truth), accel1_position_sd_m=tuple(sd[0]),
        accel2_position_sd_m=tuple(sd[1])), flight.metadata)
    est = OutputErrorEstimator(noise_model=noise_model, substeps=8, compile_model=False)
    prob = est.problem(flight)
    p = np.zeros(prob.model.scale.size)
    p[:truth.size] = 1.0  # the truth (scale = prior = truth)
    y, J = prob.model.outputs_jacobian(p)
    from aeroid.estimation import _floor as fisher

    form = _floors.FLOOR_FORMS[key]
    var = fisher.model_noise_sd(PaperNoise(), y, noise_form=form) ** 2
    info, _ = fisher_information(J, np.zeros_like(y), var)
    info += prob.prior_terms(p)[2]
    cov = np.linalg.inv(info) * np.outer(prob.model.scale, prob.model.scale)
    np.testing.assert_allclose(floors["conditions"][0][key], np.sqrt(np.diag(cov))[:truth.size],
                               rtol=OE_AGREEMENT_RTOL)


def test_the_runner_stores_the_floors_and_the_report_shows_them(study, floors, tmp_path):
    out = tmp_path / "s"
    outcome = run_study(study, out, progress=False)
    stored = json.loads((out / "floors.json").read_text())
    assert stored["fingerprint"] == study.fingerprint()
    for got, want in zip(stored["conditions"], floors["conditions"], strict=True):
        assert got == want
    text = write_report(study, out, outcome.records, figures=False).read_text()
    truth = np.abs(study.scenario.coefficient_vector)
    paper = text.split("## Noise: paper")[1].split("## Noise:")[0]
    for key in ("per_channel", "per_sample"):
        shown = f"{np.array(floors['conditions'][0][key])[3] / truth[3] * 100:.3g}"
        assert shown in paper.split("| Czq |")[1].splitlines()[0], key
    assert "A: per-channel" in paper
    assert "no floor" in text.split("## Noise: clean")[1]


def test_the_report_names_the_floor_each_estimator_can_reach():
    assert _floors.reachable_floor({"noise_model": "signal"}) == "per_sample"
    assert _floors.reachable_floor({"noise_model": "channel"}) == "per_channel"
    assert _floors.reachable_floor({"weighting": "noise"}) == "per_channel"


def test_resume_keeps_the_floors_and_overwrite_moves_them_aside(study, tmp_path, monkeypatch):
    from aeroid.study import _runner

    out = tmp_path / "s"
    run_study(study.with_runs(1), out, progress=False)
    first = (out / "floors.json").read_text()

    def not_again(study):
        raise AssertionError("floors computed again on resume")

    monkeypatch.setattr(_runner, "study_floors", not_again)
    run_study(study, out, resume=True, progress=False)
    assert (out / "floors.json").read_text() == first
    monkeypatch.undo()
    run_study(study, out, overwrite=True, progress=False)
    assert (out / "previous-1" / "floors.json").read_text() == first
    assert (out / "floors.json").exists()


def test_a_folder_without_floors_gets_them_computed_for_the_report(study, floors, tmp_path):
    out = tmp_path / "s"
    outcome = run_study(study, out, progress=False)
    (out / "floors.json").write_text("{not json")
    text = write_report(study, out, outcome.records, figures=False).read_text()
    assert "computed for this report (no valid floors.json)" in text
    czq = np.array(floors["conditions"][1]["per_channel"])[3]
    truth = abs(study.scenario.coefficient_vector[3])
    tactical = text.split("## Noise: tactical")[1]
    assert f"{czq / truth * 100:.3g}" in tactical.split("| Czq |")[1].splitlines()[0]
