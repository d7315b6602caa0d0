"""The study runner: seeding, executors, failures, interruption and resume.

The estimators here are cheap stand-ins defined at module level (so that spawned
worker processes and Dask workers can import them); each depends on its flight and on
its rng, so any mix-up of seeds, flights or rows shows up as a different number.
"""

import json
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest
from study_fakes import Jitter, stable  # shared with the store's tests

from aeroid import Estimator, failed_result, simulate
from aeroid.errors import StudyError
from aeroid.model import NAMES
from aeroid.study import _runner as study_runner
from aeroid.study import loads_study, read_results, run_study


@dataclass(frozen=True, kw_only=True)
class Raises(Estimator):
    name: ClassVar[str] = "raises"

    def run(self, flight, rng):
        raise RuntimeError("boom\nsecond line")


@dataclass(frozen=True, kw_only=True)
class Fails(Estimator):
    name: ClassVar[str] = "fails"

    def run(self, flight, rng):
        return failed_result(self.name, "filter diverged")


_INTERRUPT = {"at_call": None, "calls": 0}


@dataclass(frozen=True, kw_only=True)
class Interrupting(Jitter):
    """A Jitter that raises KeyboardInterrupt at its n-th call once armed (in-process)."""

    name: ClassVar[str] = "interrupting"

    def run(self, flight, rng):
        _INTERRUPT["calls"] += 1
        if _INTERRUPT["calls"] == _INTERRUPT["at_call"]:
            raise KeyboardInterrupt
        return super().run(flight, rng)


REGISTRY = {"jitter": Jitter, "raises": Raises, "fails": Fails, "interrupting": Interrupting}

STUDY = """
[study]
name = "t"
runs = 3
seed = 11

[[noise]]
label = "paper"
model = "paper"

[[noise]]
label = "gauss"
model = "gaussian"

[[estimators]]
label = "J1"
method = "jitter"

[[estimators]]
label = "J2"
method = "jitter"
options = { scale = 0.02 }
"""


@pytest.fixture(scope="module")
def study():
    return loads_study(STUDY, registry=REGISTRY)


@pytest.fixture(scope="module")
def serial(study, tmp_path_factory):
    return run_study(study, tmp_path_factory.mktemp("serial"), progress=False)


def test_serial_run_writes_every_fit(study, serial):
    assert serial.n_new == study.n_fits == 12 and serial.n_failed == 0
    on_disk = read_results(serial.results_path)
    assert stable(on_disk) == stable(serial.records)
    keys = {(r["run"], r["noise"], r["estimator"]) for r in on_disk}
    assert len(keys) == 12
    truth = np.array(on_disk[0]["truth"])
    np.testing.assert_array_equal(truth, study.scenario.coefficient_vector)


def test_flight_equals_aeroid_simulate_with_the_run_seed(study):
    """The runner's cached-truth flight is exactly aeroid.simulate's flight."""
    for k_noise in range(len(study.noise)):
        ours = study_runner.simulate_run(study, 2, k_noise)
        rng = np.random.default_rng(study_runner.flight_seed(study.seed, 2))
        ref = simulate(study.scenario.airframe, study.scenario.coefficient_vector,
                       study.scenario.manoeuvre, study.noise[k_noise].model, rng=rng)
        assert ours.data.equals(ref.data)
        assert ours.airframe == ref.airframe
        assert ours.metadata == ref.metadata


def test_runs_depend_on_seed_and_index_only(study, serial, tmp_path):
    """Run i is the same in a 2-run study; estimators of a run share their rng stream."""
    two = run_study(study.with_runs(2), tmp_path, progress=False)
    first = [r for r in stable(serial.records) if r["run"] < 2]
    assert stable(two.records) == first
    by = {(r["run"], r["noise"], r["estimator"]): np.array(r["theta"]) for r in serial.records}
    prior = study.scenario.airframe.prior_vector()
    for run in range(3):
        for noise in ("paper", "gauss"):
            # J = prior (1 + s z) + c with one z per run and one c per flight:
            # J2 - J1 = 0.01 prior z, and J1 - prior (1 + 0.01 z) is c in all nine entries
            z = (by[run, noise, "J2"] - by[run, noise, "J1"]) / (prior * 0.01)
            c = by[run, noise, "J1"] - prior * (1 + 0.01 * z)
            np.testing.assert_allclose(c, c[0], rtol=0, atol=1e-9)  # one data term per fit
    # different runs draw differently
    assert not np.allclose(by[0, "paper", "J1"], by[1, "paper", "J1"])
    # noise conditions share the run's estimator draws but not the flight
    assert not np.array_equal(by[0, "paper", "J1"], by[0, "gauss", "J1"])


def test_two_processes_give_identical_results(study, serial, tmp_path):
    parallel = run_study(study, tmp_path, jobs=2, progress=False)
    assert stable(parallel.records) == stable(serial.records)
    workers = {r["worker"] for r in parallel.records}
    assert len(workers) >= 1 and all(":" in w for w in workers)


def test_local_dask_cluster_gives_identical_results(study, serial, tmp_path):
    pytest.importorskip("dask.distributed")
    dask = run_study(study, tmp_path, dask_local=2, progress=False)
    assert stable(dask.records) == stable(serial.records)


def test_local_dask_cluster_starts_when_port_8787_is_taken(study, serial, tmp_path):
    """Dask's default HTTP port held by someone else (a second study, a dashboard): the
    local cluster used to fail to start ("Port 8787 is already in use")."""
    import socket

    pytest.importorskip("dask.distributed")
    with socket.socket() as held:
        try:
            held.bind(("0.0.0.0", 8787))
        except OSError:
            pytest.skip("port 8787 is in use here already")
        held.listen()
        dask = run_study(study, tmp_path, dask_local=2, progress=False)
    assert stable(dask.records) == stable(serial.records)


def test_history_kept_for_run_0_only(study, serial):
    for noise in ("paper", "gauss"):
        for label in ("J1", "J2"):
            h = study_runner.load_history(serial.out_dir, noise, label)
            assert h is not None and h["history_axis"] == "iteration"
            theta0 = next(r["theta"] for r in serial.records
                          if (r["run"], r["noise"], r["estimator"]) == (0, noise, label))
            np.testing.assert_array_equal(h["history_theta"][3], theta0)
    # one file per (noise index, estimator index), named by the record that owns it
    files = sorted(p.name for p in (serial.out_dir / "histories").iterdir())
    assert files == ["n0-e0.npz", "n0-e1.npz", "n1-e0.npz", "n1-e1.npz"]
    named = {r["history"] for r in serial.records if r["run"] == 0}
    assert named == {f"histories/{name}" for name in files}
    assert all(r["history"] is None for r in serial.records if r["run"] > 0)


def test_failures_are_recorded_and_the_study_goes_on(tmp_path):
    text = STUDY.replace('options = { scale = 0.02 }', "") + """
[[estimators]]
label = "R"
method = "raises"

[[estimators]]
label = "F"
method = "fails"
"""
    study = loads_study(text.replace("runs = 3", "runs = 2"), registry=REGISTRY)
    out = run_study(study, tmp_path, progress=False)
    assert len(out.records) == 2 * 2 * 4 and out.n_failed == 2 * 2 * 2
    for r in out.records:
        if r["estimator"] == "R":
            assert not r["success"] and r["message"] == "RuntimeError: boom"
            assert r["theta"] == [None] * len(NAMES)
        elif r["estimator"] == "F":
            assert not r["success"] and r["message"] == "filter diverged"
        else:
            assert r["success"]


def test_interrupted_study_resumes_to_exactly_the_uninterrupted_rows(tmp_path):
    text = STUDY + '\n[[estimators]]\nlabel = "I"\nmethod = "interrupting"\n'
    study = loads_study(text, registry=REGISTRY)
    _INTERRUPT.update(at_call=None, calls=0)
    reference = run_study(study, tmp_path / "ref", progress=False)

    _INTERRUPT.update(at_call=4, calls=0)  # the 4th fit of "I": run 1, noise "gauss"
    with pytest.raises(KeyboardInterrupt):
        run_study(study, tmp_path / "cut", progress=False)
    partial = read_results(tmp_path / "cut" / "results.jsonl")
    assert 0 < len(partial) < study.n_fits
    # a study killed while writing leaves half a line: resume must drop it
    with (tmp_path / "cut" / "results.jsonl").open("a") as fh:
        fh.write('{"run": 2, "noise": "paper", "estim')
    _INTERRUPT.update(at_call=None)
    resumed = run_study(study, tmp_path / "cut", resume=True, progress=False)
    assert resumed.n_new == study.n_fits - len(partial)
    on_disk = read_results(tmp_path / "cut" / "results.jsonl")
    assert len(on_disk) == study.n_fits  # no duplicates, nothing lost
    assert stable(on_disk) == stable(reference.records)
    # resuming a complete study runs nothing
    again = run_study(study, tmp_path / "cut", resume=True, progress=False)
    assert again.n_new == 0 and stable(again.records) == stable(reference.records)


def test_resume_refuses_results_of_another_design(study, tmp_path):
    run_study(study.with_runs(1), tmp_path, progress=False)
    other = loads_study(STUDY.replace("seed = 11", "seed = 12"), registry=REGISTRY)
    with pytest.raises(StudyError, match="another study design"):
        run_study(other, tmp_path, resume=True, progress=False)
    # more runs of the same design is fine: only the new runs are fitted
    more = run_study(study.with_runs(2), tmp_path, resume=True, progress=False)
    assert more.n_new == 4 and len(more.records) == 8


def test_a_folder_with_results_is_refused_without_resume_or_overwrite(study, tmp_path):
    run_study(study.with_runs(1), tmp_path, progress=False)
    first = (tmp_path / "results.jsonl").read_text()
    with pytest.raises(StudyError, match="holds a study's results.*--resume.*--overwrite"):
        run_study(study.with_runs(1), tmp_path, progress=False)
    assert (tmp_path / "results.jsonl").read_text() == first  # untouched


def test_overwrite_moves_each_previous_study_into_a_new_folder(study, tmp_path):
    run_study(study.with_runs(1), tmp_path, progress=False)
    first = (tmp_path / "results.jsonl").read_text()
    run_study(study.with_runs(2), tmp_path, overwrite=True, progress=False)
    second = (tmp_path / "results.jsonl").read_text()
    assert (tmp_path / "previous-1" / "results.jsonl").read_text() == first
    assert sorted(p.name for p in (tmp_path / "previous-1" / "histories").iterdir())
    run_study(study.with_runs(1), tmp_path, overwrite=True, progress=False)
    assert (tmp_path / "previous-1" / "results.jsonl").read_text() == first  # kept
    assert (tmp_path / "previous-2" / "results.jsonl").read_text() == second
    assert len((tmp_path / "results.jsonl").read_text().splitlines()) == 4
    with pytest.raises(StudyError, match="not both"):
        run_study(study, tmp_path, overwrite=True, resume=True, progress=False)


def test_damaged_results_file_is_an_error(study, tmp_path):
    run_study(study.with_runs(1), tmp_path, progress=False)
    lines = (tmp_path / "results.jsonl").read_text().splitlines()
    lines[1] = lines[1][:20]
    (tmp_path / "results.jsonl").write_text("\n".join(lines) + "\n")
    with pytest.raises(StudyError, match="line 2 is not valid JSON"):
        run_study(study.with_runs(1), tmp_path, resume=True, progress=False)


@pytest.mark.parametrize(("kwargs", "expected"), [
    ({"jobs": 0}, "--jobs must be an integer >= 1"),
    ({"scheduler": "tcp://x:1", "dask_local": 2}, "not both"),
    ({"dask_local": 0}, "--dask-local must be >= 1"),
])
def test_bad_executor_settings(study, tmp_path, kwargs, expected):
    with pytest.raises(StudyError, match=expected):
        run_study(study, tmp_path, progress=False, **kwargs)


def test_records_are_plain_json(serial):
    line = serial.results_path.read_text().splitlines()[0]
    record = json.loads(line)
    assert set(record) >= {"run", "noise", "estimator", "method", "truth", "theta", "stderr",
                           "success", "message", "cost", "n_evaluations", "wall_time_s"}
    assert "NaN" not in serial.results_path.read_text()
