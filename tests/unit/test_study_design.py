"""Study files: what loads, and every malformed file failing on load with one line."""

import os
import textwrap
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pytest

from aeroid import EstimationResult, Estimator
from aeroid.cli import main
from aeroid.errors import StudyError
from aeroid.flights._noise import GaussianNoise, NoNoise, PaperNoise
from aeroid.study import _design as design
from aeroid.study._design import load_study, loads_study


@dataclass(frozen=True, kw_only=True)
class Prior(Estimator):
    """Returns the prior; options only to exercise option parsing."""

    name = "prior"
    n_iterations: int = 10
    mode: Literal["a", "b"] = "a"

    def run(self, flight, rng):
        return EstimationResult(estimator=self.name, theta=flight.airframe.prior_vector())


@dataclass(frozen=True, kw_only=True)
class Other(Prior):
    name = "other"


REGISTRY = {"prior": Prior, "other": Other}

GOOD = """
[study]
name = "demo"
description = "two noise conditions, one method under two labels"
runs = 4
seed = 7

[[noise]]
label = "paper 0.02"
model = "paper"
accelerations_xi = 0.02
rates_xi = 0.02

[[noise]]
label = "imu"
model = "gaussian"
accel_sd_mps2 = 0.1

[[noise]]
label = "clean"
model = "none"

[[estimators]]
label = "P10"
method = "prior"

[[estimators]]
label = "P99"
method = "prior"
options = { n_iterations = 99, mode = "b" }
"""


def test_good_study_loads_with_every_setting():
    study = loads_study(GOOD, registry=REGISTRY)
    assert (study.name, study.runs, study.seed, study.n_fits) == ("demo", 4, 7, 4 * 3 * 2)
    paper, imu, clean = (n.model for n in study.noise)
    # unspecified paper options come from the reference scenario's [noise.paper] table
    assert paper == PaperNoise(accelerations_xi=0.02, rates_xi=0.02, accel_position_xi=0.1)
    assert imu == GaussianNoise(accel_sd_mps2=0.1)
    assert clean == NoNoise()
    assert [e.label for e in study.estimators] == ["P10", "P99"]
    assert study.estimators[1].estimator == Prior(n_iterations=99, mode="b")
    assert study.estimators[0].method == "prior"
    quick = load_study(None, registry={"ekf": Prior})
    np.testing.assert_array_equal(study.scenario.coefficient_vector,
                                  quick.scenario.coefficient_vector)


def test_fingerprint_ignores_runs_but_not_seed_or_options():
    base = loads_study(GOOD, registry=REGISTRY)
    assert base.with_runs(50).fingerprint() == base.fingerprint()
    assert loads_study(GOOD.replace("seed = 7", "seed = 8"),
                       registry=REGISTRY).fingerprint() != base.fingerprint()
    assert loads_study(GOOD.replace("n_iterations = 99", "n_iterations = 98"),
                       registry=REGISTRY).fingerprint() != base.fingerprint()


def test_scenario_path_is_relative_to_the_study_file(tmp_path):
    from aeroid.model._airframe import reference_scenario_data

    text = (design.quick_study_path().parent / "reference-scenario.toml").read_text()
    text = text.replace("Cx = -0.98", "Cx = -0.99")
    assert "Cx = -0.99" in text
    (tmp_path / "scen").mkdir()
    (tmp_path / "scen" / "s.toml").write_text(text)
    with_scenario = GOOD.replace("seed = 7", 'seed = 7\nscenario = "scen/s.toml"')
    (tmp_path / "st.toml").write_text(with_scenario)
    study = load_study(tmp_path / "st.toml", registry=REGISTRY)
    assert study.scenario.coefficients[0] == -0.99
    assert reference_scenario_data()["coefficients"]["Cx"] == -0.98


BAD = [
    ("[study\nruns = 1", "invalid TOML"),
    (GOOD.replace("runs = 4\n", ""), "[study] is missing runs"),
    (GOOD.replace("seed = 7\n", ""), "[study] is missing seed"),
    (GOOD.replace("runs = 4", "runs = 0"), "runs must be an integer >= 1"),
    (GOOD.replace("runs = 4", "runs = 2.5"), "runs must be an integer >= 1"),
    (GOOD.replace("runs = 4", "runs = 1e9"), "runs must be an integer >= 1, got 1000000000.0"),
    (GOOD.replace("seed = 7", "seed = 7\nsed = 1"), "[study] has unknown key(s) sed"),
    (GOOD + "\n[extra]\na = 1\n", "unknown table(s) extra"),
    (GOOD.replace('method = "prior"\n\n[[estimators]]', 'method = "nope"\n\n[[estimators]]'),
     "[[estimators]] #1 (P10): unknown method 'nope'"),
    (GOOD.replace("n_iterations = 99", "n_iteration = 99"),
     "[[estimators]] #2 (P99): prior: unknown option(s) n_iteration"),
    (GOOD.replace("n_iterations = 99", 'n_iterations = "many"'),
     "option n_iterations expects an integer"),
    (GOOD.replace('mode = "b"', 'mode = "c"'), "option mode='c' not one of"),
    (GOOD.replace('label = "P99"', 'label = "P10"'), "label(s) given twice: P10"),
    (GOOD.replace('model = "none"', 'model = "pink"'), "unknown noise model 'pink'"),
    (GOOD.replace("accel_sd_mps2 = 0.1", "accel_sd = 0.1"), "[[noise]] #2 (imu): noise model"),
    (GOOD.replace('label = "imu"\n', ""), "[[noise]] #2 is missing label"),
    (GOOD.replace('label = "P10"\n', ""), "[[estimators]] #1 is missing label"),
    (GOOD.split("[[estimators]]")[0], "no [[estimators]] entry"),
    (GOOD.replace("seed = 7", 'seed = 7\nscenario = "missing.toml"'), "missing.toml"),
    # option values and sizes are checked before any run starts
    (GOOD.replace('method = "prior"\n\n[[estimators]]', 'method = ["x"]\n\n[[estimators]]'),
     "[[estimators]] #1 (P10): method must be a string"),
    (GOOD.replace("runs = 4", "runs = 1000000000"), "runs = 1000000000 is over the limit"),
    (GOOD.replace("runs = 4", "runs = 90000") + '[[estimators]]\nlabel = "Q"\nmethod = "other"\n'
     '[[estimators]]\nlabel = "R"\nmethod = "other"\n', "= 1080000 fits is over the limit"),
    (GOOD.replace("accel_sd_mps2 = 0.1", 'accel_sd_mps2 = "0.1"'),
     "[[noise]] #2 (imu): noise model 'gaussian': accel_sd_mps2 must be a finite number >= 0, "
     "got '0.1'"),
    (GOOD.replace("rates_xi = 0.02", "rates_xi = true"),
     "rates_xi must be a finite number >= 0, got True"),
    (GOOD.replace("accel_sd_mps2 = 0.1", "accel_sd_mps2 = -0.1"), "got -0.1"),
    (GOOD.replace("accel_sd_mps2 = 0.1", "accel_sd_mps2 = nan"), "got nan"),
    (GOOD.replace('model = "gaussian"', "model = 3"), "(imu): model must be a string"),
    (GOOD.replace("seed = 7", 'seed = 7\nscenario = "/dev/zero"'),
     "[study] scenario: /dev/zero: not a regular file"),
    (GOOD.replace("seed = 7", 'seed = 7\nscenario = "."'), "a folder (a TOML file is expected)"),
    (GOOD.replace('name = "demo"', 'name = ".."'), "name must be a non-empty printable"),
    (GOOD.replace('name = "demo"', 'name = "a\\\\b"'), "without '/', '\\'"),
]


@pytest.mark.parametrize(("text", "expected"), BAD, ids=[b[1][:30] for b in BAD])
def test_malformed_study_fails_on_load_with_one_line(tmp_path, text, expected):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(StudyError) as info:
        load_study(path, registry=REGISTRY)
    message = str(info.value)
    assert expected in message
    assert message.startswith(str(path)) and "\n" not in message


def test_a_noise_model_that_fails_on_data_fails_on_load(monkeypatch):
    """A model that accepts its options but cannot corrupt a flight fails before any run."""
    from aeroid.flights import GaussianNoise

    def broken(self, channels, rng):
        raise TypeError("can't multiply sequence by non-int of type 'float'")

    monkeypatch.setattr(GaussianNoise, "corrupt", broken)
    with pytest.raises(StudyError, match=r"\[\[noise\]\] #2 \(imu\): the noise model fails "
                                         r"with these options \(TypeError: can't multiply"):
        loads_study(GOOD, registry=REGISTRY)


def test_study_file_that_is_not_a_regular_file_is_refused(tmp_path):
    big = tmp_path / "big.toml"
    big.write_text("# " + "x" * design.MAX_FILE_BYTES + "\n" + GOOD)
    with pytest.raises(StudyError, match="over the limit of 1000000 for a TOML file"):
        load_study(big, registry=REGISTRY)
    with pytest.raises(StudyError, match="/dev/zero: not a regular file"):
        load_study("/dev/zero", registry=REGISTRY)
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)
    with pytest.raises(StudyError, match="fifo.toml: not a regular file"):
        load_study(fifo, registry=REGISTRY)  # would block on open() if it were read


def test_cli_runs_over_the_limit_exit_2(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(design, "_registry", lambda: REGISTRY)
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    assert main(["study", str(path), "--runs", "1000000000", "--out", str(tmp_path / "o"),
                 "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "over the limit of 100000" in err[0]


def test_quick_study_skips_missing_methods_but_a_user_study_does_not(tmp_path):
    quick = load_study(None, registry={"ekf": Prior})
    assert [e.method for e in quick.estimators] == ["prior"]  # the class's own name
    assert quick.skipped and all("(" in s for s in quick.skipped)
    path = tmp_path / "copy.toml"
    path.write_text(design.quick_study_path().read_text())
    with pytest.raises(StudyError, match="unknown method"):
        load_study(path, registry={"ekf": Prior})
    with pytest.raises(StudyError, match="none of the estimators is installed"):
        load_study(None, registry={})


def test_cli_malformed_study_exits_2_with_one_line(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text(GOOD.replace("runs = 4\n", ""))
    out = tmp_path / "out"
    assert main(["study", str(path), "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "[study] is missing runs" in err[0]
    assert not out.exists()  # failed before any run started


def test_cli_unknown_method_exits_2_before_any_run(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(design, "_registry", lambda: REGISTRY)
    path = tmp_path / "bad.toml"
    path.write_text(textwrap.dedent(GOOD).replace('method = "prior"', 'method = "zzz"', 1))
    out = tmp_path / "out"
    assert main(["study", str(path), "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown method 'zzz'" in err[0]
    assert not out.exists()


STUDIES = sorted((design.quick_study_path().parents[2] / "studies").glob("*.toml"))


@pytest.mark.parametrize("path", STUDIES, ids=[p.stem for p in STUDIES])
def test_shipped_studies_load_with_the_installed_estimators(path):
    study = load_study(path)
    assert study.name == path.stem and not study.skipped
    assert study.n_fits == study.runs * len(study.noise) * len(study.estimators)


def test_quick_study_runs_every_fast_estimator_and_not_eam():
    study = load_study(None)
    methods = {e.method for e in study.estimators}
    assert methods == {"sebm-pso", "ebm-pso", "equation-error", "output-error", "ekf", "ukf",
                       "pyswarms"}
    assert not study.skipped and study.runs == 3
    assert {p.stem for p in STUDIES} >= {"paper_table5", "noise_sweep", "realistic_imu"}
