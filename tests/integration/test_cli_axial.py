"""``aeroid estimate LOG.toml --method axial-drag`` (issue 25): a flight computer's files,
fitted as they are, on the command line.

References: the files written by ``examples/make_axial_log.py`` fitted by a subprocess
``aeroid estimate`` give exactly the Python fit's numbers (``read_suite_log`` and
``make_estimator("axial-drag", ...).fit``: same estimates, standard errors and cost, bit
for bit through JSON's shortest round-trip floats); the report's ``tables.csv`` holds
those points, and ``drag_vs_reference.csv`` equals ``-Cx S / S_ref`` and
``-(Cx +- 1.96 se) S / S_ref`` computed here from the JSON and the two areas, over the
fitted track's Mach range for a constant Cx. Every bad input is one line, exit 2.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from aeroid.cli import main
from aeroid.estimation import make_estimator
from aeroid.flights import (
    SensorSuite,
    load_scenario,
    read_suite_log,
    simulate_suite,
    write_suite_log,
)
from aeroid.model import NAMES

ROOT = Path(__file__).resolve().parents[2]
#: Seconds a subprocess command may take (imports, numba's cache, the two consider re-fits).
SUBPROCESS_TIMEOUT_S = 300
KNOTS = "[0.2, 0.4, 0.6, 0.9]"
MASS_SD_KG = 0.3
REFERENCE_AREA_M2 = 0.0129
#: The 95 % interval's half-width in standard errors (aeroid.report's Z95).
Z95 = 1.96
#: A CSV written with 10 significant digits (aeroid.report's DIGITS) against a float.
CSV_RTOL = 1e-9
CLI = "import sys; from aeroid.cli import main; sys.exit(main())"


def _run(args: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", CLI, *map(str, args)], text=True,
                          capture_output=True, timeout=SUBPROCESS_TIMEOUT_S, check=False)


@pytest.fixture(scope="module")
def log_toml(tmp_path_factory) -> Path:
    spec = importlib.util.spec_from_file_location(
        "make_axial_log", ROOT / "examples" / "make_axial_log.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.make_axial_log(tmp_path_factory.mktemp("axial") / "axial-log",
                                 verbose=False)


@pytest.fixture(scope="module")
def curve(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("curve") / "design.csv"
    path.write_text("Mach,Cd\n0.1,0.50\n0.5,0.46\n0.8,0.47\n1.0,0.60\n")
    return path


def _python_fit(path: Path, options: dict, mass_sd: float | None):
    log = read_suite_log(path)
    if mass_sd is not None:
        log = dataclasses.replace(log, airframe=log.airframe.replace(mass_sd_kg=mass_sd))
    return log, make_estimator("axial-drag", options).fit(log, rng=1)


def _reference_check(folder: Path, out: dict, area: float, mach: np.ndarray) -> None:
    """drag_vs_reference.csv against -Cx S / S_ref from the JSON (closed form, here)."""
    table = pd.read_csv(folder / "drag_vs_reference.csv")
    names = [n for n in out["coefficients"] if n.startswith("Cx")]
    cx = np.array([out["coefficients"][n] for n in names])
    se = np.array([out["stderr"][n] for n in names])
    if len(names) == 1:  # a constant Cx: a band over the track's Mach range
        cx, se = np.repeat(cx, 2), np.repeat(se, 2)
    factor = area / REFERENCE_AREA_M2
    np.testing.assert_allclose(table["mach"], mach, rtol=CSV_RTOL)
    np.testing.assert_allclose(table["cd"], -cx * factor, rtol=CSV_RTOL)
    np.testing.assert_allclose(table["cd_lo"], -(cx + Z95 * se) * factor, rtol=CSV_RTOL)
    np.testing.assert_allclose(table["cd_hi"], -(cx - Z95 * se) * factor, rtol=CSV_RTOL)


def test_the_command_line_reproduces_the_python_fit(log_toml, curve, tmp_path) -> None:
    report = tmp_path / "report"
    run = _run(["estimate", log_toml, "--method", "axial-drag", "--option",
                f"cx_knots={KNOTS}", "--mass-sd", MASS_SD_KG, "--seed", 1, "--json",
                "--report", report, "--reference-curve", curve, "--reference-area",
                REFERENCE_AREA_M2])
    assert run.returncode == 0, run.stderr
    assert "Traceback" not in run.stderr
    out = json.loads(run.stdout)
    log, result = _python_fit(log_toml, {"cx_knots": json.loads(KNOTS)}, MASS_SD_KG)
    assert out["success"] and result.success
    assert list(out["coefficients"]) == list(result.names) == [
        f"Cx@M{k:g}" for k in json.loads(KNOTS)]
    for j, name in enumerate(result.names):  # exactly: the same fit, bit for bit
        assert out["coefficients"][name] == result.theta[j], name
        assert out["stderr"][name] == result.stderr[j], name
    assert out["cost"] == result.cost
    # the mass sd widened the se (the consider path), said before the fit
    assert "--mass-sd: mass 10 +- 0.3 kg" in run.stderr
    assert "mass taken as exact" not in run.stderr  # the consider re-fits say nothing
    assert all(out["stderr"][n] > s for n, s in zip(
        result.names, result.consider.stderr_without, strict=True))
    # the report: the table's points, and the reference curve beside them
    tables = pd.read_csv(report / "tables.csv")
    np.testing.assert_allclose(tables["value"], result.theta, rtol=CSV_RTOL)
    _reference_check(report, out, log.airframe.area_m2, np.array(json.loads(KNOTS)))
    text = (report / "report.md").read_text()
    for part in ("# axial-drag on", "## Cx against Mach", "| Cx at Mach 0.4 |",
                 "## Drag against a reference curve", "consider parameters", "| accel |"):
        assert part in text, part
    assert (report / "tables.png").is_file() and (report / "drag_vs_reference.png").is_file()
    assert "Cd = -Cx x S_aeroid / S_ref" in run.stderr


def test_a_constant_cx_is_a_band_over_the_tracks_mach_range(log_toml, curve, tmp_path,
                                                              capsys) -> None:
    report = tmp_path / "band"
    assert main(["estimate", str(log_toml), "--method", "axial-drag", "--seed", "1",
                 "--json", "--report", str(report), "--reference-curve", str(curve),
                 "--reference-area", str(REFERENCE_AREA_M2)]) == 0
    out = json.loads(capsys.readouterr().out)
    log, result = _python_fit(log_toml, {}, None)
    assert out["coefficients"]["Cx"] == result.theta[0]
    low, high = result.info["mach_range"]
    # the coast flies Mach 0.9 down to 0.2 (the scenario): the fitted track's range
    assert 0.19 < low < 0.21 and 0.89 < high < 0.91
    _reference_check(report, out, log.airframe.area_m2, np.array([low, high]))
    assert "assumption: mass taken as exact" in (report / "report.md").read_text()


def test_method_all_on_a_suite_log_fits_the_methods_that_read_one(log_toml, capsys) -> None:
    status = main(["estimate", str(log_toml), "--method", "all", "--option",
                   "max_iterations=2"])
    assert status in (0, 1)  # two evaluations: the fit check decides, not this test
    out = capsys.readouterr()
    assert out.out.startswith("axial-drag: ")
    said = [line for line in out.err.splitlines() if "--method all on a suite log" in line]
    assert len(said) == 1 and "axial-drag (the installed methods that read" in said[0]
    assert "aeroid reconstruct" in said[0]


def _one_line_error(capsys, argv: list[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith("aeroid: error: ")]
    assert len(lines) == 1, err
    return lines[0]


@pytest.mark.parametrize(("extra", "match"), [
    (["--method", "output-error"], "output-error fits a flight: run 'aeroid reconstruct"),
    (["--method", "axial-drag,ekf"], "ekf fits a flight"),
    (["--method", "nope"], "unknown method 'nope'"),
    (["--method", "axial-drag", "--windows", "0-5"], "--windows is not taken with a suite"),
    (["--method", "axial-drag", "--degrees"], "--degrees is not taken with a suite log"),
    (["--method", "axial-drag", "--thrust-curve", "m.csv"], "go together"),
    (["--method", "axial-drag", "--hold", "Cx=-0.4"], "Cx held or given a prior"),
    (["--method", "axial-drag", "--prior", "Cma=-15:2"], "holds and priors are not taken"),
    (["--method", "axial-drag", "--option", "foo=1"], "option(s) foo taken by none"),
    (["--method", "axial-drag", "--mass-sd", "20"], "--mass-sd"),
    (["--method", "axial-drag", "--reference-curve", "c.csv"], "--reference-area"),
])
def test_bad_inputs_are_one_line(log_toml, capsys, extra, match) -> None:
    assert match in _one_line_error(capsys, ["estimate", str(log_toml), *extra])


def test_a_log_among_other_files_and_a_log_without_airframe(log_toml, tmp_path,
                                                             capsys) -> None:
    line = _one_line_error(capsys, ["estimate", str(log_toml), "f.csv", "--method",
                                    "axial-drag"])
    assert "a suite log is fitted alone" in line
    bare = tmp_path / "bare.toml"  # the same groups, no [log] airframe
    text = log_toml.read_text().split("[groups.imu]", 1)[1]
    bare.write_text("[groups.imu]" + text.replace('file = "', f'file = "{log_toml.parent}/'))
    line = _one_line_error(capsys, ["estimate", str(bare), "--method", "axial-drag"])
    assert "no airframe" in line and "--airframe" in line


def test_a_log_into_the_burn_fits_with_the_motor_file_and_fails_without(tmp_path,
                                                                       capsys) -> None:
    """The burnout scenario logged by the axial-only board (the suite simulator now flies
    the thrust): the motor given on the command line, the fit a success with Cx within 3
    se; the same files without it, not a success (exit 1)."""
    spec = importlib.util.spec_from_file_location(
        "make_axial_log", ROOT / "examples" / "make_axial_log.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    scenario = load_scenario(ROOT / "studies" / "scenarios" / "rocket_burnout.toml")
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         SensorSuite(**example.FLIGHT_COMPUTER), rng=3)
    curve = scenario.airframe.thrust_curve
    log = example.axial_only(sim.log)
    path = tmp_path / "burn.toml"
    write_suite_log(dataclasses.replace(log, airframe=log.airframe.replace(
        thrust_curve=None)), path)
    motor = tmp_path / "motor.csv"
    pd.DataFrame({"time_s": curve.time_s, "thrust_N": curve.thrust_n,
                  "mass_kg": curve.mass_kg}).to_csv(motor, index=False)
    assert main(["estimate", str(path), "--method", "axial-drag", "--json"]) == 1
    assert not json.loads(capsys.readouterr().out)["success"]
    assert main(["estimate", str(path), "--method", "axial-drag", "--json", "--thrust-curve",
                 str(motor), "--thrust-origin", "-0.5", "--burn", "0:1.6"]) == 0
    out = capsys.readouterr()
    result = json.loads(out.out)
    cx = float(scenario.coefficient_vector[NAMES.index("Cx")])
    assert abs(result["coefficients"]["Cx"] - cx) < 3 * result["stderr"]["Cx"]
    assert "--thrust-curve: " in out.err and "time nodes inside the burn" in out.err


def test_the_rocket_example_refuses_axial_only_with_another_mounting(tmp_path) -> None:
    run = subprocess.run([sys.executable, str(ROOT / "examples" / "make_rocket_log.py"),
                          str(tmp_path / "x"), "--axial-only", "--wrong-mounting"],
                         text=True, capture_output=True, timeout=SUBPROCESS_TIMEOUT_S,
                         check=False)
    assert run.returncode == 2
    assert "--axial-only writes the rocket coast's log" in run.stderr
    assert not (tmp_path / "x").exists()
