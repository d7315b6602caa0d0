"""A study's ``[perturb] mass_rel_sd``: each run flies its own mass, drawn from the stated
sd on the run's own seed child; the estimators keep the file's mass (aeroid/study/_perturb.py).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

import aeroid
from aeroid import EstimationResult, Estimator
from aeroid.errors import StudyError
from aeroid.study import loads_study
from aeroid.study._fits import flight_seed, simulate_run
from aeroid.study._metrics import tidy
from aeroid.study._perturb import perturb_lines, perturb_seed, run_mass_scale
from aeroid.study._runner import run_study

ROOT = Path(__file__).resolve().parents[2]
#: The chi-square test's two-sided level: a correct sampler fails it once in 1000 runs.
CHI2_LEVEL = 1e-3


@dataclass(frozen=True, kw_only=True)
class Prior(Estimator):
    """Returns the prior (the study's machinery, not an estimator, is under test)."""

    name = "prior"

    def run(self, flight, rng):
        return EstimationResult(estimator=self.name, theta=flight.airframe.prior_vector())


REGISTRY = {"prior": Prior}

STUDY = """
[study]
runs = {runs}
seed = 11
{extra}

[[noise]]
label = "imu"
model = "gaussian"
accel_sd_mps2 = 0.1

[[estimators]]
label = "prior"
method = "prior"
"""


def _study(extra: str = "[perturb]\nmass_rel_sd = 0.03", runs: int = 3):
    return loads_study(STUDY.format(runs=runs, extra=extra), registry=REGISTRY)


def test_the_draw_is_the_runs_own_seed_child_and_repeats():
    study = _study()
    base = study.scenario.manoeuvre.mass_scale
    for run in range(3):
        z = np.random.default_rng(np.random.SeedSequence(11, spawn_key=(run, 3))).standard_normal()
        assert run_mass_scale(study, run) == base * (1.0 + 0.03 * z)
        assert run_mass_scale(study, run) == run_mass_scale(_study(runs=7), run)  # same seed
    assert perturb_seed(11, 2).spawn_key == (2, 3)
    assert run_mass_scale(_study(extra=""), 0) is None


def test_the_draws_sd_is_the_stated_one():
    """2000 draws: (n-1) s^2 / sd^2 is chi-square(n-1) and the mean is N(0, sd^2 / n)."""
    study = _study(runs=2000)
    rel = np.array([run_mass_scale(study, i) for i in range(study.runs)]) - 1.0
    n = rel.size
    statistic = (n - 1) * rel.var(ddof=1) / 0.03 ** 2
    lo, hi = stats.chi2.ppf([CHI2_LEVEL / 2, 1 - CHI2_LEVEL / 2], n - 1)
    assert lo < statistic < hi
    assert abs(rel.mean()) < stats.norm.ppf(1 - CHI2_LEVEL / 2) * 0.03 / np.sqrt(n)
    assert stats.kstest(rel / 0.03, "norm").pvalue > CHI2_LEVEL


def test_the_run_flies_its_drawn_mass_and_the_flight_keeps_the_files():
    study = _study()
    scale = run_mass_scale(study, 1)
    scenario = study.scenario
    flight = simulate_run(study, 1, 0)
    manoeuvre = dataclasses.replace(scenario.manoeuvre, mass_scale=scale)
    expected = aeroid.simulate(scenario.airframe, scenario.coefficient_vector, manoeuvre,
                               study.noise[0].model,
                               rng=np.random.default_rng(flight_seed(study.seed, 1)))
    np.testing.assert_array_equal(flight.data.to_numpy(), expected.data.to_numpy())
    assert flight.airframe.mass_kg == scenario.airframe.mass_kg  # the estimators' mass
    unperturbed = simulate_run(_study(extra=""), 1, 0)
    assert not np.array_equal(flight.data["ax1"], unperturbed.data["ax1"])  # it moved


def test_records_results_table_and_report_hold_each_runs_draw(tmp_path):
    study = _study()
    outcome = run_study(study, tmp_path / "out", progress=False)
    for r in outcome.records:
        assert r["mass_scale"] == run_mass_scale(study, r["run"])
        assert r["mass_kg_flown"] == pytest.approx(
            r["mass_scale"] * study.scenario.airframe.mass_kg, rel=1e-15)
    frame = tidy(outcome.records)
    assert set(frame.groupby("run")["mass_scale"].first()) == {
        run_mass_scale(study, i) for i in range(3)}
    lines = perturb_lines(outcome.records, study)
    assert lines[0].startswith("## The flown mass") and len(lines) == 7 + 3 + 1
    assert lines[7] == f"| 0 | {run_mass_scale(study, 0):.5f} | " + (
        f"{run_mass_scale(study, 0) * study.scenario.airframe.mass_kg:.4f} | "
        f"{run_mass_scale(study, 0) - 1.0:+.4f} |")
    plain = run_study(_study(extra=""), tmp_path / "plain", progress=False)
    assert "mass_scale" not in plain.records[0] and "mass_scale" not in tidy(plain.records)
    assert perturb_lines(plain.records, _study(extra="")) == []


def test_the_design_and_fingerprint_say_it():
    with_draw, without = _study(), _study(extra="")
    assert with_draw.describe()["perturb"] == {"mass_rel_sd": 0.03}
    assert "perturb" not in without.describe()
    assert with_draw.fingerprint() != without.fingerprint()
    assert _study(extra="[perturb]\nmass_rel_sd = 0.02").fingerprint() != with_draw.fingerprint()


@pytest.mark.parametrize(("extra", "expected"), [
    ("[perturb]\nmass_rel_sd = 0", r"\[perturb\] mass_rel_sd must be a number in \(0, 0.1\]"),
    ("[perturb]\nmass_rel_sd = -0.01", "mass_rel_sd must be a number"),
    ("[perturb]\nmass_rel_sd = 0.2", "mass_rel_sd must be a number"),
    ("[perturb]\nmass_rel_sd = nan", "mass_rel_sd must be a number"),
    ("[perturb]\nmass_rel_sd = true", "mass_rel_sd must be a number"),
    ("[perturb]\nmass_rel_sd = \"3 %\"", "mass_rel_sd must be a number"),
    ("[perturb]\ninertia_rel_sd = 0.03", r"unknown key\(s\) inertia_rel_sd"),
])
def test_bad_perturb_fails_on_load_with_one_line(extra, expected):
    with pytest.raises(StudyError, match=expected) as info:
        _study(extra=extra)
    assert "\n" not in str(info.value) and str(info.value).startswith("<string>")
    with pytest.raises(StudyError, match=r"<string>: \[perturb\] must be a table"):
        loads_study("perturb = 3\n" + STUDY.format(runs=1, extra=""), registry=REGISTRY)


def test_draws_the_simulator_would_refuse_are_refused_on_load(tmp_path):
    text = (ROOT / "studies" / "scenarios" / "rocket_coast.toml").read_text()
    assert text.count("[initial_state]") == 1 and "mass_scale" not in text
    (tmp_path / "heavy.toml").write_text(text.replace("[initial_state]",
                                                      "[initial_state]\nmass_scale = 1.9"))
    study = STUDY.format(runs=1, extra='scenario = "heavy.toml"\n[perturb]\nmass_rel_sd = 0.05')
    with pytest.raises(StudyError, match=r"a \+6-sd draw is refused .*mass_scale must be in"):
        loads_study(study, base_dir=tmp_path, registry=REGISTRY)
    ok = loads_study(study.replace("0.05", "0.005"), base_dir=tmp_path, registry=REGISTRY)
    assert ok.scenario.manoeuvre.mass_scale == 1.9 and ok.mass_rel_sd == 0.005


def test_a_records_consider_fields_tell_the_share_from_the_method_own():
    from types import SimpleNamespace

    from aeroid.study._fits import consider_fields

    consider = SimpleNamespace(names=("mass_kg",), stderr_without=np.array([0.1, np.inf]),
                               stderr_share=np.array([0.3, 0.0]),
                               refit_messages=("mass_kg = 9.7: max_iterations (200) reached",))
    info = {"attitude_offset_rad": {"phi": 1e-3, "theta": -2e-4},
            "attitude_offset_stderr_rad": {"phi": 3e-3, "theta": 1e-4}}
    out = consider_fields(SimpleNamespace(consider=consider, info=info))
    assert out == {"consider": {"names": ["mass_kg"], "stderr_without": [0.1, None],
                                "stderr_share": [0.3, 0.0],
                                "refit_messages": ["mass_kg = 9.7: max_iterations (200) reached"]},
                   "attitude_offset": {"phi": [1e-3, 3e-3], "theta": [-2e-4, 1e-4]}}
    assert consider_fields(SimpleNamespace(consider=None, info={})) == {}
