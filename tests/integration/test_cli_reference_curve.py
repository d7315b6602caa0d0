"""``aeroid estimate --report DIR --reference-curve CD.csv --reference-area M2`` (issue 25).

References: the conversion ``Cd = -Cx * S_aeroid / S_ref`` computed here from the fit's
own JSON output (its Cx, its standard error) and the two areas from their diameters; the
flight's Mach range from the simulated speed and the ISA speed of sound at 10 km
(223.15 K). The figure's plotted data are read off the matplotlib artists the CLI drew.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pandas as pd
import pytest

import aeroid.report._reference_curve as reference_module
from aeroid.cli import main
from aeroid.model import TableSpec

D_REF = 0.13
S_REF = math.pi * D_REF**2 / 4
#: ISA speed of sound at the reference flight's 10 km [m/s].
SOUND_10KM = math.sqrt(1.4 * 287.05287 * 223.15)
#: The 95 % half-width in standard errors the figure draws (the tables' own).
Z95 = 1.96
#: Knots of the Cx table fitted in the table test; the flight flies Mach 1.68-1.69.
KNOTS = (1.6, 1.8)
CURVE = "Mach,Cd\n0.5,0.40\n1.0,0.55\n1.5,0.62\n2.0,0.58\n"


@pytest.fixture(scope="module")
def logs(tmp_path_factory, paper_flight):
    """The paper flight (with its prior, so no prior notice) as a constant-Cx log and as a
    log whose airframe takes Cx as a table in Mach; the curve file."""
    folder = tmp_path_factory.mktemp("refcurve")
    airframe = paper_flight.airframe.replace(prior=tuple(paper_flight.airframe.prior_vector()))
    constant = dataclasses.replace(paper_flight, airframe=airframe)
    constant.write(folder / "flight.csv")
    table = dataclasses.replace(paper_flight, airframe=airframe.replace(
        tables=TableSpec((("Cx", KNOTS),))))
    table.write(folder / "table.csv")
    (folder / "cd.csv").write_text(CURVE)
    return folder, paper_flight


@pytest.fixture
def drawn(monkeypatch):
    """The figures the CLI writes, kept (the artists hold the plotted data)."""
    figures = []
    write = reference_module.write_figure_atomic

    def keep(fig, path, dpi):
        figures.append(fig)
        return write(fig, path, dpi)

    monkeypatch.setattr(reference_module, "write_figure_atomic", keep)
    return figures


def _ratio(flight) -> float:
    return (math.pi * flight.airframe.diameter_m**2 / 4) / S_REF


def _estimate(capsys, log, folder, *extra) -> tuple[dict, str]:
    code = main(["estimate", str(log), "--method", "equation-error", "--json", "--report",
                 str(folder / "rep"), "--reference-curve", str(log.parent / "cd.csv"),
                 "--reference-area", repr(S_REF), *extra])
    out = capsys.readouterr()
    assert code == 0, out.err
    return json.loads(out.out), out.err


def test_constant_cx_is_drawn_converted_over_the_flights_mach_range(logs, tmp_path, capsys,
                                                                     drawn):
    folder, flight = logs
    fit, err = _estimate(capsys, folder / "flight.csv", tmp_path)
    cx, se = fit["coefficients"]["Cx"], fit["stderr"]["Cx"]
    ratio = _ratio(flight)
    speed = np.sqrt(flight["u"] ** 2 + flight["v"] ** 2 + flight["w"] ** 2)
    ends = [speed.min() / SOUND_10KM, speed.max() / SOUND_10KM]
    # the conversion said once, in one line, before the fit
    notes = [line for line in err.splitlines() if "Cd = -Cx x S_aeroid / S_ref" in line]
    assert len(notes) == 1 and "do not overlap" not in err
    # the data written beside the figure
    data = pd.read_csv(tmp_path / "rep" / "drag_vs_reference.csv")
    np.testing.assert_allclose(data["mach"], ends, rtol=1e-6)
    np.testing.assert_allclose(data["cd"], -cx * ratio, rtol=1e-9)
    np.testing.assert_allclose(data["cd_lo"], -(cx + Z95 * se) * ratio, rtol=1e-9)
    np.testing.assert_allclose(data["cd_hi"], -(cx - Z95 * se) * ratio, rtol=1e-9)
    # the figure: the curve as given, the fit's Cd as a line and its interval as a band
    (fig,) = drawn
    ax = fig.axes[0]
    lines = {line.get_label(): line for line in ax.get_lines()}
    np.testing.assert_array_equal(lines["cd.csv (Cd)"].get_ydata(), [0.40, 0.55, 0.62, 0.58])
    fitted = lines["equation-error, +- 1.96 se (95 %)"]
    np.testing.assert_allclose(fitted.get_xdata(), ends, rtol=1e-6)
    np.testing.assert_allclose(fitted.get_ydata(), -cx * ratio, rtol=1e-9)
    band = ax.collections[0].get_paths()[0].vertices[:, 1]
    assert band.min() == pytest.approx(-(cx + Z95 * se) * ratio, rel=1e-9)
    assert band.max() == pytest.approx(-(cx - Z95 * se) * ratio, rel=1e-9)
    png = (tmp_path / "rep" / "drag_vs_reference.png").read_bytes()
    assert png.startswith(b"\x89PNG")
    text = (tmp_path / "rep" / "report.md").read_text()
    assert "## Drag against a reference curve" in text
    assert "![drag against the reference curve](drag_vs_reference.png)" in text


def test_a_cx_table_is_drawn_as_its_points_with_their_intervals(logs, tmp_path, capsys,
                                                                drawn):
    folder, flight = logs
    fit, _ = _estimate(capsys, folder / "table.csv", tmp_path)
    names = [f"Cx@M{k:g}" for k in KNOTS]
    cx = np.array([fit["coefficients"][n] for n in names])
    se = np.array([fit["stderr"][n] for n in names])
    assert np.all(se > 0)
    ratio = _ratio(flight)
    (fig,) = drawn
    (bars,) = fig.axes[0].containers
    np.testing.assert_array_equal(bars.lines[0].get_xdata(), KNOTS)
    np.testing.assert_allclose(bars.lines[0].get_ydata(), -cx * ratio, rtol=1e-9)
    segments = bars.lines[2][0].get_segments()  # each point's [lo, hi], converted
    np.testing.assert_allclose([s[:, 1] for s in segments],
                               np.stack([-(cx + Z95 * se), -(cx - Z95 * se)], 1) * ratio,
                               rtol=1e-9)
    data = pd.read_csv(tmp_path / "rep" / "drag_vs_reference.csv")
    np.testing.assert_allclose(data["cd"], -cx * ratio, rtol=1e-9)
    rep = tmp_path / "rep"
    assert (rep / "tables.png").is_file() and (rep / "drag_vs_reference.png").is_file()
    text = (rep / "report.md").read_text()
    assert "coefficient tables in Mach" in text and "(drag_vs_reference.png)" in text


def test_curve_beyond_the_flights_mach_range_is_said_in_one_line(logs, tmp_path, capsys):
    folder, _ = logs
    (folder / "cd.csv").write_text("Mach,Cd\n0.2,0.45\n0.9,0.5\n")
    try:
        _, err = _estimate(capsys, folder / "flight.csv", tmp_path)
    finally:
        (folder / "cd.csv").write_text(CURVE)
    warned = [line for line in err.splitlines() if "do not overlap" in line]
    assert len(warned) == 1 and warned[0].startswith("aeroid: warning: reference curve cd.csv")
    assert "0.2 .. 0.9" in warned[0] and "1.68 .. 1.69" in warned[0]
    assert "do not overlap" in (tmp_path / "rep" / "report.md").read_text()


@pytest.mark.parametrize(("extra", "curve", "fragment"), [
    (["--report", "R", "--reference-curve", "CURVE"], CURVE,
     "state the curve's reference area with --reference-area"),
    (["--reference-curve", "CURVE", "--reference-area", "0.0129"], CURVE,
     "--reference-curve draws into the report folder: give --report DIR"),
    (["--report", "R", "--reference-area", "0.0129"], CURVE,
     "--reference-area is the area of --reference-curve"),
    (["--report", "R", "--reference-curve", "CURVE", "--reference-area", "0"], CURVE,
     "the reference area must be a positive number"),
    (["--report", "R", "--reference-curve", "CURVE", "--reference-area", "nan"], CURVE,
     "the reference area must be a positive number"),
    (["--report", "R", "--reference-curve", "CURVE", "--reference-area", "0.0129"],
     "Mach,Drag\n0.5,0.4\n", "missing: cd; not used: Drag"),
    (["--report", "R", "--reference-curve", "CURVE", "--reference-area", "0.0129",
      "--windows", "5-5.4,5.5-6"], CURVE, "--reference-curve takes one log of one window"),
])
def test_refusals_are_one_line(logs, tmp_path, capsys, extra, curve, fragment):
    folder, _ = logs
    path = tmp_path / "curve.csv"
    path.write_text(curve)
    extra = [str(path) if a == "CURVE" else str(tmp_path / "rep") if a == "R" else a
             for a in extra]
    assert main(["estimate", str(folder / "flight.csv"), "--method", "equation-error",
                 *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("aeroid: error: ") and fragment in err
    assert not (tmp_path / "rep" / "drag_vs_reference.png").exists()


def _scripted(monkeypatch, result):
    """Make ``aeroid estimate`` use an estimator that returns ``result``."""
    from dataclasses import dataclass
    from typing import ClassVar

    from aeroid.cli import _estimate as commands
    from aeroid.estimation import Estimator

    @dataclass(frozen=True, kw_only=True)
    class Scripted(Estimator):
        name: ClassVar[str] = "scripted"

        def run(self, flight, rng):
            return result

    monkeypatch.setattr(commands, "make_estimator", lambda name, options: Scripted())


def test_a_held_cx_is_drawn_without_an_interval(logs, tmp_path, capsys, monkeypatch, drawn):
    from aeroid.estimation import EstimationResult
    from aeroid.model import NAMES

    folder, flight = logs
    names = tuple(NAMES)
    theta = np.array(flight.airframe.prior_vector(), dtype=float)
    theta[names.index("Cx")] = -0.9
    stderr = np.full(len(names), 0.01)
    stderr[names.index("Cx")] = np.nan
    _scripted(monkeypatch, EstimationResult(estimator="scripted", names=names, theta=theta,
                                            stderr=stderr, held={"Cx": -0.9}))
    assert main(["estimate", str(folder / "flight.csv"), "--method", "scripted", "--report",
                 str(tmp_path / "rep"), "--reference-curve", str(folder / "cd.csv"),
                 "--reference-area", repr(S_REF)]) == 0
    capsys.readouterr()
    data = pd.read_csv(tmp_path / "rep" / "drag_vs_reference.csv")
    expected = 0.9 * _ratio(flight)
    for column in ("cd", "cd_lo", "cd_hi"):
        np.testing.assert_allclose(data[column], expected, rtol=1e-9)
    (fig,) = drawn
    (line,) = [ln for ln in fig.axes[0].get_lines() if "held: no interval" in ln.get_label()]
    np.testing.assert_allclose(line.get_ydata(), expected, rtol=1e-9)


def test_a_failed_fit_keeps_its_report_and_says_there_is_no_figure(logs, tmp_path, capsys,
                                                                   monkeypatch):
    from aeroid.estimation import failed_result

    folder, _ = logs
    _scripted(monkeypatch, failed_result("scripted", "singular system at t = 5.1 s"))
    assert main(["estimate", str(folder / "flight.csv"), "--method", "scripted", "--report",
                 str(tmp_path / "rep"), "--reference-curve", str(folder / "cd.csv"),
                 "--reference-area", repr(S_REF)]) == 1
    capsys.readouterr()
    text = (tmp_path / "rep" / "report.md").read_text()
    assert "- no figure: reference curve: the scripted fit has no finite Cx to draw" in text
    assert not (tmp_path / "rep" / "drag_vs_reference.png").exists()


def test_several_methods_each_get_the_figure_and_the_note_is_said_once(logs, tmp_path,
                                                                      capsys):
    folder, _ = logs
    code = main(["estimate", str(folder / "flight.csv"), "--method", "equation-error,ebm-pso",
                 "--option", "n_iterations=3", "--seed", "0", "--report", str(tmp_path),
                 "--reference-curve", str(folder / "cd.csv"), "--reference-area", repr(S_REF)])
    assert code in (0, 1)
    err = capsys.readouterr().err
    assert err.count("Cd = -Cx x S_aeroid / S_ref") == 1
    for method in ("equation-error", "ebm-pso"):
        assert (tmp_path / method / "drag_vs_reference.png").is_file()
        assert "(drag_vs_reference.png)" in (tmp_path / method / "report.md").read_text()


def test_a_flight_without_a_speed_of_sound_is_refused_before_the_fit(logs, tmp_path, capsys):
    folder, flight = logs
    dense = dataclasses.replace(flight, airframe=flight.airframe.replace(
        altitude_m=None, given_density_kgm3=0.41))
    dense.write(tmp_path / "dense.csv")
    assert main(["estimate", str(tmp_path / "dense.csv"), "--method", "equation-error",
                 "--report", str(tmp_path / "rep"), "--reference-curve",
                 str(folder / "cd.csv"), "--reference-area", repr(S_REF)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("aeroid: error: Mach of the flight: its atmosphere is a density")
    assert len(err) == 1  # nothing said before: no conversion note, no fit
