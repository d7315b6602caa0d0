"""A study of a turbulent scenario (issue 26): every run flies its own Dryden gusts.

Reference: ``aeroid.simulate`` with the run's flight generator (the gusts are drawn
from it first, then the sensor noise), as for a still-air study's runs
(``test_study_runner.py``); the floors are not computed (no common noise-free flight).
"""

import json
from pathlib import Path

import numpy as np
import pytest
from study_fakes import Echo

from aeroid import simulate
from aeroid.study import _floors, loads_study, run_study
from aeroid.study import _runner as study_runner

STUDIES = Path(__file__).resolve().parents[2] / "studies"
STUDY = """
[study]
name = "turbulence_small"
runs = 2
seed = 5
scenario = "scenarios/turbulence.toml"

[[noise]]
label = "tactical"
model = "gaussian"

[[estimators]]
label = "A"
method = "echo"
"""


@pytest.fixture(scope="module")
def study():
    return loads_study(STUDY, base_dir=STUDIES, registry={"echo": Echo})


def test_each_run_is_aeroid_simulate_with_its_seed(study):
    assert study.scenario.manoeuvre.wind.turbulent
    flights = []
    for run in range(2):
        ours = study_runner.simulate_run(study, run, 0)
        rng = np.random.default_rng(study_runner.flight_seed(study.seed, run))
        ref = simulate(study.scenario.airframe, study.scenario.coefficient_vector,
                       study.scenario.manoeuvre, study.noise[0].model, rng=rng)
        assert ours.data.equals(ref.data)
        assert ours.metadata == ref.metadata
        flights.append(ours)
    # the two runs flew different gusts: their air-relative angles differ by much more
    # than the IMU noise could make (the logged alpha is noise-free)
    gap = np.abs(flights[0]["alpha"] - flights[1]["alpha"])
    assert np.max(gap) > 1e-3


def test_the_study_runs_and_says_why_it_has_no_floor(study, tmp_path):
    outcome = run_study(study, tmp_path, progress=False)
    assert outcome.n_new == study.n_fits == 2 and outcome.n_failed == 0
    floors = json.loads((tmp_path / "floors.json").read_text())
    assert floors["conditions"][0]["reason"] == _floors.TURBULENCE_NO_FLOOR
