"""Issue 21's hostile commands: each is exit status 2 (143 for SIGTERM) with one line.

Output that cannot be written, numbers beyond the float range, nesting beyond the parser,
a closed pipe, SIGTERM, and the messages that said the wrong thing (a sidecar without
read permission, a noise option, a TOML byte-order mark, spaces in a CSV header, an
``airframe = 5``). Each used to end in a traceback or an unclear line.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

import aeroid.cli
from aeroid.cli import main
from aeroid.model import reference_scenario_data

#: A 400-digit integer: TOML and JSON read it exactly; float() of it overflows.
HUGE = "9" * 400
#: Seconds a subprocess command may take (imports, numba's cache).
SUBPROCESS_TIMEOUT_S = 180
SCENARIO = (Path(aeroid.cli.__file__).parents[1] / "data" / "reference-scenario.toml")


def _one_line_error(capsys, argv: list[str], status: int = 2) -> str:
    assert main(argv) == status
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith("aeroid: error: ")]
    assert len(lines) == 1, err
    return lines[0]


def _run(args: list[str], **kwargs) -> subprocess.CompletedProcess:
    code = "import sys; from aeroid.cli import main; sys.exit(main())"
    return subprocess.run([sys.executable, "-c", code, *args], text=True,
                          timeout=SUBPROCESS_TIMEOUT_S, **kwargs)


@pytest.fixture(scope="module")
def flight_csv(tmp_path_factory, paper_flight):
    path = tmp_path_factory.mktemp("flight") / "f.csv"
    paper_flight.write(path)
    return path


# Output that cannot be written --------------------------------------------------------
@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
def test_json_to_a_full_disk(flight_csv):
    with open("/dev/full", "w") as full:
        done = _run(["estimate", str(flight_csv), "--method", "equation-error", "--json"],
                    stdout=full, stderr=subprocess.PIPE)
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().splitlines()[-1] == (
        "aeroid: error: standard output: cannot write: No space left on device")
    assert "Traceback" not in done.stderr and "Exception ignored" not in done.stderr


def test_a_closed_pipe():
    with subprocess.Popen([sys.executable, "-c",
                           "import sys; from aeroid.cli import main; sys.exit(main())",
                           "methods", "--options", "output-error"],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as proc:
        proc.stdout.close()  # `| head -0`: the reader is gone before the first line
        err = proc.stderr.read()
        status = proc.wait(timeout=SUBPROCESS_TIMEOUT_S)
    assert status == 2, err
    assert err.strip() == ("aeroid: error: standard output was closed before everything "
                           "was written (broken pipe)")


@pytest.mark.parametrize(("target", "reason"), [
    ("/dev/full", "No space left on device"),
    ("/proc/version", "Input/output error|Permission denied"),
    ("LONG", "File name too long"),
])
def test_simulate_to_a_file_that_cannot_be_written(capsys, tmp_path, target, reason):
    if not Path(target).exists() and target != "LONG":
        pytest.skip(f"no {target}")
    path = str(tmp_path / ("a" * 300 + ".csv")) if target == "LONG" else target
    err = _one_line_error(capsys, ["simulate", "-o", path])
    assert err.startswith(f"aeroid: error: -o {path}: cannot write the flight: ")
    assert any(r in err for r in reason.split("|")), err


@pytest.mark.parametrize("out", ["b" * 300, "b/" * 2500, "loop"])
def test_study_out_folders_the_system_refuses(capsys, tmp_path, out):
    if out == "loop":
        (tmp_path / "loop").symlink_to(tmp_path / "loop")
    err = _one_line_error(capsys, ["study", "--runs", "1", "--no-progress",
                                   "--out", str(tmp_path / out)])
    assert "cannot use it as a folder: " in err
    assert ("a symbolic link loop" if out == "loop" else "File name too long") in err
    assert len(err) < 400  # a 5000-character name is shortened in the message


# Numbers beyond the float range, nesting beyond the parser -----------------------------
def _scenario(tmp_path, old: str, new: str) -> Path:
    text = SCENARIO.read_text()
    assert old in text
    path = tmp_path / "s.toml"
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize(("old", "new", "fragment"), [
    ("mass_kg = 70.0", f"mass_kg = {HUGE}",
     "[airframe] mass_kg must be a finite number, got 999"),
    ("command_amplitude = 0.5", f"command_amplitude = {HUGE}", "command_amplitude must be"),
    ("accelerations_xi = 0.05", f"accelerations_xi = {HUGE}",
     "accelerations_xi must be a finite number >= 0"),
])
def test_a_400_digit_integer_in_a_scenario(capsys, tmp_path, old, new, fragment):
    path = _scenario(tmp_path, old, new)
    err = _one_line_error(capsys, ["simulate", "--scenario", str(path), "-o",
                                   str(tmp_path / "f.csv")])
    assert fragment in err


def test_a_400_digit_integer_in_a_fin_law_and_an_airframe(capsys, tmp_path, flight_csv):
    path = tmp_path / "a.toml"
    data = reference_scenario_data()
    lines = ["[airframe]"] + [f"{k} = {json.dumps(v)}" for k, v in data["airframe"].items()]
    lines += ["[atmosphere]", "altitude_m = 10000.0",
              "[fin_law]", f"command_amplitude = {HUGE}", "command_phase_deg = 60.0"]
    path.write_text("\n".join(lines) + "\n")
    err = _one_line_error(capsys, ["estimate", str(flight_csv), "--airframe", str(path),
                                   "--method", "equation-error"])
    assert "[fin_law] command_amplitude" in err


@pytest.mark.parametrize(("key", "value", "fragment"), [
    ("prior_offset", f"[0.1, {HUGE}]", "[study] prior_offset must be two numbers"),
    ("noise", HUGE, "accel_sd_mps2 must be a finite number >= 0"),
])
def test_a_400_digit_integer_in_a_study(capsys, tmp_path, key, value, fragment):
    noise = f"accel_sd_mps2 = {value}\n" if key == "noise" else ""
    offset = f"prior_offset = {value}\n" if key == "prior_offset" else ""
    path = tmp_path / "s.toml"
    path.write_text(f'[study]\nname = "h"\nruns = 1\nseed = 1\n{offset}'
                    f'[[noise]]\nlabel = "g"\nmodel = "gaussian"\n{noise}'
                    '[[estimators]]\nlabel = "ee"\nmethod = "equation-error"\n')
    err = _one_line_error(capsys, ["study", str(path), "--no-progress", "--out",
                                   str(tmp_path / "out")])
    assert fragment in err


def test_a_sidecar_nested_100000_deep(capsys, tmp_path, paper_flight):
    sidecar = paper_flight.write(tmp_path / "f.csv")
    text = sidecar.read_text()
    sidecar.write_text(text.replace('"metadata": {',
                                    '"metadata": {"deep": ' + "[" * 100_000 + "]" * 100_000
                                    + ", ", 1))
    err = _one_line_error(capsys, ["estimate", str(tmp_path / "f.csv"), "--method",
                                   "equation-error"])
    assert f"{sidecar}: JSON nested too deeply to read" in err


def test_a_toml_nested_100000_deep(capsys, tmp_path):
    path = tmp_path / "s.toml"
    path.write_text("[airframe]\nx = " + "[" * 100_000 + "]" * 100_000 + "\n")
    err = _one_line_error(capsys, ["simulate", "--scenario", str(path), "-o",
                                   str(tmp_path / "f.csv")])
    assert "malformed TOML (arrays or tables nested thousands deep)" in err


# SIGTERM -------------------------------------------------------------------------------
def test_sigterm_is_one_line_and_status_143(capsys, monkeypatch):
    def dispatch(args):
        os.kill(os.getpid(), signal.SIGTERM)  # a real signal to this process
        time.sleep(30)  # the handler raises before this ends
        return 0

    before = signal.getsignal(signal.SIGTERM)
    monkeypatch.setattr(aeroid.cli, "_dispatch", dispatch)
    started = time.monotonic()
    assert main(["study", "--runs", "1", "--no-progress"]) == 143
    assert time.monotonic() - started < 30
    assert capsys.readouterr().err.strip().splitlines()[-1] == (
        "aeroid: terminated by SIGTERM; run the same command with --resume to complete "
        "only what is missing")
    assert signal.getsignal(signal.SIGTERM) == before  # the caller's handler is back


# Messages that said the wrong thing ----------------------------------------------------
def test_a_sidecar_without_read_permission_says_so(capsys, tmp_path, paper_flight,
                                                   monkeypatch):
    sidecar = paper_flight.write(tmp_path / "f.csv")  # tests run as root: mock the denial
    original = Path.read_bytes

    def read_bytes(self):
        if self == sidecar:
            raise PermissionError(13, "Permission denied", str(self))
        return original(self)

    monkeypatch.setattr(Path, "read_bytes", read_bytes)
    err = _one_line_error(capsys, ["estimate", str(tmp_path / "f.csv"), "--method",
                                   "equation-error"])
    assert f"{sidecar}: cannot read the sidecar (Permission denied)" in err
    assert "not JSON" not in err


def test_an_unknown_noise_option_is_the_only_one_named(capsys, tmp_path):
    path = _scenario(tmp_path, "rates_xi = 0.05", "rates_xi = 0.05\nbogus = 3")
    err = _one_line_error(capsys, ["simulate", "--scenario", str(path), "-o",
                                   str(tmp_path / "f.csv")])
    assert ("noise model 'paper': unknown option(s) ['bogus']; allowed ['accelerations_xi', "
            "'rates_xi', 'accel_position_xi']") in err


def test_a_byte_order_mark_in_a_toml_file(capsys, tmp_path):
    path = tmp_path / "s.toml"
    path.write_bytes(b"\xef\xbb\xbf" + SCENARIO.read_bytes())
    err = _one_line_error(capsys, ["simulate", "--scenario", str(path), "-o",
                                   str(tmp_path / "f.csv")])
    assert "starts with a UTF-8 byte-order mark (BOM), which TOML does not allow" in err


def test_spaces_after_the_commas_of_a_csv_header(capsys, tmp_path, paper_flight):
    sidecar = paper_flight.write(tmp_path / "f.csv")
    head, rest = (tmp_path / "f.csv").read_text().split("\n", 1)
    (tmp_path / "f.csv").write_text(head.replace(",", ", ") + "\n" + rest)
    assert sidecar.exists()
    err = _one_line_error(capsys, ["estimate", str(tmp_path / "f.csv"), "--method",
                                   "equation-error"])
    assert "column name(s) ' ax1', ' ay1', ' az1', ' ax2', ... have spaces around them" in err
    assert "missing required" not in err


def test_airframe_as_a_number(capsys, tmp_path, flight_csv):
    path = tmp_path / "a.toml"
    path.write_text("airframe = 5\n")
    err = _one_line_error(capsys, ["estimate", str(flight_csv), "--airframe", str(path),
                                   "--method", "equation-error"])
    assert err == f"aeroid: error: {path}: [airframe] must be a table, got 5"


# Repeated numerical warnings -----------------------------------------------------------
def test_the_ekf_on_extreme_accelerations_warns_in_two_lines(capsys, tmp_path, paper_flight):
    data = {c: paper_flight[c] for c in paper_flight.channels}
    for c in ("ax1", "ay1", "az1", "ax2", "ay2", "az2"):
        data[c] = data[c] * 1e150  # within the spike check: every sample scaled alike
    from aeroid.flights import make_flight

    make_flight(data, paper_flight.airframe, paper_flight.metadata).write(tmp_path / "f.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("default")  # as outside pytest (which makes warnings errors)
        assert main(["estimate", str(tmp_path / "f.csv"), "--method", "ekf", "--quiet"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    # was 4006 lines: 2003 LinAlgWarnings of scipy.linalg.inv, each with its source line
    assert len(err) == 2, err
    assert err[0].startswith("aeroid: warning: LinAlgWarning at filterpy/kalman/EKF.py:")
    assert "more like it in this filter pass" in err[0]
    assert err[1].endswith("more time(s), not shown")


def test_a_repeated_notice_is_printed_once_and_warnings_always(capsys) -> None:
    """A study's fits each say the same notice (the fin law taken): the command prints
    it once; a warning is printed every time."""
    import logging

    from aeroid.cli import _notices

    logger = logging.getLogger("aeroid")
    handler = _notices(False)
    try:
        for _ in range(3):
            logger.info("output-error: input = law (the airframe has a [fin_law])")
            logger.warning("warning: something")
        logger.info("another notice")
    finally:
        logger.removeHandler(handler)
    err = capsys.readouterr().err.splitlines()
    assert err == ["aeroid: output-error: input = law (the airframe has a [fin_law])",
                   "aeroid: warning: something", "aeroid: warning: something",
                   "aeroid: warning: something", "aeroid: another notice"]
