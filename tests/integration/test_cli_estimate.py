"""``aeroid estimate`` and ``aeroid methods``: end to end, errors, and entry-point plug-ins."""

from __future__ import annotations

import dataclasses
import json
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from aeroid.cli import main
from aeroid.errors import AeroidWarning
from aeroid.estimation import available, get_estimator
from aeroid.flights._flight import Flight
from aeroid.model._airframe import save_airframe
from aeroid.model._coefficients import NAMES

PLUGIN_DIR = Path(__file__).resolve().parents[1] / "plugin"
#: The CLI run in a fresh interpreter (``python -m aeroid.cli`` would warn: aeroid's
#: package import already imports aeroid.cli).
CLI = [sys.executable, "-c", "import sys; from aeroid.cli import main; sys.exit(main())"]
FAST = ["--option", "n_iterations=20"]
#: The same flight through degrees and back differs by round-off (1e-16); SEBM-PSO at its
#: default 200 iterations converges onto the closed form (test_paper_estimators), so the
#: estimates agree far better than this (a half-converged swarm would amplify round-off).
DEGREES_RTOL = 1e-6


@pytest.fixture(scope="module")
def flight_csv(tmp_path_factory, paper_flight) -> Path:
    """The paper flight with its airframe's prior given (the reference coefficients, the
    start a missing [prior] means too): no notice about it on stderr."""
    path = tmp_path_factory.mktemp("cli") / "flight.csv"
    prior = tuple(paper_flight.airframe.prior_vector())
    dataclasses.replace(paper_flight, airframe=paper_flight.airframe.replace(prior=prior)
                        ).write(path)
    return path


def _run(args: list[str], env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=300, env=env,
                          check=False)


def _one_line_error(capsys, argv: list[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("aeroid: error: ")
    return err


def test_estimate_json_in_a_subprocess_matches_in_process(flight_csv, capsys) -> None:
    args = ["estimate", str(flight_csv), "--method", "sebm-pso", "--seed", "1", "--json"]
    proc = _run(args)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["method"] == "sebm-pso"
    assert out["success"] is True
    assert list(out["coefficients"]) == list(NAMES)
    assert {"stderr", "message", "n_evaluations", "wall_time_s"} <= set(out)
    assert main(args) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["coefficients"] == out["coefficients"]  # same seed, same numbers


def test_estimate_table_shows_truth_when_known(flight_csv, capsys) -> None:
    assert main(["estimate", str(flight_csv), "--method", "ebm-pso", "--seed", "2", *FAST]) == 0
    out = capsys.readouterr().out
    assert "ebm-pso: ok" in out
    assert "truth" in out and "error %" in out
    for name in NAMES:
        assert name in out


def test_methods_lists_the_papers_estimators(capsys) -> None:
    assert main(["methods"]) == 0
    out = capsys.readouterr().out
    for name in ("eam-pso", "ebm-pso", "sebm-pso"):
        assert name in out


@pytest.mark.parametrize(("extra", "fragment"), [
    (["--method", "nope"], "unknown method 'nope'"),
    (["--method", "ebm-pso", "--option", "colour=red"], "unknown option(s) colour"),
    (["--method", "ebm-pso", "--option", "n_particles"], "expected KEY=VALUE"),
    (["--method", "ebm-pso", "--option", "n_particles=many"], "expects an integer"),
    (["--method", "ebm-pso", "--option", "n_particles=100000000"],
     "n_particles must be in [3, 10000]"),
    (["--method", "eam-pso", "--option", "n_iterations=0"], "n_iterations must be in [1, "),
])
def test_bad_method_or_option_exit_2(flight_csv, capsys, extra, fragment) -> None:
    assert fragment in _one_line_error(capsys, ["estimate", str(flight_csv), *extra])


def _parser_error(capsys, argv: list[str]) -> str:
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


@pytest.mark.parametrize(("argv", "fragment"), [
    (["estimate", "f.csv", "--method", "ebm-pso", "--seed", "-1"],
     "aeroid estimate: error: argument --seed: must be an integer >= 0, got -1"),
    (["estimate", "f.csv", "--method", "ebm-pso", "--seed", "1e3"], "invalid int value: '1e3'"),
    (["study", "--runs", "0"], "argument --runs: must be an integer >= 1, got 0"),
    (["study", "--jobs", "-2"], "argument --jobs: must be an integer in [1, 256], got -2"),
    (["study", "--dask-local", "100000"], "argument --dask-local: must be an integer in [1, 2"),
])
def test_numeric_arguments_out_of_range_exit_2(capsys, argv, fragment) -> None:
    assert fragment in _parser_error(capsys, argv)


def _help(capsys, argv: list[str]) -> str:
    with pytest.raises(SystemExit) as info:
        main([*argv, "--help"])
    assert info.value.code == 0
    return capsys.readouterr().out


def test_help_is_plain_text_with_descriptions_and_examples(capsys) -> None:
    top = _help(capsys, [])
    assert "``" not in top and "aeroid estimate flight.csv --method sebm-pso" in top
    for command in ("simulate", "estimate", "methods", "study"):
        text = _help(capsys, [command])
        assert "``" not in text
        assert "examples:\n  aeroid " + command in text
        description = text.split("\n\n")[1]
        assert len(description.split()) >= 10, (command, description)


def test_estimate_help_lists_every_method_and_how_to_see_options(capsys) -> None:
    text = _help(capsys, ["estimate"])
    assert "aeroid methods --options NAME" in text
    for name, cls in available().items():
        assert f"  {name}  " in text and cls.description.split()[0] in text


def test_methods_options_prints_types_defaults_and_descriptions(capsys) -> None:
    assert main(["methods", "--options", "sebm-pso"]) == 0
    out = capsys.readouterr().out
    assert "  n_particles : list of int = [50, 150, 100, 150]\n      Swarm sizes of" in out
    assert "  weighting : {noise, relative} = noise\n" in out
    assert "  box : list of float or none = none\n" in out
    for name in get_estimator("sebm-pso").option_names():
        assert f"\n  {name} : " in out
    assert "A method's options" not in out
    assert main(["methods"]) == 0
    assert "A method's options: aeroid methods --options NAME" in capsys.readouterr().out
    assert "unknown method 'nope'" in _one_line_error(capsys, ["methods", "--options", "nope"])


@pytest.mark.parametrize(("quiet", "json_output", "stderr_tty", "stdout_tty", "wanted"), [
    (False, False, True, True, True),
    (False, False, True, False, True),  # a table to a file, the bar on the terminal
    (False, True, True, True, True),
    (False, True, True, False, False),  # JSON to a pipe: a script is reading
    (True, False, True, True, False),  # --quiet
    (False, False, False, True, False),  # stderr not a terminal (a log file)
])
def test_progress_bar_only_where_a_person_watches(quiet, json_output, stderr_tty,
                                                 stdout_tty, wanted) -> None:
    from aeroid.cli._estimate import progress_wanted

    assert progress_wanted(quiet=quiet, json_output=json_output, stderr_tty=stderr_tty,
                           stdout_tty=stdout_tty) is wanted


def test_progress_bar_drawn_on_stderr_and_results_unchanged(flight_csv, capsys,
                                                           monkeypatch) -> None:
    from aeroid.cli import _estimate as commands

    args = ["estimate", str(flight_csv), "--method", "ebm-pso", "--seed", "2", "--json",
            "--option", "n_iterations=5"]
    assert main(args) == 0
    quiet = capsys.readouterr()
    assert quiet.err == ""  # stderr is not a terminal under pytest: no bar
    monkeypatch.setattr(commands, "progress_wanted", lambda **kwargs: True)
    assert main(args) == 0
    drawn = capsys.readouterr()
    assert "ebm-pso PSO" in drawn.err and "/5" in drawn.err
    assert json.loads(drawn.out)["coefficients"] == json.loads(quiet.out)["coefficients"]


def _scripted(monkeypatch, result=None, warn: str | None = None):
    """Make ``aeroid estimate`` use an estimator that warns and returns ``result``."""
    from dataclasses import dataclass
    from typing import ClassVar

    from aeroid.cli import _estimate as commands
    from aeroid.estimation import EstimationResult, Estimator

    @dataclass(frozen=True, kw_only=True)
    class Scripted(Estimator):
        name: ClassVar[str] = "scripted"

        def run(self, flight, rng):
            if warn:
                warnings.warn(warn, AeroidWarning, stacklevel=2)
            return result or EstimationResult(estimator=self.name, theta=np.ones(len(NAMES)))

    monkeypatch.setattr(commands, "make_estimator", lambda name, options: Scripted())


def test_estimate_prints_each_aeroid_warning_as_one_line(flight_csv, capsys,
                                                        monkeypatch) -> None:
    _scripted(monkeypatch, warn="flight.csv: q looks like deg/s\n(use --degrees)")
    assert main(["estimate", str(flight_csv), "--method", "scripted"]) == 0
    assert capsys.readouterr().err == (
        "aeroid: warning: flight.csv: q looks like deg/s (use --degrees)\n")


def test_estimate_says_compiled_or_interpreted(flight_csv, capsys, monkeypatch) -> None:
    from aeroid.estimation import EstimationResult

    _scripted(monkeypatch, EstimationResult(estimator="scripted", theta=np.ones(len(NAMES)),
                                            info={"compiled": False}))
    assert main(["estimate", str(flight_csv), "--method", "scripted"]) == 0
    assert "model evaluated interpreted" in capsys.readouterr().out
    assert main(["estimate", str(flight_csv), "--method", "scripted", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["compiled"] is False


def test_estimate_shows_result_warnings(flight_csv, capsys) -> None:
    """SEBM-PSO under the paper's noise ends on its box (test_paper_estimators)."""
    args = ["estimate", str(flight_csv), "--method", "sebm-pso", "--seed", "1"]
    assert main(args) == 0
    table = capsys.readouterr().out.splitlines()
    assert table[1].startswith("warning: FAZ: on the edge of the search box")
    assert main([*args, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert len(out["warnings"]) == 3 and out["warnings"][0] == table[1][len("warning: "):]


@pytest.mark.parametrize(("command", "expected"), [
    (["study"], "aeroid: interrupted; run the same command with --resume to complete only "
                "what is missing\n"),
    (["estimate", "f.csv", "--method", "ebm-pso"], "aeroid: interrupted\n"),
])
def test_interrupt_is_one_line_and_suggests_resume_for_a_study(capsys, monkeypatch, command,
                                                               expected) -> None:
    import aeroid.cli

    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(aeroid.cli, "_dispatch", interrupted)
    assert main(command) == 130
    assert capsys.readouterr().err == expected


def _write(tmp_path: Path, flight: Flight, name: str = "f.csv", sidecar: bool = True) -> Path:
    path = tmp_path / name
    flight.write(path)
    if not sidecar:
        path.with_suffix(".json").unlink()
    return path


def test_missing_file_exit_2(tmp_path, capsys) -> None:
    missing = tmp_path / "none.csv"
    err = _one_line_error(capsys, ["estimate", str(missing), "--method", "ebm-pso"])
    assert str(missing) in err and "no such file" in err


def test_unreadable_file_exit_2(tmp_path, capsys) -> None:
    bad = tmp_path / "bad.parquet"
    bad.write_bytes(b"\x00\x01 not parquet")
    err = _one_line_error(capsys, ["estimate", str(bad), "--method", "ebm-pso"])
    assert str(bad) in err and ("cannot read" in err or "pyarrow" in err)


def test_missing_airframe_file_exit_2(flight_csv, tmp_path, capsys) -> None:
    missing = tmp_path / "x.toml"
    err = _one_line_error(capsys, ["estimate", str(flight_csv), "--method", "ebm-pso",
                                   "--airframe", str(missing)])
    assert str(missing) in err


def test_nan_in_flight_exit_2_names_file_and_column(tmp_path, capsys, paper_flight) -> None:
    data = paper_flight.data.copy()
    data.loc[42, "q"] = np.nan
    path = _write(tmp_path, Flight(data, paper_flight.airframe, dict(paper_flight.metadata)))
    err = _one_line_error(capsys, ["estimate", str(path), "--method", "ebm-pso"])
    assert str(path) in err and "'q'" in err and "row 42" in err


def test_missing_column_exit_2(tmp_path, capsys, paper_flight) -> None:
    data = paper_flight.data.drop(columns=["az2"])
    path = _write(tmp_path, Flight(data, paper_flight.airframe, dict(paper_flight.metadata)))
    err = _one_line_error(capsys, ["estimate", str(path), "--method", "sebm-pso"])
    assert str(path) in err and "az2" in err


def test_log_without_sidecar_needs_airframe(tmp_path, capsys, paper_flight) -> None:
    path = _write(tmp_path, paper_flight, sidecar=False)
    err = _one_line_error(capsys, ["estimate", str(path), "--method", "ebm-pso"])
    assert str(path) in err and "--airframe" in err


def test_users_own_log_with_airframe_columns_and_degrees(tmp_path, capsys, paper_flight) -> None:
    """A sidecar-less log with its own column names and angles in degrees."""
    data = paper_flight.data.copy()
    for name in ("p", "q", "r", "delta", "alpha", "beta", "phi", "theta", "psi"):
        data[name] = np.degrees(data[name])
    data = data.rename(columns={"p": "roll_rate_dps", "az1": "acc_z_front"})
    path = tmp_path / "log.csv"
    data.to_csv(path, index=False, float_format="%.17g")
    airframe = tmp_path / "airframe.toml"
    save_airframe(paper_flight.airframe, airframe)
    columns = tmp_path / "columns.toml"
    columns.write_text('roll_rate_dps = "p"\nacc_z_front = "az1"\n')
    common = ["--method", "sebm-pso", "--seed", "3", "--json"]
    assert main(["estimate", str(path), "--airframe", str(airframe), "--columns",
                 str(columns), "--degrees", *common]) == 0
    from_log = json.loads(capsys.readouterr().out)
    reference = _write(tmp_path, paper_flight, "ref.csv")
    assert main(["estimate", str(reference), *common]) == 0
    direct = json.loads(capsys.readouterr().out)
    for name in NAMES:
        assert from_log["coefficients"][name] == pytest.approx(direct["coefficients"][name],
                                                               rel=DEGREES_RTOL)


# --------------------------------------------------------------------------------------
# Third-party estimators through the entry-point group (nothing is installed: a
# *.dist-info folder on PYTHONPATH is what importlib.metadata discovers).
# --------------------------------------------------------------------------------------
def _plugin_env(tmp_path: Path, entry_name: str) -> dict[str, str]:
    site = tmp_path / "site"
    info = site / "aeroid_test_plugin-0.1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: aeroid-test-plugin\n"
                                   "Version: 0.1.0\n")
    (info / "entry_points.txt").write_text(
        f"[aeroid.estimators]\n{entry_name} = aeroid_test_plugin:PriorMeanEstimator\n")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        [str(site), str(PLUGIN_DIR), *filter(None, [env.get("PYTHONPATH")])])
    return env


def test_plugin_found_by_methods_and_runs_through_estimate(tmp_path, flight_csv,
                                                          paper_flight) -> None:
    env = _plugin_env(tmp_path, "test-plugin-mean")
    listed = _run(["methods"], env)
    assert listed.returncode == 0, listed.stderr
    assert "test-plugin-mean" in listed.stdout
    assert "centre of the prior search box" in listed.stdout
    options = _run(["methods", "--options", "test-plugin-mean"], env)
    assert options.returncode == 0, options.stderr
    assert "\n  scale : float = 0.5\n      Half-width" in options.stdout
    assert ("Half-width of the box as a fraction of the prior (the box is prior x "
            "[1 - scale, 1 + scale]).") in " ".join(options.stdout.split())
    ran = _run(["estimate", str(flight_csv), "--method", "test-plugin-mean", "--json",
                "--option", "scale=0.2"], env)
    assert ran.returncode == 0, ran.stderr
    out = json.loads(ran.stdout)
    assert out["method"] == "test-plugin-mean"
    prior = paper_flight.airframe.prior_vector()
    np.testing.assert_allclose([out["coefficients"][n] for n in NAMES], prior, rtol=1e-12)


def test_plugin_with_a_builtin_name_is_an_error_naming_both(tmp_path) -> None:
    proc = _run(["methods"], _plugin_env(tmp_path, "sebm-pso"))
    assert proc.returncode == 2
    err = proc.stderr.strip()
    assert len(err.splitlines()) == 1, err
    assert "'sebm-pso' registered twice" in err
    assert "aeroid.estimation._sebm.SEBMPSO" in err
    assert "aeroid_test_plugin:PriorMeanEstimator" in err


def test_failed_fit_is_printed_and_exits_1(flight_csv, capsys, monkeypatch) -> None:
    """A method that fails (success=False) still prints its result, with exit status 1."""
    from dataclasses import dataclass
    from typing import ClassVar

    from aeroid.cli import _estimate as commands
    from aeroid.estimation import Estimator, failed_result

    @dataclass(frozen=True, kw_only=True)
    class AlwaysFails(Estimator):
        name: ClassVar[str] = "always-fails"

        def run(self, flight, rng):
            return failed_result(self.name, "singular system at t = 5.1 s")

    monkeypatch.setattr(commands, "make_estimator", lambda name, options: AlwaysFails())
    assert main(["estimate", str(flight_csv), "--method", "always-fails", "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert out["success"] is False
    assert out["message"] == "singular system at t = 5.1 s"


def test_first_compilations_are_announced(flight_csv, capsys, monkeypatch, tmp_path) -> None:
    """A fresh install compiles the C model: it is said in one line (numba's kernels:
    test_cli_compile_notice.py)."""
    from aeroid.model import _forward

    monkeypatch.setenv("AEROID_CASADI_CACHE", str(tmp_path / "casadi"))
    _forward._symbolic_record.cache_clear()  # built models are cached per process
    assert main(["estimate", str(flight_csv), "--method", "output-error", "--json"]) in (0, 1)
    err = capsys.readouterr().err
    assert "aeroid: compiling the C model (once: cached on disk for later runs)" in err
    assert re.search(r"^aeroid: compiled the C model in [0-9.]+ s$", err, re.MULTILINE)
    assert "compiling the model to C" not in err  # the old second line, said once now
    # quiet: nothing
    monkeypatch.setenv("AEROID_CASADI_CACHE", str(tmp_path / "again"))
    _forward._symbolic_record.cache_clear()
    main(["estimate", str(flight_csv), "--method", "output-error", "--json", "--quiet"])
    assert "compiling" not in capsys.readouterr().err


# --method all / a,b / --report -----------------------------------------------------------
#: The cheapest settings of every registered method that still run it end to end: the
#: PSO methods' iterations and the filters' passes (the other methods have no such knob).
CHEAP = ["--option", "n_iterations=3", "--option", "max_passes=1"]


def test_method_all_lists_every_registered_method(flight_csv, capsys) -> None:
    assert main(["estimate", str(flight_csv), "--method", "all", *CHEAP, "--json"]) in (0, 1)
    out = json.loads(capsys.readouterr().out)
    registered = set(available(refresh=True))
    assert {m["method"] for m in out["methods"]} == registered
    for method in out["methods"]:
        assert list(method["coefficients"]) == list(NAMES)
    applied = out["options_applied"]
    for name in registered:
        takes = set(get_estimator(name).option_names())
        assert set(applied[name]) == {"n_iterations", "max_passes"} & takes


def test_method_list_prints_one_side_by_side_table(flight_csv, capsys) -> None:
    code = main(["estimate", str(flight_csv), "--method", "equation-error,ekf,ebm-pso",
                 *CHEAP, "--seed", "1"])
    out = capsys.readouterr().out.splitlines()
    assert code in (0, 1)  # 1 when a method failed (a 3-iteration swarm may miss the fit)
    assert out[0].split() == ["truth", "equation-error", "ekf", "ebm-pso"]
    rows = {line.split()[0]: line for line in out[1:]}
    for name in NAMES:
        assert "±" in rows[name]  # estimate +- standard error where a method has one
    assert rows["success"].split()[:3] == ["success", "yes", "yes"]
    assert rows["success"].split()[3] == ("yes" if code == 0 else "FAILED")
    assert "option n_iterations: applied to ebm-pso; not an option of equation-error, ekf" \
        in out
    assert "option max_passes: applied to ekf; not an option of equation-error, ebm-pso" in out


@pytest.mark.parametrize(("method", "extra", "fragment"), [
    ("ekf,output-error", ["--option", "n_iterations=3"],
     "option(s) n_iterations taken by none of ekf, output-error"),
    ("ekf,ekf", [], "ekf given twice"),
    ("ekf,", [], "an empty method name"),
    ("ekf,nope", [], "nope"),
])
def test_bad_method_lists_exit_2(flight_csv, capsys, method, extra, fragment) -> None:
    err = _one_line_error(capsys, ["estimate", str(flight_csv), "--method", method, *extra])
    assert fragment in err


def test_report_of_one_method(flight_csv, tmp_path, capsys) -> None:
    out_dir = tmp_path / "fit"
    code = main(["estimate", str(flight_csv), "--method", "output-error", "--report",
                 str(out_dir), "--no-progress"])
    assert code == 0
    assert f"aeroid: wrote {out_dir / 'report.md'}" in capsys.readouterr().err
    text = (out_dir / "report.md").read_text()
    assert text.startswith(f"# output-error on {flight_csv}")
    for name in ("ax1", "p", "autocorrelation", "deflection", "correlation"):
        assert (out_dir / f"{name}.png").stat().st_size > 1000


def test_report_of_several_methods(flight_csv, tmp_path, capsys) -> None:
    code = main(["estimate", str(flight_csv), "--method", "equation-error,ebm-pso",
                 "--option", "n_iterations=3", "--report", str(tmp_path)])
    assert code == 0
    text = (tmp_path / "comparison.md").read_text()
    assert "|  | truth | equation-error | ebm-pso |" in text
    for method in ("equation-error", "ebm-pso"):
        assert f"[{method}: report]({method}/report.md)" in text
        assert (tmp_path / method / "report.md").is_file()
        assert (tmp_path / method / "q.png").is_file()


def test_html_report_of_several_methods(flight_csv, tmp_path, capsys) -> None:
    code = main(["estimate", str(flight_csv), "--method", "equation-error,ebm-pso",
                 "--option", "n_iterations=3", "--report", str(tmp_path),
                 "--report-format", "html"])
    assert code == 0
    assert f"aeroid: wrote {tmp_path / 'comparison.html'}" in capsys.readouterr().err
    page = (tmp_path / "comparison.html").read_text()
    assert page.startswith("<!DOCTYPE html>") and "<th>truth</th>" in page
    for method in ("equation-error", "ebm-pso"):
        assert f'<a href="{method}/report.html">{method}: report</a>' in page
        report = (tmp_path / method / "report.html").read_text()
        assert '<img src="q.png" alt="q [rad/s]: measured, model in still air and residual"' \
            in report  # the caption says the air (issue 26)
        assert not (tmp_path / method / "report.md").exists()


def test_report_format_without_report_exit_2(flight_csv, capsys) -> None:
    err = _one_line_error(capsys, ["estimate", str(flight_csv), "--method", "equation-error",
                                   "--report-format", "html"])
    assert "--report-format is the format of --report DIR" in err


def test_no_prior_is_said_after_the_fit(tmp_path, capsys, paper_flight) -> None:
    path = _write(tmp_path, paper_flight)
    assert paper_flight.airframe.prior is None
    assert main(["estimate", str(path), "--method", "equation-error"]) == 0
    err = capsys.readouterr().err
    assert err.count("the airframe has no [prior]: the reference missile's coefficients "
                     "were the start") == 1
    assert main(["estimate", str(path), "--method", "equation-error", "--quiet"]) == 0
    assert capsys.readouterr().err == ""


def test_json_carries_info(flight_csv, capsys) -> None:
    # max_passes=4: the paper flight's passes settle at pass 4; at 2 the passes' settle
    # verdict (baselines._kalman_verdict) rightly refuses the fit (Cmq moved 3.2 se)
    assert main(["estimate", str(flight_csv), "--method", "ekf", "--option", "max_passes=4",
                 "--json"]) == 0
    info = json.loads(capsys.readouterr().out)["info"]
    assert {"fit_check", "passes", "noise_law", "accel_positions_m", "options",
            "omitted"} <= set(info)


def test_unwritable_report_folder_exit_2(flight_csv, tmp_path, capsys) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    err = _one_line_error(capsys, ["estimate", str(flight_csv), "--method", "equation-error",
                                   "--report", str(blocker / "report")])
    assert str(blocker / "report") in err and "cannot create the report folder" in err


def test_no_progress_hides_the_bar_on_a_terminal(flight_csv, capsys, monkeypatch) -> None:
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    monkeypatch.setattr(sys.stdout, "isatty", lambda: True)
    args = ["estimate", str(flight_csv), "--method", "ebm-pso", "--option", "n_iterations=3"]
    assert main(args) == 0
    assert "ebm-pso PSO" in capsys.readouterr().err  # a terminal: the bar
    assert main([*args, "--no-progress"]) == 0
    assert "ebm-pso PSO" not in capsys.readouterr().err
