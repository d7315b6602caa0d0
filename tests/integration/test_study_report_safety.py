"""A study's report is written atomically, and one study at a time writes a folder.

Issue 21: a disk that filled while the report was written crashed with a traceback (the
records were kept, nobody said so); a kill during the report left a 0-byte results.csv
or PNG; a ``--resume`` into a folder another study was writing doubled 42 records. The
disk fills here by a patched write that lets part of the bytes out first, as a real
full disk does; the second writer is a real process holding the lock (then SIGKILLed).
"""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from study_fakes import REGISTRY

from aeroid.cli import main
from aeroid.study import _design as design
from aeroid.study import _store, read_results, study_lock

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
STUDY = """
[study]
name = "safety"
runs = 2
seed = 3

[[noise]]
label = "paper"
model = "paper"

[[estimators]]
label = "J1"
method = "jitter"
"""
#: Seconds the lock-holding subprocess may take to start (imports aeroid).
START_TIMEOUT_S = 60


@pytest.fixture
def study_file(tmp_path, monkeypatch):
    monkeypatch.setattr(design, "_registry", lambda: REGISTRY)
    path = tmp_path / "s.toml"
    path.write_text(STUDY)
    return path


def _study(path: Path, out: Path, *extra: str) -> int:
    return main(["study", str(path), "--out", str(out), "--no-progress", *extra])


def _fill_disk_on(monkeypatch, name: str) -> None:
    """Make writes to files named ``name`` (or ``name.tmp``) fail half-way with ENOSPC."""
    original = _store._write_all

    def write(fd, data):
        target = os.path.basename(os.readlink(f"/proc/self/fd/{fd}"))
        if target in (name, name + ".tmp"):
            os.write(fd, data[: len(data) // 2])
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        original(fd, data)

    monkeypatch.setattr(_store, "_write_all", write)


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc")
def test_a_full_disk_during_the_report_keeps_the_records_and_says_so(study_file, tmp_path,
                                                                      monkeypatch, capsys):
    out = tmp_path / "out"
    _fill_disk_on(monkeypatch, "results.csv")
    assert _study(study_file, out) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("aeroid: error: the report was not written (")
    assert "results.csv: cannot write: No space left on device" in err
    assert f"all 2 fit records are kept in {out / 'results.jsonl'}" in err
    assert "--resume to write the report" in err
    assert len(read_results(out / "results.jsonl")) == 2
    assert not (out / "results.csv").exists()  # no half file under the real name
    assert list(out.rglob("*.tmp")) == []
    monkeypatch.undo()  # the disk has room again
    monkeypatch.setattr(design, "_registry", lambda: REGISTRY)
    assert _study(study_file, out, "--resume") == 0
    assert "0 new fits" in capsys.readouterr().err
    assert (out / "results.csv").read_text().count("\n") > 2


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc")
def test_a_failed_rewrite_leaves_the_previous_report_files_whole(study_file, tmp_path,
                                                                  monkeypatch, capsys):
    out = tmp_path / "out"
    assert _study(study_file, out) == 0
    before = {p: p.read_bytes() for p in (out / "results.csv", out / "summary.csv",
                                          out / "report.md")}
    pngs = sorted((out / "figures").glob("*.png"))
    assert pngs
    _fill_disk_on(monkeypatch, "summary.csv")
    assert _study(study_file, out, "--resume") == 2
    assert "the report was not written" in capsys.readouterr().err
    for path, data in before.items():
        assert path.read_bytes() == data, path
    # a figure whose write dies half-way: the previous PNG stays, no temporary is left
    import matplotlib.figure

    def savefig(self, fname, **kwargs):
        Path(fname).write_bytes(PNG_MAGIC)  # the first bytes got out
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(fname))

    monkeypatch.undo()
    monkeypatch.setattr(design, "_registry", lambda: REGISTRY)
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", savefig)
    assert _study(study_file, out, "--resume") == 2
    err = capsys.readouterr().err
    assert "No space left on device" in err and "fit records are kept" in err
    for png in pngs:
        data = png.read_bytes()
        assert data.startswith(PNG_MAGIC) and len(data) > 1000, png
    assert list(out.rglob("*.tmp")) == []


def test_a_second_study_in_a_locked_folder_is_refused(study_file, tmp_path, capsys):
    out = tmp_path / "out"
    with study_lock(out) as notes:
        assert notes == []
        assert _study(study_file, out, "--resume") == 2
        err = capsys.readouterr().err.strip().splitlines()[-1]
        assert err.startswith(f"aeroid: error: {out}: another study is writing this folder "
                              f"(pid {os.getpid()} on ")
        assert not (out / "results.jsonl").exists()  # refused before anything was written
    assert not (out / "study.lock").exists()
    assert _study(study_file, out) == 0
    assert not (out / "study.lock").exists()


def test_the_lock_of_a_killed_study_is_taken_over_with_a_note(study_file, tmp_path, capsys):
    out = tmp_path / "out"
    code = ("import sys, time; from aeroid.study import study_lock\n"
            "with study_lock(sys.argv[1]):\n"
            "    print('locked', flush=True); time.sleep(600)\n")
    holder = subprocess.Popen([sys.executable, "-c", code, str(out)], stdout=subprocess.PIPE,
                              text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        assert _study(study_file, out) == 2
        assert f"(pid {holder.pid} on " in capsys.readouterr().err
        holder.send_signal(signal.SIGKILL)
        holder.wait(timeout=START_TIMEOUT_S)
    finally:
        if holder.poll() is None:
            holder.kill()
            holder.wait()
        holder.stdout.close()
    assert f"pid {holder.pid} on " in (out / "study.lock").read_text()  # left behind
    started = time.monotonic()
    assert _study(study_file, out) == 0
    assert time.monotonic() - started < START_TIMEOUT_S
    err = capsys.readouterr().err
    assert f"took over the lock {out / 'study.lock'} left by pid {holder.pid} on " in err
    assert len(read_results(out / "results.jsonl")) == 2


# Real kills during the report ----------------------------------------------------------
REPORT_SCRIPT = """
import os, signal, sys
from study_fakes import REGISTRY, STUDY
from aeroid.study import _store, loads_study, run_study, write_report
out, target = sys.argv[1], sys.argv[2]
study = loads_study(STUDY, registry=REGISTRY)
outcome = run_study(study, out, resume=True, progress=False)
if target.endswith(".png"):
    import matplotlib.figure
    original = matplotlib.figure.Figure.savefig
    def savefig(self, fname, **kwargs):
        if os.path.basename(str(fname)) == target + ".tmp":
            with open(fname, "wb") as fh:
                fh.write(b"\\x89PNG\\r\\n\\x1a\\n")  # the first bytes of the PNG, then killed
            os.kill(os.getpid(), signal.SIGKILL)
        return original(self, fname, **kwargs)
    matplotlib.figure.Figure.savefig = savefig
elif target != "none":
    original = _store._write_all
    def write(fd, data):
        if os.path.basename(os.readlink(f"/proc/self/fd/{fd}")) == target + ".tmp":
            os.write(fd, data[: len(data) // 2])
            os.kill(os.getpid(), signal.SIGKILL)
        original(fd, data)
    _store._write_all = write
write_report(study, out, outcome.records)
"""
#: Seconds a report subprocess may take (a 12-fit study of stand-ins, its floors, figures).
REPORT_TIMEOUT_S = 300


def _report_killed_at(out: Path, target: str) -> int:
    here = Path(__file__).parent
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(here), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-c", REPORT_SCRIPT, str(out), target], env=env,
                          capture_output=True, text=True, timeout=REPORT_TIMEOUT_S)
    assert done.returncode in (0, -signal.SIGKILL), done.stderr
    return done.returncode


# 24 s of the fast suite (a study killed over and over while it writes its report), which
# a fresh clone's .ci/run had brought to 902 s (limit 15 min); a kill during the study
# itself stays fast (tests/integration/test_study_store.py)
@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc")
def test_a_sigkill_during_the_report_never_leaves_a_truncated_file(tmp_path):
    out = tmp_path / "out"
    # killed while the first results.csv is half written: there is none, not half of one
    assert _report_killed_at(out, "results.csv") == -signal.SIGKILL
    assert not (out / "results.csv").exists()
    assert _report_killed_at(out, "none") == 0
    whole = {p.relative_to(out): p.read_bytes()
             for p in [out / "results.csv", out / "summary.csv", out / "report.md",
                       *sorted((out / "figures").glob("*.png"))]}
    assert list(out.rglob("*.tmp")) == []
    for target in ("results.csv", "summary.csv", "report.md", "runtime.png"):
        assert _report_killed_at(out, target) == -signal.SIGKILL, target
        for name, data in whole.items():  # each file is the previous one, whole
            assert (out / name).read_bytes() == data, (target, name)
