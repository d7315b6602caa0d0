"""Executors: Dask shuts down quietly; bad scheduler addresses are one line."""

import os
import subprocess
import sys
from pathlib import Path

import pytest
from study_fakes import REGISTRY, STUDY

from aeroid.cli import main
from aeroid.errors import StudyError
from aeroid.study import loads_study, run_study
from aeroid.study._executors import check_scheduler

HERE = Path(__file__).parent

DASK_STUDIES = """
import sys
from study_fakes import REGISTRY, STUDY
from aeroid.study import loads_study, run_study

def stop(record):
    raise KeyboardInterrupt

study = loads_study(STUDY, registry=REGISTRY)
run_study(study, sys.argv[1] + "/complete", dask_local=2, progress=False)
print("complete")
try:
    run_study(study.with_runs(20), sys.argv[1] + "/cut", dask_local=2, progress=False,
              on_record=stop)
except KeyboardInterrupt:
    print("interrupted")
"""


def test_local_dask_cluster_shuts_down_without_log_lines(tmp_path):
    """A finished and an interrupted study on a local cluster print nothing on stderr."""
    pytest.importorskip("dask.distributed")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(HERE), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-c", DASK_STUDIES, str(tmp_path)], env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["complete", "interrupted"]
    assert done.stderr.strip() == ""


SPAWNED_WORKER = """
import numba  # as the aeroid command: a spawned worker imports this before its initializer
from worker_probe import compile_in_worker
from aeroid.study._executors import _pool, submit

if __name__ == "__main__":
    pool = _pool(1)
    print(*submit(pool, compile_in_worker).result(), sep="|")
    pool.shutdown()
"""


def test_a_spawned_worker_compiles_with_one_numba_thread(tmp_path):
    """A study's worker process compiles numba code (a study without numba's cache):
    it used to fail every such fit with "Cannot set NUMBA_NUM_THREADS to a different
    value once the threads have been launched" (the pool started its processes after
    the variables were restored, and the worker set them after numba had read them)."""
    pytest.importorskip("numba")
    script = tmp_path / "spawn_worker.py"
    script.write_text(SPAWNED_WORKER)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(HERE), os.environ.get("PYTHONPATH", "")])}
    env.pop("NUMBA_NUM_THREADS", None)
    done = subprocess.run([sys.executable, str(script)], env=env, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().split("|") == ["1", "1", "compiled"]


@pytest.mark.parametrize("address", ["localhost:8786", "http://x:1", "tcp://x", "tcp://:1",
                                     "tcp://x:1/path", "", "tcp://a b:1"])
def test_bad_scheduler_address_is_one_line_before_anything_runs(tmp_path, address):
    study = loads_study(STUDY, registry=REGISTRY)
    with pytest.raises(StudyError, match="expected a Dask scheduler address like tcp://"):
        run_study(study, tmp_path / "o", scheduler=address, progress=False)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("address", ["tcp://127.0.0.1:8786", "tls://scheduler.lan:8786"])
def test_good_scheduler_addresses_pass_the_check(address):
    check_scheduler(address)


def test_cli_scheduler_without_scheme_exits_2(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text("[study]\nruns = 1\nseed = 1\n[[estimators]]\nlabel = 'E'\n"
                    "method = 'equation-error'\n")
    assert main(["study", str(path), "--out", str(tmp_path / "o"), "--scheduler",
                 "localhost:8786", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "tcp://HOST:8786" in err[-1]


@pytest.mark.parametrize(("extra", "expected"), [
    (["--out", "FILE"], "is a file, not a folder"),
    (["--out", "."], "working directory or one of its parents"),
    (["--resume", "--overwrite"], "not both"),
])
def test_cli_bad_output_settings_exit_2_with_one_line(tmp_path, capsys, monkeypatch, extra,
                                                      expected):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "FILE").write_text("x")
    path = tmp_path / "s.toml"
    path.write_text("[study]\nruns = 1\nseed = 1\n[[estimators]]\nlabel = 'E'\n"
                    "method = 'equation-error'\n")
    assert main(["study", str(path), "--no-progress", *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and expected in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["FILE", "s.toml"]


def test_cli_a_second_run_into_the_same_folder_is_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "s.toml"
    path.write_text("[study]\nruns = 1\nseed = 1\n[[estimators]]\nlabel = 'E'\n"
                    "method = 'equation-error'\n")
    assert main(["study", str(path), "--no-progress"]) == 0
    first = (tmp_path / "results" / "s" / "results.jsonl").read_text()
    capsys.readouterr()
    assert main(["study", str(path), "--no-progress"]) == 2
    assert "--resume to complete them, --overwrite" in capsys.readouterr().err
    assert main(["study", str(path), "--no-progress", "--overwrite"]) == 0
    assert (tmp_path / "results" / "s" / "previous-1" / "results.jsonl").read_text() == first


def test_cli_interrupt_suggests_resume(tmp_path, capsys, monkeypatch):
    from aeroid.cli import _study

    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(_study, "study", interrupted)
    assert main(["study", "--no-progress"]) == 130
    assert "run the same command with --resume" in capsys.readouterr().err
