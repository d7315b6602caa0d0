"""The study store cannot lose data: real kills, full disks, dead workers, guarded folders.

Every kill here is a real SIGKILL of a real process (a subprocess running
``study_fakes.py``, or a worker of the process pool); after it, ``--resume`` must give
exactly the rows of an uninterrupted run.
"""

import contextlib
import errno
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from study_fakes import REGISTRY, STUDY, stable

from aeroid.errors import StudyError
from aeroid.study import _histories, _store, load_history, loads_study, read_results, run_study
from aeroid.study._executors import WORKER_DIED
from aeroid.study._fits import estimator_seed

HERE = Path(__file__).parent
#: Seconds a subprocess study may take (start-up with numba's cache is a few seconds).
SUBPROCESS_TIMEOUT_S = 120
#: Seconds a worker may outlive its killed study (it checks its parent every second).
ORPHAN_TIMEOUT_S = 10



@pytest.fixture(scope="module")
def study():
    return loads_study(STUDY, registry=REGISTRY)


@pytest.fixture(scope="module")
def reference(study, tmp_path_factory):
    return run_study(study, tmp_path_factory.mktemp("reference"), progress=False)


def _run_script(out: Path, point: str, *extra: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(HERE), os.environ.get("PYTHONPATH", "")])}
    code = "import sys, study_fakes; sys.exit(study_fakes.main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, str(out), point, *extra], env=env,
                          capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT_S)


def _leftovers(out: Path) -> list[str]:
    return sorted(p.name for p in out.rglob("*.tmp"))


# --------------------------------------------------------------------------------------
# Real kills of the study process, then --resume
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("point", ["fit:5", "history:2", "record:3", "tmp:3"])
def test_sigkill_at_each_point_then_resume_gives_the_uninterrupted_rows(
        study, reference, tmp_path, point):
    out = tmp_path / "cut"
    killed = _run_script(out, point)
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    partial = read_results(out / "results.jsonl")
    assert len(partial) < study.n_fits
    if point == "history:2":  # the history is on disk, its record is not
        assert (out / "histories" / "n0-e1.npz").exists() and len(partial) == 1
    if point == "record:3":  # half a line
        assert not (out / "results.jsonl").read_bytes().endswith(b"\n")
    if point == "tmp:3":
        assert _leftovers(out) == ["n1-e0.npz.tmp"]
    resumed = run_study(study, out, resume=True, progress=False)
    assert resumed.n_new == study.n_fits - len(partial)
    on_disk = read_results(out / "results.jsonl")
    assert stable(on_disk) == stable(reference.records)
    assert _leftovers(out) == []
    for noise in ("paper", "gauss"):
        for label in ("J1", "J2"):
            mine, ref = (load_history(o, noise, label) for o in (out, reference.out_dir))
            np.testing.assert_array_equal(mine["history_theta"], ref["history_theta"])


def test_sigkill_from_outside_during_a_parallel_study_then_resume(study, reference, tmp_path):
    """The parent of two workers killed by another process once some fits are stored."""
    out = tmp_path / "cut"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(HERE), os.environ.get("PYTHONPATH", "")])}
    code = "import sys, study_fakes; sys.exit(study_fakes.main(sys.argv[1:]))"
    runs = 30  # 120 fits: far more than the 4 stored before the kill
    proc = subprocess.Popen([sys.executable, "-c", code, str(out), "none", "--jobs", "2",
                             "--runs", str(runs)], env=env, stderr=subprocess.DEVNULL)
    results = out / "results.jsonl"
    deadline = time.monotonic() + SUBPROCESS_TIMEOUT_S
    while time.monotonic() < deadline and proc.poll() is None:
        if results.exists() and results.read_bytes().count(b"\n") >= 4:
            workers = _children(proc.pid)
            proc.send_signal(signal.SIGKILL)
            break
        time.sleep(0.002)
    proc.wait(timeout=SUBPROCESS_TIMEOUT_S)
    assert proc.returncode == -signal.SIGKILL
    _assert_exited(workers)
    partial = read_results(results)
    assert 4 <= len(partial) < runs * 4
    resumed = run_study(study.with_runs(runs), out, resume=True, progress=False)
    assert resumed.n_new == runs * 4 - len(partial)
    uninterrupted = run_study(study.with_runs(runs), tmp_path / "ref", progress=False)
    assert stable(read_results(results)) == stable(uninterrupted.records)


def _children(pid: int) -> list[int]:
    """Process ids of the children of ``pid`` (Linux /proc; empty elsewhere)."""
    found = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        with contextlib.suppress(OSError):
            found += [int(x) for x in (task / "children").read_text().split()]
    return found


def _running(pid: int) -> bool:
    """Whether ``pid`` is a live process (not gone, not a zombie awaiting its reaper)."""
    try:
        return "zombie" not in Path(f"/proc/{pid}/status").read_text()
    except OSError:  # gone (or gone between two reads)
        return False


def _assert_exited(pids: list[int]) -> None:
    """The worker processes of a killed study end by themselves (no orphans left)."""
    deadline = time.monotonic() + ORPHAN_TIMEOUT_S
    alive = list(pids)
    while alive and time.monotonic() < deadline:
        alive = [p for p in alive if _running(p)]
        time.sleep(0.1)
    assert not alive, f"worker processes {alive} outlived the killed study"


# --------------------------------------------------------------------------------------
# Full disk and other OS errors
# --------------------------------------------------------------------------------------
def _enospc(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_full_disk_on_a_record_is_one_line_and_the_folder_stays_resumable(
        study, reference, tmp_path, monkeypatch):
    original = _store._write_all
    calls = {"n": 0}

    def write(fd, data):
        if data.startswith(b'{"run"'):
            calls["n"] += 1
            if calls["n"] == 3:
                os.write(fd, data[:10])  # part of the line got out before the error
                _enospc()
        original(fd, data)

    monkeypatch.setattr(_store, "_write_all", write)
    with pytest.raises(StudyError) as info:
        run_study(study, tmp_path, progress=False)
    message = str(info.value)
    assert "No space left on device" in message and "--resume" in message
    assert "\n" not in message
    text = (tmp_path / "results.jsonl").read_text()
    assert text.endswith("\n") and len(text.splitlines()) == 2  # no partial line
    assert _leftovers(tmp_path) == []
    monkeypatch.setattr(_store, "_write_all", original)
    run_study(study, tmp_path, resume=True, progress=False)
    assert stable(read_results(tmp_path / "results.jsonl")) == stable(reference.records)


def test_full_disk_on_a_history_leaves_no_temporary_file(study, tmp_path, monkeypatch):
    def savez(path, arrays):
        path.write_bytes(b"partial")
        _enospc()

    monkeypatch.setattr(_histories, "_savez", savez)
    with pytest.raises(StudyError, match="cannot write the history: No space left"):
        run_study(study, tmp_path, progress=False)
    assert _leftovers(tmp_path) == []
    assert read_results(tmp_path / "results.jsonl") == []  # no record without its history


def test_full_disk_on_study_json_is_one_line(study, tmp_path, monkeypatch):
    monkeypatch.setattr(_store, "_write_all", _enospc)
    with pytest.raises(StudyError, match=r"study\.json: cannot write: No space left"):
        run_study(study, tmp_path, progress=False)
    assert _leftovers(tmp_path) == [] and not (tmp_path / "study.json").exists()


# --------------------------------------------------------------------------------------
# Dead workers of --jobs
# --------------------------------------------------------------------------------------
def _with_killer(options: str) -> str:
    return STUDY + f'\n[[estimators]]\nlabel = "K"\nmethod = "killer"\noptions = {{ {options} }}\n'


def test_a_worker_killed_once_is_retried_and_the_study_goes_on(tmp_path):
    marker = tmp_path / "died"
    text = _with_killer(f'marker = "{marker}"')
    study = loads_study(text, registry=REGISTRY)
    out = run_study(study, tmp_path / "par", jobs=2, progress=False)
    assert marker.exists()  # one worker did die
    assert out.n_failed == 0 and len(out.records) == study.n_fits
    serial = run_study(study, tmp_path / "ser", progress=False)  # the marker exists: no kill
    assert stable(out.records) == stable(serial.records)


def test_a_fit_that_kills_its_worker_twice_is_recorded_as_failed(tmp_path):
    u = [np.random.default_rng(estimator_seed(11, run)).random() for run in range(3)]
    threshold = min(u) * 1.000001  # only the run with the smallest u kills its worker
    victim = int(np.argmin(u))
    study = loads_study(_with_killer(f"victim_below = {threshold!r}"), registry=REGISTRY)
    out = run_study(study, tmp_path / "par", jobs=2, progress=False)
    failed = [(r["run"], r["noise"], r["estimator"]) for r in out.records if not r["success"]]
    assert sorted(failed) == [(victim, "gauss", "K"), (victim, "paper", "K")]
    assert all(r["message"] == WORKER_DIED for r in out.records if not r["success"])
    alive = loads_study(_with_killer("victim_below = 0.0"), registry=REGISTRY)
    serial = run_study(alive, tmp_path / "ser", progress=False)
    good = [r for r in stable(out.records) if r["success"]]
    assert good == [r for r in stable(serial.records)
                    if (r["run"], r["estimator"]) != (victim, "K")]


# --------------------------------------------------------------------------------------
# Guarded folders and designs
# --------------------------------------------------------------------------------------
def test_resume_requires_study_json(study, tmp_path):
    run_study(study.with_runs(1), tmp_path, progress=False)
    (tmp_path / "study.json").unlink()
    with pytest.raises(StudyError, match=r"study\.json: missing"):
        run_study(study, tmp_path, resume=True, progress=False)


def test_resume_refuses_results_of_other_code(study, tmp_path):
    run_study(study.with_runs(1), tmp_path, progress=False)
    design = json.loads((tmp_path / "study.json").read_text())
    assert design["code"]["packages"]["numpy"] == np.__version__
    design["code"]["source"] = "0" * 16
    design["code"]["packages"]["numba"] = "0.1"
    design["code"]["id"] = "other"
    (tmp_path / "study.json").write_text(json.dumps(design))
    with pytest.raises(StudyError, match=r"other code \(source 0{16} -> [0-9a-f]{16}; "
                                         r"numba 0\.1 -> .*--overwrite"):
        run_study(study, tmp_path, resume=True, progress=False)
    del design["code"]
    (tmp_path / "study.json").write_text(json.dumps(design))
    with pytest.raises(StudyError, match="does not say which code"):
        run_study(study, tmp_path, resume=True, progress=False)


def test_resume_on_another_cpu_says_so(study, tmp_path, capsys):
    run_study(study.with_runs(1), tmp_path, progress=False)
    design = json.loads((tmp_path / "study.json").read_text())
    design["code"]["cpu"] = "x86_64 generic"
    (tmp_path / "study.json").write_text(json.dumps(design))
    more = run_study(study.with_runs(2), tmp_path, resume=True, progress=False)
    assert more.n_new == 4
    assert "computed on a x86_64 generic CPU" in capsys.readouterr().err


@pytest.mark.parametrize(("damage", "expected"), [
    ("{not json", r"study\.json: not valid JSON"),
    ("[1, 2]", r"study\.json: not a study design"),
])
def test_malformed_study_json_is_one_line(study, tmp_path, damage, expected):
    run_study(study.with_runs(1), tmp_path, progress=False)
    (tmp_path / "study.json").write_text(damage)
    with pytest.raises(StudyError, match=expected):
        run_study(study, tmp_path, resume=True, progress=False)


@pytest.mark.parametrize(("line", "expected"), [
    ("[1, 2]", "not a JSON object"),
    ('{"run": "0", "noise": "paper", "estimator": "J1", "success": true, "theta": []}',
     "'run' missing or not int"),
    ('{"run": 0, "noise": "paper", "estimator": "J1", "success": true, "theta": [],'
     ' "history": "../../etc/passwd"}', "'history' is not a file name"),
])
def test_malformed_record_line_is_one_line(study, tmp_path, line, expected):
    run_study(study.with_runs(1), tmp_path, progress=False)
    with (tmp_path / "results.jsonl").open("a") as fh:
        fh.write(line + "\n")
    with pytest.raises(StudyError, match=f"line 5 is not a study record .*{expected}"):
        run_study(study, tmp_path, resume=True, progress=False)


def test_a_record_whose_history_is_missing_is_refitted(study, reference, tmp_path):
    run_study(study, tmp_path, progress=False)
    (tmp_path / "histories" / "n1-e1.npz").unlink()
    again = run_study(study, tmp_path, resume=True, progress=False)
    assert again.n_new == 1
    assert stable(read_results(tmp_path / "results.jsonl")) == stable(reference.records)
    assert (tmp_path / "histories" / "n1-e1.npz").exists()


def test_out_must_be_a_folder_of_its_own(study, tmp_path, monkeypatch):
    (tmp_path / "file").write_text("x")
    with pytest.raises(StudyError, match="is a file, not a folder"):
        run_study(study, tmp_path / "file", progress=False)
    work = tmp_path / "work"
    work.mkdir()
    (work / "histories").mkdir()
    (work / "histories" / "mine.txt").write_text("keep")
    monkeypatch.chdir(work)
    for out in (".", "..", str(work)):
        with pytest.raises(StudyError, match="working directory or one of its parents"):
            run_study(study, out, progress=False)
    assert sorted(p.name for p in work.rglob("*")) == ["histories", "mine.txt"]


def test_study_named_dotdot_is_refused(tmp_path):
    with pytest.raises(StudyError, match="not only dots"):
        loads_study(STUDY.replace('name = "store"', 'name = ".."'), registry=REGISTRY)


def test_labels_that_slug_alike_keep_their_own_histories(tmp_path):
    text = STUDY.replace('label = "J1"', 'label = "M/1"').replace('label = "J2"',
                                                                 'label = "M_1"')
    study = loads_study(text.replace("runs = 3", "runs = 1"), registry=REGISTRY)
    out = run_study(study, tmp_path, progress=False)
    a, b = (load_history(tmp_path, "paper", label)["history_theta"] for label in ("M/1", "M_1"))
    theta = {r["estimator"]: r["theta"] for r in out.records if r["noise"] == "paper"}
    np.testing.assert_array_equal(a[-1], theta["M/1"])
    np.testing.assert_array_equal(b[-1], theta["M_1"])
    assert not np.array_equal(a, b)

