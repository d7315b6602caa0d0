"""``aeroid simulate``: writes a valid flight; bad input is one line on stderr, exit 2."""

from __future__ import annotations

import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from aeroid import __version__
from aeroid.cli import main
from aeroid.errors import AeroidWarning
from aeroid.flights import read_flight
from aeroid.flights._noise import NoNoise
from aeroid.flights._scenario import load_scenario
from aeroid.flights._simulate import simulate_scenario
from aeroid.model._airframe import dumps_toml, reference_scenario_data


def test_simulate_in_process_writes_the_paper_flight(tmp_path, capsys, paper_flight):
    out = tmp_path / "f.csv"
    assert main(["simulate", "--seed", "1", "-o", str(out)]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    assert "wrote" in captured.out and "501 samples" in captured.out
    flight = read_flight(out).validate()
    # the default noise is the paper's with the scenario's settings: seed 1 is the fixture
    pd.testing.assert_frame_equal(flight.data, paper_flight.data, check_exact=True)
    assert flight.airframe == paper_flight.airframe
    assert flight.metadata["seed"] == 1


#: CSV round trip of a float written with 17 significant digits: exact; the Gaussian
#: flight is compared after one addition, so allow a few ulps of the largest channel.
ADDITIVE_NOISE_ATOL = 1e-12


def test_simulate_noise_none_and_gaussian(tmp_path, capsys, clean_flight):
    out = tmp_path / "clean.csv"
    assert main(["simulate", "--noise", "none", "-o", str(out)]) == 0
    np.testing.assert_array_equal(read_flight(out)["ay2"], clean_flight["ay2"])
    out = tmp_path / "gauss.csv"
    assert main(["simulate", "--noise", "gaussian", "--seed", "4", "-o", str(out)]) == 0
    flight = read_flight(out)
    assert flight.metadata["noise"]["model"] == "gaussian"
    # GaussianNoise's documented draw order: the six accelerations as one (n, 6) block of
    # standard normals first, then p, q, r; defaults 0.05 m/s^2 and 0.005 rad/s
    draws = np.random.default_rng(4)
    n = clean_flight.n_samples
    for names, sd, block in ((("ax1", "ay1", "az1", "ax2", "ay2", "az2"), 0.05,
                              draws.standard_normal((n, 6))),
                             (("p", "q", "r"), 0.005, draws.standard_normal((n, 3)))):
        for j, name in enumerate(names):
            np.testing.assert_allclose(flight[name], clean_flight[name] + sd * block[:, j],
                                       rtol=0, atol=ADDITIVE_NOISE_ATOL)
    capsys.readouterr()


def test_simulate_with_a_scenario_file(tmp_path, capsys, clean_flight):
    data = reference_scenario_data()
    data["coefficients"]["Cx"] = -1.2
    data["recording"]["window_s"] = [5.0, 5.2]
    noise = data.pop("noise")
    scenario = tmp_path / "s.toml"
    scenario.write_text(dumps_toml(data) + dumps_toml({"noise.paper": noise["paper"]}))
    out = tmp_path / "s.csv"
    assert main(["simulate", "--scenario", str(scenario), "--noise", "none", "-o", str(out)]) == 0
    flight = read_flight(out)
    assert flight.n_samples == 101
    assert flight.metadata["true_coefficients"]["Cx"] == -1.2
    # the file's scenario, simulated in this process, is what the command wrote
    expected = simulate_scenario(load_scenario(scenario), NoNoise(), rng=0)
    pd.testing.assert_frame_equal(flight.data, expected.data, check_exact=True)
    capsys.readouterr()


def test_version(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"aeroid {__version__}"


def _bad_toml(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("[airframe\nmass_kg = 1\n")
    return path


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (lambda tmp: ["simulate", "--scenario", str(tmp / "absent.toml"), "-o", str(tmp / "f.csv")],
         "absent.toml: no such file"),
        (lambda tmp: ["simulate", "--scenario", str(_bad_toml(tmp)), "-o", str(tmp / "f.csv")],
         "malformed TOML"),
        (lambda tmp: ["simulate", "--noise", "laplace", "-o", str(tmp / "f.csv")],
         "invalid choice: 'laplace'"),
        (lambda tmp: ["simulate", "--seed", "one", "-o", str(tmp / "f.csv")],
         "invalid int value"),
        (lambda tmp: ["simulate", "--seed", "-1", "-o", str(tmp / "f.csv")],
         "--seed: must be an integer >= 0, got -1"),
        (lambda tmp: ["simulate", "-o", str(tmp / "no" / "such" / "f.csv")],
         "does not exist"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, argv, expected):
    try:
        status = main(argv(tmp_path))
    except SystemExit as exc:  # argparse errors exit from the parser
        status = exc.code
    captured = capsys.readouterr()
    assert status == 2
    lines = captured.err.splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith("aeroid") and "error:" in lines[0] and expected in lines[0]
    assert "Traceback" not in captured.err


def _run(*args, cwd):
    """Run the installed ``aeroid`` entry point (or ``main`` in this interpreter)."""
    script = shutil.which("aeroid")
    command = [script] if script else [sys.executable, "-c",
                                       "import sys; from aeroid.cli import main; sys.exit(main())"]
    return subprocess.run([*command, *args], capture_output=True, text=True, cwd=cwd,
                          timeout=120, check=False)


def test_subprocess_simulate_and_bad_input(tmp_path, paper_flight):
    done = _run("simulate", "--seed", "1", "-o", "f.csv", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    flight = read_flight(tmp_path / "f.csv").validate()
    pd.testing.assert_frame_equal(flight.data, paper_flight.data, check_exact=True)
    bad = _run("simulate", "--scenario", "absent.toml", "-o", "g.csv", cwd=tmp_path)
    assert bad.returncode == 2
    assert bad.stderr.count("\n") == 1 and "Traceback" not in bad.stderr
    assert not (tmp_path / "g.csv").exists()


def test_simulate_help_has_a_description_and_examples(capsys):
    with pytest.raises(SystemExit) as info:
        main(["simulate", "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "Simulate the flight of a scenario" in out
    assert "examples:\n  aeroid simulate --seed 1 -o flight.csv" in out


def test_simulate_prints_each_aeroid_warning_as_one_line(tmp_path, capsys, monkeypatch):
    import warnings

    import aeroid.flights  # the command takes simulate from the package's face

    original = aeroid.flights.simulate

    def warn_then_simulate(*args, **kwargs):
        warnings.warn("scenario: thrust is negative\n(a brake?)", AeroidWarning, stacklevel=2)
        return original(*args, **kwargs)

    monkeypatch.setattr(aeroid.flights, "simulate", warn_then_simulate)
    assert main(["simulate", "--noise", "none", "-o", str(tmp_path / "f.csv")]) == 0
    err = capsys.readouterr().err
    assert err == "aeroid: warning: scenario: thrust is negative (a brake?)\n"
