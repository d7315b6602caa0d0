"""``--quiet`` and ``--no-progress`` mean the same on every command that has them."""

from __future__ import annotations

import sys

import numba

from aeroid.cli import build_parser, main


def _options(command: str) -> dict[str, str]:
    parser = build_parser()
    (sub,) = [a for a in parser._actions if a.dest == "command"]
    return {option: action.help for action in sub.choices[command]._actions
            for option in action.option_strings}


def test_the_commands_with_a_progress_bar_take_both_options_with_one_meaning():
    estimate, study = _options("estimate"), _options("study")
    for option in ("--quiet", "--no-progress"):
        assert estimate[option] == study[option], option
    assert estimate["--quiet"] == "no progress bar and no notices"
    assert estimate["--no-progress"] == "no progress bar"
    assert "--quiet" in _options("simulate")  # no bar to hide: its notices only


def test_study_quiet_hides_bar_and_notices_on_a_terminal(tmp_path, capsys, monkeypatch):
    from aeroid.cli import _study

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    path = tmp_path / "s.toml"
    path.write_text("[study]\nruns = 1\nseed = 1\n[[estimators]]\nlabel = 'E'\n"
                    "method = 'equation-error'\n")
    probe = numba.njit(lambda x: x - 1.0)  # a compilation: a notice unless --quiet
    original = _study.study
    monkeypatch.setattr(_study, "study", lambda args: (probe(1.0), original(args))[1])
    assert main(["study", str(path), "--quiet", "--out", str(tmp_path / "a")]) == 0
    err = capsys.readouterr().err
    assert "aeroid:" not in err and "1/1 [" not in err
    # without it: the bar and the notice (this test can fail)
    probe = numba.njit(lambda x: x - 2.0)
    assert main(["study", str(path), "--out", str(tmp_path / "b")]) == 0
    err = capsys.readouterr().err
    assert "aeroid: compiling the numba kernel <lambda>" in err and "1/1 [" in err
