"""``Reconstruction.to_flight(aiding=True)`` passes the log's GNSS velocity and INS attitude
as logged."""

from __future__ import annotations

import numpy as np
import pytest

from aeroid.errors import FlightError
from aeroid.flights import SensorSuite, reference_scenario, simulate_suite
from aeroid.reconstruction import reconstruct


@pytest.fixture(scope="module")
def rec_and_log():
    scenario = reference_scenario()
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         SensorSuite(), rng=2)
    return reconstruct(sim.log), sim.log


def test_to_flight_passes_the_gnss_velocity_samples_as_logged(rec_and_log):
    rec, log = rec_and_log
    flight = rec.to_flight(imu="raw", aiding=True)
    gnss = flight.metadata["aiding"]["gnss"]
    inside = (log["gnss"].t >= flight.t[0]) & (log["gnss"].t <= flight.t[-1])
    np.testing.assert_array_equal(gnss["t"], log["gnss"].t[inside])
    for c in ("vn", "ve", "vd"):
        np.testing.assert_array_equal(gnss[c], log["gnss"].channels[c][inside])
        assert gnss["sd"][c] == log["gnss"].noise_sd[c]
    assert any(n.startswith("aiding: 11 GNSS velocity samples") for n in flight.metadata["notes"])
    assert "aiding_log" not in flight.metadata


def test_to_flight_passes_the_ins_attitude_samples_as_logged(rec_and_log):
    rec, log = rec_and_log
    flight = rec.to_flight(imu="raw", aiding=True)
    ins = flight.metadata["aiding"]["ins"]
    inside = (log["ins"].t >= flight.t[0]) & (log["ins"].t <= flight.t[-1])
    np.testing.assert_array_equal(ins["t"], log["ins"].t[inside])
    for c in ("phi", "theta", "psi"):
        np.testing.assert_array_equal(ins[c], log["ins"].channels[c][inside])  # wrapped
        assert ins["sd"][c] == log["ins"].noise_sd[c]
    assert np.max(np.abs(ins["phi"])) <= np.pi
    assert any(n.startswith(f"aiding: {int(inside.sum())} INS attitude samples")
               for n in flight.metadata["notes"])


def test_to_flight_without_aiding_carries_none(rec_and_log):
    rec, _ = rec_and_log
    for imu in ("raw", "corrected"):
        meta = rec.to_flight(imu=imu).metadata
        assert "aiding" not in meta and "aiding_log" not in meta


def test_aiding_without_gnss_velocity_is_one_line(rec_and_log):
    rec, _ = rec_and_log
    bare = type(rec)(**{**rec.__dict__, "metadata": {k: v for k, v in rec.metadata.items()
                                                     if k != "aiding_log"}})
    with pytest.raises(FlightError, match="needs GNSS velocity") as exc:
        bare.to_flight(imu="raw", aiding=True)
    assert "\n" not in str(exc.value)


def test_cli_aiding_flight_then_output_error_with_gnss(tmp_path, capsys):
    """``--aiding`` writes the samples into the sidecar; output-error reads them back."""
    import dataclasses
    import json

    from aeroid.cli import main
    from aeroid.flights import read_flight, write_suite_log

    scenario = reference_scenario()
    manoeuvre = dataclasses.replace(scenario.manoeuvre, window_s=(5.0, 5.5))
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, manoeuvre, rng=4)
    write_suite_log(sim.log, tmp_path / "suite.toml")
    out, flight = tmp_path / "states.csv", tmp_path / "raw.csv"
    assert main(["reconstruct", str(tmp_path / "suite.toml"), "-o", str(out), "--aiding"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--aiding" in err and "--flight" in err
    assert main(["reconstruct", str(tmp_path / "suite.toml"), "-o", str(out), "--flight",
                 str(flight), "--raw-imu", "--aiding"]) == 0
    capsys.readouterr()
    gnss = read_flight(flight).metadata["aiding"]["gnss"]
    np.testing.assert_allclose(gnss["vn"], sim.log["gnss"].channels["vn"], rtol=1e-15)
    status = main(["estimate", str(flight), "--method", "output-error", "--json",
                   "--option", "imu_errors=bias+scale",
                   "--option", "estimate_initial_velocity=true",
                   "--option", "aiding=gnss-velocity"])
    result = json.loads(capsys.readouterr().out)
    assert status == 0, result["message"]
    assert result["info"]["aiding"]["n_samples"] == 6  # 5.0, 5.1, ..., 5.5 s
    ins = read_flight(flight).metadata["aiding"]["ins"]  # the sidecar keeps the INS too
    np.testing.assert_allclose(ins["phi"], sim.log["ins"].channels["phi"], rtol=1e-15)
    status = main(["estimate", str(flight), "--method", "output-error", "--json",
                   "--option", "imu_errors=bias+scale",
                   "--option", "estimate_initial_velocity=true",
                   "--option", "aiding=gnss-velocity+ins-attitude"])
    result = json.loads(capsys.readouterr().out)
    assert status == 0, result["message"]
    assert result["info"]["aiding"]["sources"]["ins"]["n_samples"] == 51  # 100 Hz, 5-5.5 s
