"""A sounding rocket's flight-computer log through the command line, start to finish
(issue 25): ``examples/make_rocket_log.py`` writes it, ``aeroid reconstruct`` makes the
raw-IMU flight, ``aeroid estimate`` fits it with the fin terms held (passive fin)."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

from aeroid.cli import main
from aeroid.flights import load_scenario
from aeroid.model import NAMES

ROOT = Path(__file__).resolve().parents[2]
#: Output-error's estimates within this many of their own standard errors: on the example's
#: seed (2026) Cx, Cl0, Clp lie within 0.6 (measured); the benchmark's 8 seeds within 1.8.
WITHIN_SE = 3.0


def _make_log():
    spec = importlib.util.spec_from_file_location("make_rocket_log",
                                                  ROOT / "examples" / "make_rocket_log.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.make_log


def test_rocket_log_start_to_finish(tmp_path, capsys):
    log = _make_log()(tmp_path / "rocket-log", verbose=False)
    raw = tmp_path / "raw.csv"
    assert main(["reconstruct", str(log), "-o", str(tmp_path / "states.csv"), "--flight",
                 str(raw), "--raw-imu"]) == 0
    out = capsys.readouterr()
    text = out.out + out.err
    assert "mounted: axes x=-y, y=x, z=z" in text
    assert 'the baro temperature is the board\'s, temperature = "board"' in text
    assert "gnss: positions only" in text
    assert text.count("consistent with the stated noise sd") == 3  # gnss, baro, ins
    assert main(["estimate", str(raw), "--method", "output-error", "--option",
                 "imu_errors=bias+scale", "--option", "estimate_initial_velocity=true",
                 "--option", "initial_velocity_prior=flight", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["success"], result["message"]
    assert sorted(result["held"]) == ["Cmd", "Czd"]
    truth = dict(zip(NAMES, load_scenario(ROOT / "studies" / "scenarios" /
                                          "rocket_coast.toml").coefficient_vector,
                     strict=True))
    for name in ("Cx", "Cl0", "Clp"):
        estimate, se = result["coefficients"][name], result["stderr"][name]
        assert abs(estimate - truth[name]) < WITHIN_SE * se, name
        assert se < 0.001 * abs(truth[name]), name  # and the se are informative: < 0.1 %


def test_the_same_log_with_a_wrong_mounting_is_not_a_success(tmp_path, capsys):
    # the same readings with a proper but wrong mounting (two signs flipped): on this seed
    # the residual checks say NOT consistent and output-error's fit fails (exit 1)
    log = _make_log()(tmp_path / "wrong", wrong_mounting=True, verbose=False)
    assert 'axes = "x=y, y=-x, z=z"' in log.read_text()
    raw = tmp_path / "raw.csv"
    # a residual check NOT consistent is exit status 1, the files still written
    assert main(["reconstruct", str(log), "-o", str(tmp_path / "states.csv"), "--flight",
                 str(raw), "--raw-imu"]) == 1
    out = capsys.readouterr()
    assert (out.out + out.err).count("NOT consistent") == 3
    assert main(["estimate", str(raw), "--method", "output-error", "--option",
                 "imu_errors=bias+scale", "--option", "estimate_initial_velocity=true",
                 "--option", "initial_velocity_prior=flight", "--json"]) == 1
    assert not json.loads(capsys.readouterr().out)["success"]
