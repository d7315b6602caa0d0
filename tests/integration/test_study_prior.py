"""Studies that start off the truth: ``prior_offset = [lo, hi]`` in ``[study]``.

Per run every coefficient's prior is ``truth (1 + s U(lo, hi))`` with a random sign,
the same for every estimator and noise condition of the run, drawn from the run's seed
only (its own seed child: flights and estimator draws are those of a study without it).
The stand-in estimator here (``study_fakes.Echo``) returns its airframe's prior, so a
record's estimate *is* the prior that estimator was given.
"""

import numpy as np
import pytest
from study_fakes import Echo

from aeroid.errors import StudyError
from aeroid.study import _fits, loads_study, read_results, run_study

VOLATILE = ("wall_time_s", "compile_time_s", "worker")
LO, HI = 0.10, 0.25
REGISTRY = {"echo": Echo}


def _study(runs=4, offset=f"[{LO}, {HI}]", extra=""):
    line = "" if offset is None else f"prior_offset = {offset}\n"
    return loads_study(f"""
[study]
name = "prior"
runs = {runs}
seed = 5
{line}{extra}
[[noise]]
label = "paper"
model = "paper"

[[noise]]
label = "gauss"
model = "gaussian"

[[estimators]]
label = "A"
method = "echo"

[[estimators]]
label = "B"
method = "echo"
""", registry=REGISTRY)


def _stable(records):
    return [{k: v for k, v in r.items() if k not in VOLATILE} for r in records]


def test_every_estimator_and_noise_condition_of_a_run_starts_from_the_same_prior(tmp_path):
    study = _study()
    out = run_study(study, tmp_path / "s", progress=False)
    truth = np.array(study.scenario.coefficient_vector)
    priors = {}
    for r in out.records:
        assert r["theta"] == r["prior"]  # the estimator was given the record's prior
        assert r["truth"] == pytest.approx(list(truth), rel=0, abs=0)  # metrics: the truth
        priors.setdefault(r["run"], []).append(r["prior"])
    for run, given in priors.items():
        assert len(given) == 4 and all(p == given[0] for p in given)
        assert given[0] == list(_fits.run_prior(study, run))
    assert len({tuple(p[0]) for p in priors.values()}) == study.runs  # runs differ


def test_serial_and_two_workers_give_the_same_priors(tmp_path):
    study = _study(runs=3)
    serial = run_study(study, tmp_path / "serial", progress=False)
    parallel = run_study(study, tmp_path / "jobs2", jobs=2, progress=False)
    assert _stable(serial.records) == _stable(parallel.records)
    stored = sorted(read_results(tmp_path / "jobs2" / "results.jsonl"),
                    key=lambda r: (r["run"], r["noise"] != "paper", r["estimator"]))
    assert _stable(stored) == _stable(serial.records)


def test_offsets_lie_in_lo_hi_with_both_signs():
    study = _study(runs=50)
    truth = np.array(study.scenario.coefficient_vector)
    rel = np.array([_fits.run_prior(study, i) / truth - 1.0 for i in range(study.runs)])
    assert np.all(np.abs(rel) >= LO - 1e-12) and np.all(np.abs(rel) <= HI + 1e-12)
    for j in range(truth.size):  # each coefficient is moved up in some runs, down in others
        assert (rel[:, j] > 0).any() and (rel[:, j] < 0).any()
    # U(lo, hi): the magnitudes fill the interval (mean (lo + hi) / 2, sd (hi - lo) / sqrt 12)
    assert np.mean(np.abs(rel)) == pytest.approx((LO + HI) / 2, abs=4 * (HI - LO) / 12**0.5
                                                  / rel.size**0.5)


def test_the_prior_leaves_flights_and_estimator_draws_as_they_were(tmp_path):
    with_prior = run_study(_study(runs=2), tmp_path / "a", progress=False).records
    without = run_study(_study(runs=2, offset=None), tmp_path / "b", progress=False).records
    assert [r["cost"] for r in with_prior] == [r["cost"] for r in without]  # rng draws
    assert all(r["prior"] is None for r in without)
    truth = list(_study().scenario.coefficient_vector)
    assert all(r["theta"] == pytest.approx(truth, rel=0, abs=0) for r in without)
    for run in range(2):
        a = _fits.simulate_run(_study(runs=2), run, 0)
        b = _fits.simulate_run(_study(runs=2, offset=None), run, 0)
        assert a.data.equals(b.data)


def test_the_prior_offset_is_part_of_the_design(tmp_path):
    base, other, none = _study(), _study(offset="[0.10, 0.30]"), _study(offset=None)
    assert len({base.fingerprint(), other.fingerprint(), none.fingerprint()}) == 3
    assert base.describe()["prior_offset"] == [LO, HI]
    assert none.describe()["prior_offset"] is None
    run_study(base.with_runs(1), tmp_path / "s", progress=False)
    with pytest.raises(StudyError, match="design"):
        run_study(other.with_runs(2), tmp_path / "s", resume=True, progress=False)


def test_output_error_starts_from_the_offset_prior():
    pytest.importorskip("casadi")
    study = loads_study(f"""
[study]
runs = 1
seed = 3
prior_offset = [{LO}, {HI}]

[[noise]]
label = "tactical"
model = "gaussian"

[[estimators]]
label = "OE"
method = "output-error"
options = {{ max_iterations = 1, equation_error_start = false }}
""")  # the prior start alone: the history is the likeliest start's
    record, history = _fits.fit_task(study, (0, 0, 0))
    prior = np.array(record["prior"])
    truth = np.array(record["truth"])
    assert np.all(np.abs(prior / truth - 1.0) >= LO)
    np.testing.assert_array_equal(history["history_theta"][0], prior)  # its first iterate


@pytest.mark.parametrize("value, fragment", [
    ("[0.3, 0.1]", "need 0 <= lo <= hi < 1"),
    ("[-0.1, 0.2]", "need 0 <= lo <= hi < 1"),
    ("[0.1, 1.0]", "need 0 <= lo <= hi < 1"),
    ("[0.1, nan]", "need 0 <= lo <= hi < 1"),
    ("[0.1]", "must be two numbers"),
    ("[0.1, 0.2, 0.3]", "must be two numbers"),
    ('"0.1-0.2"', "must be two numbers"),
    ("[true, 0.2]", "must be two numbers"),
    ('["0.1", 0.2]', "must be two numbers"),
])
def test_bad_prior_offsets_are_one_line(value, fragment):
    with pytest.raises(StudyError) as err:
        _study(offset=value)
    text = str(err.value)
    assert "\n" not in text and "[study] prior_offset" in text and fragment in text
