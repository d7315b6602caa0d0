"""``aeroid reconstruct``'s exit status: a residual check NOT consistent is not a success.

Reference: the reconstruction's own residual check (``Reconstruction.nis``) on the same
log in Python; a log whose INS sd is stated 5x too small (mean NIS far above 1: a
known-wrong input, tests/unit/test_reconstruction.py) and the same log as simulated.
"""

from __future__ import annotations

import dataclasses

import pytest

from aeroid.cli import main
from aeroid.cli._exits import EXIT_BAD_INPUT, EXIT_DONE, EXIT_NOT_SUCCESS
from aeroid.flights import read_suite_log, reference_scenario, simulate_suite, write_suite_log
from aeroid.reconstruction import reconstruct

#: The stated INS sd over the simulated one in the known-wrong log.
TOO_SMALL = 1.0 / 5.0


@pytest.fixture(scope="module")
def log():
    """The reference window's first 0.3 s through the default suite (seed 4)."""
    scenario = reference_scenario()
    manoeuvre = dataclasses.replace(scenario.manoeuvre, window_s=(5.0, 5.3))
    return simulate_suite(scenario.airframe, scenario.coefficient_vector, manoeuvre,
                          rng=4).log


def test_exit_statuses_are_distinct():
    assert len({EXIT_DONE, EXIT_NOT_SUCCESS, EXIT_BAD_INPUT}) == 3
    assert EXIT_DONE == 0 and EXIT_BAD_INPUT == 2


def test_not_consistent_exits_1_with_every_file_written(log, tmp_path, capsys):
    ins = log["ins"]
    wrong = dataclasses.replace(log, groups={**log.groups, "ins": dataclasses.replace(
        ins, noise_sd={c: s * TOO_SMALL for c, s in ins.noise_sd.items()})})
    write_suite_log(wrong, tmp_path / "suite.toml")
    check = reconstruct(read_suite_log(tmp_path / "suite.toml")).nis
    assert not check["ins"]["consistent"] and check["gnss"]["consistent"]
    out, flight = tmp_path / "states.csv", tmp_path / "flight.csv"
    status = main(["reconstruct", str(tmp_path / "suite.toml"), "-o", str(out),
                   "--flight", str(flight)])
    assert status == EXIT_NOT_SUCCESS == 1
    text = capsys.readouterr()
    assert "ins: mean NIS per dof" in text.out and "NOT consistent" in text.out
    assert out.exists() and flight.exists()  # everything asked for is still written
    last = text.err.strip().splitlines()[-1]
    assert "residual check refused ins" in last and "exit status 1" in last
    assert "gnss" not in last


def test_consistent_log_exits_0(log, tmp_path, capsys):
    write_suite_log(log, tmp_path / "suite.toml")
    assert all(s["consistent"] for s in reconstruct(read_suite_log(tmp_path / "suite.toml"))
               .nis.values())
    status = main(["reconstruct", str(tmp_path / "suite.toml"), "-o",
                   str(tmp_path / "states.csv")])
    assert status == EXIT_DONE
    text = capsys.readouterr()
    assert "NOT consistent" not in text.out and "refused" not in text.err
