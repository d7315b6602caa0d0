"""The reconstruction's report: ``aeroid reconstruct ... --report DIR`` (aeroid.report)."""

from __future__ import annotations

import numpy as np
import pytest

from aeroid.cli import main
from aeroid.flights import SI_UNITS, reference_scenario, simulate_suite, write_suite_log
from aeroid.reconstruction import reconstruct
from aeroid.report import (
    RECONSTRUCTION_REPORT,
    reconstruction_figures,
    write_reconstruction_report,
)

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
SOURCES = ("gnss", "baro", "ins")


@pytest.fixture(scope="module")
def suite():
    scenario = reference_scenario()
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         rng=np.random.default_rng(11))
    return sim, reconstruct(sim.log)


def test_innovation_tables_are_the_filters(suite):
    """In the channels' units; over their sd they are the normalised innovations, at the
    measurements' own times (the first INS and GNSS samples set the prior: not used)."""
    sim, rec = suite
    assert set(rec.innovation_tables) == set(SOURCES)
    for source in SOURCES:
        table = rec.innovation_tables[source]
        channels = [c for c in table.columns if c != "t" and not c.startswith("sd_")]
        assert channels == [c for c in sim.log[source].channels]
        ratio = table[channels].to_numpy() / table[[f"sd_{c}" for c in channels]].to_numpy()
        np.testing.assert_allclose(ratio, rec.innovations[source], rtol=1e-12)
        np.testing.assert_allclose(table["t"], sim.log[source].t[1:], rtol=0, atol=1e-12)
        assert np.all(np.isfinite(table.to_numpy()))
    # one channel: S is its variance, so the mean squared ratio is the NIS per dof (with
    # several channels the NIS also weighs their correlations)
    baro = rec.innovation_tables["baro"]
    assert np.mean((baro["altitude"] / baro["sd_altitude"]) ** 2) == pytest.approx(
        rec.nis["baro"]["mean_nis_per_dof"], rel=1e-9)


def test_each_figure_names_its_channel_and_unit(suite):
    sim, rec = suite
    figures = reconstruction_figures(rec)
    assert set(figures) == {"innovations_gnss", "innovations_baro", "innovations_ins",
                            "states_velocity", "states_attitude", "states_position",
                            "instrument_errors"}
    for source in SOURCES:
        labels = [ax.get_ylabel() for ax in figures[f"innovations_{source}"].axes]
        assert labels == [f"{c} [{SI_UNITS[c]}]" for c in sim.log[source].channels]
        titles = [ax.get_title() for ax in figures[f"innovations_{source}"].axes]
        assert all(f"{source} {c} innovation [{SI_UNITS[c]}]" in title
                   for c, title in zip(sim.log[source].channels, titles, strict=True))
    velocity = [ax.get_ylabel() for ax in figures["states_velocity"].axes]
    assert velocity == ["u [m/s]", "sd u [m/s]", "v [m/s]", "sd v [m/s]", "w [m/s]",
                        "sd w [m/s]"]
    attitude = [ax.get_ylabel() for ax in figures["states_attitude"].axes]
    assert attitude[::2] == ["phi [rad]", "theta [rad]", "psi [rad]"]
    errors = figures["instrument_errors"].axes
    assert [ax.get_ylabel() for ax in errors] == [
        "accelerometer biases [m/s^2]", "gyro biases [rad/s]", "scale factors [-]"]
    assert [t.get_text() for t in errors[1].get_xticklabels()] == ["bp", "bq", "br"]


def test_report_files(tmp_path, suite):
    _, rec = suite
    path = write_reconstruction_report(rec, tmp_path / "report")
    assert path == tmp_path / "report" / RECONSTRUCTION_REPORT
    text = path.read_text()
    pngs = sorted(p.name for p in path.parent.glob("*.png"))
    assert len(pngs) == 7
    for png in pngs:
        assert f"]({png})" in text
        assert (path.parent / png).read_bytes()[:8] == PNG_MAGIC
    for source in SOURCES:
        mean = rec.nis[source]["mean_nis_per_dof"]
        assert f"| {source} | {mean:.3f} |" in text
    assert "| bp |" in text and "| rad/s |" in text
    assert not list(path.parent.glob("*.tmp"))


def test_cli_report(tmp_path, suite, capsys):
    sim, _ = suite
    write_suite_log(sim.log, tmp_path / "suite.toml")
    code = main(["reconstruct", str(tmp_path / "suite.toml"), "-o", str(tmp_path / "s.csv"),
                 "--report", str(tmp_path / "rep")])
    assert code == 0
    assert (tmp_path / "rep" / RECONSTRUCTION_REPORT).is_file()
    assert len(list((tmp_path / "rep").glob("*.png"))) == 7
    assert "reconstruction.md and its figures" in capsys.readouterr().out


def test_cli_report_folder_unwritable(tmp_path, suite, capsys):
    sim, _ = suite
    write_suite_log(sim.log, tmp_path / "suite.toml")
    (tmp_path / "afile").write_text("x")
    code = main(["reconstruct", str(tmp_path / "suite.toml"), "-o", str(tmp_path / "s.csv"),
                 "--report", str(tmp_path / "afile")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "afile" in err and "\n" not in err
    assert not (tmp_path / "s.csv").exists()  # said before the filter ran
