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
