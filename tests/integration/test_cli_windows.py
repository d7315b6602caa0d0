"""``aeroid estimate a.csv b.csv`` and ``--windows``: several windows in one fit, end to end.

Reference: the same fit through the Python face (:class:`aeroid.flights.Windows`,
:func:`aeroid.flights.cut_windows`) gives the same numbers as the command line.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from aeroid.cli import main
from aeroid.flights import (
    GaussianNoise,
    Windows,
    cut_windows,
    read_flight,
    reference_scenario,
    simulate_scenario,
)
from baselines.equation_error import EquationErrorEstimator

NOISE = GaussianNoise(accel_sd_mps2=0.05, rate_sd_radps=0.002, position_sd_m=0.0)


def _flight(window_s, seed):
    sc = reference_scenario()
    sc = dataclasses.replace(sc, manoeuvre=dataclasses.replace(sc.manoeuvre,
                                                               window_s=window_s))
    flight = simulate_scenario(sc, NOISE, rng=seed)
    prior = tuple(flight.airframe.prior_vector())  # given: no missing-prior notice
    return dataclasses.replace(flight, airframe=flight.airframe.replace(prior=prior))


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("windows")
    paths = {"log": folder / "log.csv", "a": folder / "a.csv", "b": folder / "b.csv"}
    _flight((5.0, 6.6), 7).write(paths["log"])
    _flight((5.0, 5.4), 8).write(paths["a"])
    _flight((5.0, 5.4), 9).write(paths["b"])
    return paths


def _one_line_error(capsys, argv: list[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("aeroid: error: ")
    return err


def test_two_files_json_per_window_matches_the_python_face(files, capsys):
    assert main(["estimate", str(files["a"]), str(files["b"]), "--method", "equation-error",
                 "--json", "--quiet"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [w["name"] for w in out["windows"]] == ["a", "b"]
    assert all(w["samples"] == 201 for w in out["windows"])
    windows = Windows((read_flight(files["a"]), read_flight(files["b"])), ("a", "b"))
    res = EquationErrorEstimator().fit(windows)
    np.testing.assert_allclose([out["coefficients"][n] for n in res.names], res.theta,
                               rtol=1e-12)


def test_windows_of_one_log_text_shows_each_windows_parameters(files, capsys):
    assert main(["estimate", str(files["log"]), "--windows", "5-5.3,6-6.3", "--method",
                 "output-error", "--option", "equation_error_start=false", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "per-window parameters" in text
    assert "  5-5.3: p0 = " in text and "  6-6.3: p0 = " in text and "; r0 = " in text


def test_windows_report_has_one_set_of_panels_per_window(files, tmp_path, capsys):
    report = tmp_path / "report"
    assert main(["estimate", str(files["log"]), "--windows", "5-5.3,6-6.3", "--method",
                 "ekf", "--report", str(report), "--quiet"]) == 0
    text = (report / "report.md").read_text()
    assert "## Windows" in text and "### Window 5-5.3" in text and "### Window 6-6.3" in text
    for name in ("5-5.3", "6-6.3"):
        for stem in ("ax1", "r", "deflection", "autocorrelation"):
            assert (report / f"{name}--{stem}.png").is_file()
    # the per-window panels start from each window's own state: the first window's model
    # is simulated on that window's samples only
    windows = cut_windows(read_flight(files["log"]), "5-5.3,6-6.3")
    assert f"{windows.flights[1].n_samples} samples, t = 6 .. 6.3 s" in text


@pytest.mark.parametrize(("argv", "says"), [
    (["--windows", "4-5.3"], "outside the log"),
    (["--windows", "5-5.3,5.2-5.6"], "overlap"),
    (["--windows", "5.3-5"], "ends before it starts"),
    (["--windows", "five-six"], "not START-END")])
def test_bad_windows_are_one_line_errors(files, capsys, argv, says):
    err = _one_line_error(capsys, ["estimate", str(files["log"]), "--method",
                                   "equation-error", *argv])
    assert says in err


def test_windows_with_several_files_or_a_pso_method_are_refused(files, capsys):
    err = _one_line_error(capsys, ["estimate", str(files["a"]), str(files["b"]),
                                   "--windows", "5-5.2", "--method", "equation-error"])
    assert "--windows" in err
    err = _one_line_error(capsys, ["estimate", str(files["a"]), str(files["b"]),
                                   "--method", "sebm-pso"])
    assert "cannot fit several windows" in err
