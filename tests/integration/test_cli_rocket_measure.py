"""Issue 25's measure flight through the command line (studies/scenarios/rocket_measure.toml:
the flight computer's coast, the coast mass 2 % above the file's with a 3 % sd, Cx as a
table in Mach): the same log with one axis sign flipped in the mounting is not a success."""

from __future__ import annotations

from pathlib import Path

from test_cli_rocket import _make_log  # the example script's loader, written once

from aeroid.cli import main

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "studies" / "scenarios" / "rocket_measure.toml"
#: The board's axis map with one sign flipped (z): a reflection, determinant -1.
ONE_SIGN_FLIPPED = "x=-y, y=x, z=-z"


def test_one_axis_sign_flipped_is_refused_in_one_line(tmp_path, capsys):
    log = _make_log()(tmp_path / "flipped", verbose=False, scenario_path=SCENARIO,
                      mounting=ONE_SIGN_FLIPPED)
    assert f'axes = "{ONE_SIGN_FLIPPED}"' in log.read_text()
    status = main(["reconstruct", str(log), "-o", str(tmp_path / "states.csv"), "--flight",
                   str(tmp_path / "raw.csv"), "--raw-imu"])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and not (tmp_path / "raw.csv").exists()
    assert err[-1] == (f"aeroid: error: {log}: [groups.imu].mounting: axes {ONE_SIGN_FLIPPED} "
                       "is not a proper rotation (determinant -1: one axis mirrored; check "
                       "the signs)")
    # every single sign flip of the board's map is a reflection: each is refused
    for flipped in ("x=y, y=x, z=z", "x=-y, y=-x, z=z"):
        log = _make_log()(tmp_path / flipped.replace(", ", "_").replace("=", ""),
                          verbose=False, scenario_path=SCENARIO, mounting=flipped)
        assert main(["reconstruct", str(log), "-o", str(tmp_path / "s.csv")]) == 2
        assert "is not a proper rotation (determinant -1" in capsys.readouterr().err
