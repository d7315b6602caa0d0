"""Studies of coefficient tables in Mach: each fit scored per parameter (issue 23).

References: a study fit equals the estimator's own fit of the run's flight (its record's
names, estimates and standard errors); each table point's truth is the scenario's true
row at that Mach, read from the scenario file itself; the report's coverage counts equal
those counted from the records.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from aeroid.errors import StudyError
from aeroid.study import _fits, loads_study, run_study
from aeroid.study._report import write_report

SWEEP = Path(__file__).parents[2] / "studies" / "scenarios" / "mach_sweep.toml"
#: The sweep's first 6 s (Mach 2.19-1.68) with the fits' knots at the truth's rows there.
KNOTS = "[1.65, 1.925, 2.2]"


@pytest.fixture(scope="module")
def scenario_file(tmp_path_factory):
    text = SWEEP.read_text()
    text = re.sub(r"window_s = \[0.5, 20.5\]", "window_s = [0.5, 6.5]", text)
    text = re.sub(r"^(Cx|Cmq) = \[1.1, .*\]$", rf"\1 = {KNOTS}", text, flags=re.M)
    path = tmp_path_factory.mktemp("sweep") / "sweep6.toml"
    path.write_text(text)
    return path


def _study(scenario: Path, method: str = "output-error", extra: str = ""):
    return loads_study(f"""
[study]
name = "sweep"
runs = 2
seed = 7
scenario = "{scenario}"
{extra}
[[noise]]
label = "gauss"
model = "gaussian"

[[estimators]]
label = "E"
method = "{method}"
""")


def test_a_table_study_scores_each_table_point(scenario_file, tmp_path):
    study = _study(scenario_file)
    outcome = run_study(study, tmp_path, progress=False)
    records = sorted(outcome.records, key=lambda r: r["run"])
    rows = {"Cx@M1.65": -0.98, "Cx@M1.925": -0.90, "Cx@M2.2": -0.833,
            "Cmq@M1.65": -2227.0, "Cmq@M1.925": -2060.0, "Cmq@M2.2": -1893.0,
            "Cza": -11.8}  # the scenario file's [coefficients]
    for record in records:
        assert record["success"], record["message"]
        truth = dict(zip(record["names"], record["truth"], strict=True))
        for name, value in rows.items():
            assert truth[name] == pytest.approx(value, rel=1e-12), name
    # the study's fit is the estimator's own fit of the run's flight
    flight = _fits.simulate_run(study, 1, 0)
    own = study.estimators[0].estimator.fit(flight, rng=np.random.default_rng(
        _fits.estimator_seed(study.seed, 1)))
    assert tuple(records[1]["names"]) == own.names
    np.testing.assert_allclose(records[1]["theta"], own.theta, rtol=1e-12)
    report = write_report(study, tmp_path, outcome.records).read_text()
    assert "Coverage of each parameter's 95 % interval" in report
    line = next(x for x in report.splitlines() if x.startswith("| E | Cx@M1.925 |"))
    covered = sum(abs(r["theta"][r["names"].index("Cx@M1.925")] + 0.90)
                  <= 1.96 * r["stderr"][r["names"].index("Cx@M1.925")] for r in records)
    assert line.split("|")[4].strip() == "2" and line.split("|")[5].strip() == str(covered)
    assert (tmp_path / "results.csv").exists() and (tmp_path / "summary.csv").exists()


@pytest.mark.parametrize(("method", "extra", "words"), [
    ("sebm-pso", "", "E cannot fit tables"),
    ("output-error", "prior_offset = [0.1, 0.2]", "prior_offset draws one prior"),
])
def test_what_a_table_study_cannot_do_is_one_line(scenario_file, method, extra, words):
    with pytest.raises(StudyError, match=words):
        _study(scenario_file, method, extra)
