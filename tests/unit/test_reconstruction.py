"""Flight-path reconstruction (aeroid.reconstruction) and ``aeroid reconstruct``."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pandas as pd
import pytest

from aeroid.cli import main
from aeroid.errors import FlightError
from aeroid.flights import (
    SensorGroup,
    SensorSuite,
    SuiteLog,
    exogenous,
    read_flight,
    read_suite_log,
    reference_scenario,
    simulate_suite,
    wrap_angle,
    write_suite_log,
)
from aeroid.model import EXOGENOUS, G0
from aeroid.reconstruction import IMU_CHANNELS, STATES, reconstruct

#: Fraction of samples whose error must lie within 3 sd (a Gaussian gives 99.7%; the
#: errors are correlated in time, so a few runs of samples may leave; seeds 1-2 on the
#: reference flight: 100%).
WITHIN_3SD = 0.97


@pytest.fixture(scope="module")
def reference():
    """The reference flight's window (5-6 s) through the default suite, reconstructed."""
    scenario = reference_scenario()
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         rng=np.random.default_rng(11))
    return sim, reconstruct(sim.log)


def _z(rec, truth, name):
    err = rec.table[name].to_numpy() - truth[name]
    if name in ("phi", "psi"):
        err = wrap_angle(err)
    return err / rec.table[f"sd_{name}"].to_numpy()


def test_states_within_3_sd(reference):
    sim, rec = reference
    assert len(rec.table) == len(sim.log["imu"].t)  # at the IMU's rate
    for name in ("u", "v", "w", "phi", "theta", "psi", "pn", "pe", "pd"):
        z = _z(rec, sim.truth, name)
        assert np.mean(np.abs(z) < 3.0) >= WITHIN_3SD, name
    # and the sd are informative, not inflated: attitude to a fraction of the INS's 3 mrad
    assert rec.table[["sd_phi", "sd_theta", "sd_psi"]].to_numpy().max() < 0.003
    assert rec.table[["sd_u", "sd_v", "sd_w"]].to_numpy().max() < 0.5
    np.testing.assert_allclose(rec.table["altitude"], 10000.0 - sim.truth["pd"], atol=3.0)


def test_instrument_errors_within_3_sd(reference):
    sim, rec = reference
    e = sim.errors
    truth = dict(zip(STATES[10:], np.concatenate(
        [e["accel_bias"].ravel(), e["gyro_bias"], e["accel_scale"].ravel(), e["gyro_scale"]]),
        strict=True))
    first = rec.table.iloc[0]
    for name, value in truth.items():
        assert abs(first[name] - value) < 3.0 * first[f"sd_{name}"], name
    # the roll gyro's scale factor is what the 50 rad/s roll makes observable: its sd falls
    # from the prior's 0.005 to below 2e-4, so the 3-sd check above bites there
    assert first["sd_sp"] < 2e-4
    # the corrected roll rate is then good to 0.02 rad/s at 50 rad/s
    assert np.max(np.abs(rec.table["p"] - sim.truth["p"])) < 0.02
    # the two triads' mean axial bias is informed too (sd 0.087 from the prior's 0.14)
    i, j = STATES.index("bax1"), STATES.index("bax2")
    cov = rec.covariance[0]
    sd_mean = 0.5 * math.sqrt(cov[i, i] + cov[j, j] + 2 * cov[i, j])
    assert sd_mean < 0.7 * 0.2 / math.sqrt(2)
    error = 0.5 * (first["bax1"] + first["bax2"]) - e["accel_bias"][:, 0].mean()
    assert abs(error) < 3 * sd_mean


def test_residual_check(reference):
    sim, rec = reference
    for source in ("gnss", "baro", "ins"):
        check = rec.nis[source]
        assert check["consistent"], (source, check)
        # the interval is chi-square's: for the 300 INS values about 0.77-1.26
        low, high = check["interval"]
        assert low < 1.0 < high and high - low < 2.5
    # the first sample of each source set the prior and is not used again
    assert rec.nis["ins"]["n_updates"] == 100 and rec.nis["gnss"]["n_values"] == 60


def test_residual_check_flags_a_wrong_noise_level(reference):
    """An INS whose stated sd is 5x too small: its mean NIS is far above 1."""
    sim, _ = reference
    ins = sim.log["ins"]
    wrong = dataclasses.replace(ins, noise_sd={c: s / 5 for c, s in ins.noise_sd.items()})
    log = dataclasses.replace(sim.log, groups={**sim.log.groups, "ins": wrong})
    check = reconstruct(log).nis["ins"]
    assert check["mean_nis_per_dof"] > 5.0 and not check["consistent"]


def test_to_flight_and_density(reference):
    sim, rec = reference
    flight = rec.to_flight()
    assert flight.airframe == sim.log.airframe
    np.testing.assert_array_equal(flight["delta"], sim.log["fin"].channels["delta"])
    per_sample = rec.to_flight(atmosphere="altitude")
    assert per_sample.airframe.atmosphere_channel == "altitude"
    rho = exogenous(per_sample)[:, EXOGENOUS.index("rho")]
    # ISA density of one sample's altitude through the airframe's own (independent) path
    k = 500
    expected = sim.log.airframe.replace(altitude_m=float(rec.table["altitude"][k])).density_kgm3
    assert rho[k] == pytest.approx(expected, rel=1e-12)
    np.testing.assert_allclose(rec.table["rho"], rho)
    with pytest.raises(FlightError, match="atmosphere must be"):
        rec.to_flight(atmosphere="moon")


# A closed form: a constant-rate roll about a level, constant velocity ---------------------
ROLL_RATE = 30.0  # rad/s
SPEED = 300.0  # m/s
GYRO_BIAS = 0.004  # rad/s, on p
GYRO_SCALE = 0.003


def _roll_log(rng: np.random.Generator, ins_sd: float = 0.002) -> SuiteLog:
    """A hand-made log: u = SPEED, v = w = 0, phi = ROLL_RATE t, theta = psi = 0.

    The specific force at a triad at r is ``-g_body + w x (w x r)`` with ``g_body = g (0,
    sin phi, cos phi)`` and ``w x (w x r) = -p^2 (0, r_y, r_z)``; the gyro reads ``(1 +
    GYRO_SCALE) p + GYRO_BIAS``. The INS samples (roll wrapped) fall off the IMU's grid.
    """
    scenario = reference_scenario()
    positions = scenario.airframe.accel_positions
    t = np.arange(0.0, 1.0 + 1e-9, 1e-3)
    phi = ROLL_RATE * t
    channels = {}
    for i, r in enumerate(positions, start=1):
        channels[f"ax{i}"] = np.zeros_like(t)
        channels[f"ay{i}"] = -G0 * np.sin(phi) - ROLL_RATE ** 2 * r[1]
        channels[f"az{i}"] = -G0 * np.cos(phi) - ROLL_RATE ** 2 * r[2]
    channels["p"] = np.full_like(t, (1 + GYRO_SCALE) * ROLL_RATE + GYRO_BIAS)
    channels["q"] = np.zeros_like(t)
    channels["r"] = np.zeros_like(t)
    noise = {c: 0.02 if c[0] == "a" else 0.001 for c in channels}
    channels = {c: v + noise[c] * rng.standard_normal(len(t)) for c, v in channels.items()}
    ti = np.arange(0.0037, 1.0, 0.01)
    ins = {"phi": wrap_angle(ROLL_RATE * ti + ins_sd * rng.standard_normal(len(ti))),
           "theta": ins_sd * rng.standard_normal(len(ti)),
           "psi": ins_sd * rng.standard_normal(len(ti))}
    groups = {"imu": SensorGroup("imu", t, channels, noise),
              "ins": SensorGroup("ins", ti, ins, dict.fromkeys(ins, ins_sd))}
    return SuiteLog(groups, scenario.airframe, {}, "roll log")


def test_constant_rate_roll_closed_form():
    rec = reconstruct(_roll_log(np.random.default_rng(3)), initial_velocity=(SPEED, 0, 0))
    tab = rec.table
    t = tab["t"].to_numpy()
    err_phi = wrap_angle(tab["phi"].to_numpy() - ROLL_RATE * t)
    assert np.mean(np.abs(err_phi) < 3 * tab["sd_phi"]) >= WITHIN_3SD
    assert np.max(np.abs(err_phi)) < 0.005
    # no aiding of velocity: it stays what the closed form says within its sd
    for name, value in (("u", SPEED), ("v", 0.0), ("w", 0.0)):
        z = (tab[name] - value) / tab[f"sd_{name}"]
        assert np.mean(np.abs(z) < 3.0) >= WITHIN_3SD, name
    # pn = SPEED t (the origin at the first sample), pe = pd = 0 only through gravity's
    # sd-sized drift: checked within 3 sd too
    z = (tab["pn"] - SPEED * t) / tab["sd_pn"]
    assert np.mean(np.abs(z) < 3.0) >= WITHIN_3SD
    # a constant roll rate cannot tell the gyro's bias from its scale factor: their
    # combination, the corrected rate, is what the INS fixes
    assert np.abs(tab["p"] - ROLL_RATE).mean() < 0.01
    assert rec.nis["ins"]["n_updates"] == 99  # the first set the prior
    assert rec.nis["ins"]["consistent"]
    assert "no gnss group: not used" in rec.notes


def test_needs_an_initial_state():
    log = _roll_log(np.random.default_rng(0))
    with pytest.raises(FlightError, match="no GNSS velocity: give initial_velocity"):
        reconstruct(log)
    no_ins = dataclasses.replace(log, groups={"imu": log["imu"]})
    with pytest.raises(FlightError, match="no INS attitude: give initial_attitude"):
        reconstruct(no_ins, initial_velocity=(SPEED, 0, 0))
    imu = log["imu"]
    partial = dataclasses.replace(imu, noise_sd={k: v for k, v in imu.noise_sd.items()
                                                 if k != "q"})
    with pytest.raises(FlightError, match="no noise_sd for q"):
        reconstruct(dataclasses.replace(log, groups={**log.groups, "imu": partial}),
                    initial_velocity=(SPEED, 0, 0))


def test_cli_help(capsys):
    with pytest.raises(SystemExit) as info:
        main(["reconstruct", "--help"])
    assert info.value.code == 0
    assert "examples:\n  aeroid reconstruct" in capsys.readouterr().out


def test_cli_reconstruct(tmp_path, capsys):
    scenario = reference_scenario()
    manoeuvre = dataclasses.replace(scenario.manoeuvre, window_s=(5.0, 5.3))
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, manoeuvre, rng=4)
    write_suite_log(sim.log, tmp_path / "suite.toml")
    out, flight = tmp_path / "states.csv", tmp_path / "flight.csv"
    status = main(["reconstruct", str(tmp_path / "suite.toml"), "-o", str(out),
                   "--flight", str(flight)])
    assert status == 0
    text = capsys.readouterr().out
    assert "ins: mean NIS per dof" in text
    table = pd.read_csv(out)
    assert len(table) == 301 and {"u", "sd_u", "bp", "sd_bp", "rho"} <= set(table.columns)
    assert flight.exists()
    # a bad log: one line on stderr, status 2
    (tmp_path / "suite-ins.csv").write_text("t,phi,theta,psi\n0,1,2,3\n0,1,2,3\n")
    assert main(["reconstruct", str(tmp_path / "suite.toml"), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "suite-ins.csv" in err and "not strictly" in err
    assert math.isfinite(table["rho"].iloc[0])


def test_time_offset_between_groups(tmp_path):
    """An INS logged 2 ms late: its offset_s puts it right; left out, the roll is 0.1 rad off.

    At a 50 rad/s roll a 2 ms skew is a 0.1 rad roll error, 30 times the INS's sd. The
    residual check cannot see it: the INS is the only reference of the roll angle, and a
    constant roll error's effect on the NED velocity averages out over each turn (the
    check stays consistent). A wrong skew must be found by an estimator, not here.
    """
    scenario = reference_scenario()
    manoeuvre = dataclasses.replace(scenario.manoeuvre, window_s=(5.0, 5.4))
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, manoeuvre, rng=9,
                         suite=SensorSuite(offsets_s=(("ins", 0.002),)))
    path = tmp_path / "suite.toml"
    write_suite_log(sim.log, path)
    right = reconstruct(read_suite_log(path))
    assert np.all(np.abs(_z(right, sim.truth, "phi")) < 3.0)
    path.write_text(path.read_text().replace("offset_s = 0.002", "offset_s = 0.0"))
    wrong = reconstruct(read_suite_log(path))
    error = wrap_angle(wrong.table["phi"].to_numpy() - sim.truth["phi"])
    roll_rate = sim.truth["p"].mean()
    np.testing.assert_allclose(error.mean(), roll_rate * 0.002, rtol=0.1)
    assert wrong.nis["ins"]["consistent"]  # what the check cannot see (docstring)


def test_refuses_uneven_imu_sampling():
    log = _roll_log(np.random.default_rng(0))
    imu = log["imu"]
    t = imu.t.copy()
    t[500:] += 0.004  # a 4 ms gap
    gap = dataclasses.replace(log, groups={**log.groups, "imu": dataclasses.replace(imu, t=t)})
    with pytest.raises(FlightError, match="IMU sampling not uniform: 0.005 s after t = 0.499"):
        reconstruct(gap, initial_velocity=(SPEED, 0, 0))


def test_to_flight_raw_imu(reference):
    """``imu="raw"``: the log's readings as they are, the reconstructed states beside them."""
    sim, rec = reference
    raw, corrected = rec.to_flight(imu="raw"), rec.to_flight()
    for c in IMU_CHANNELS:
        np.testing.assert_array_equal(raw[c], sim.log["imu"].channels[c])
    for c in ("u", "v", "w", "phi", "theta", "psi", "delta"):
        np.testing.assert_array_equal(raw[c], corrected[c])
    # the identity that ties them: raw = (1 + s) corrected + b with the table's s and b
    for c in IMU_CHANNELS:
        expected = (1.0 + rec.table[f"s{c}"]) * corrected[c] + rec.table[f"b{c}"]
        np.testing.assert_allclose(raw[c], expected, rtol=1e-12, atol=1e-12)
    assert any(n.startswith("IMU: raw readings") for n in raw.metadata["notes"])
    first_sd = raw.metadata["initial_state_sd"]  # output-error's initial_velocity_prior
    assert list(first_sd) == ["u", "v", "w", "phi", "theta", "psi"]
    assert first_sd["v"] == rec.table["sd_v"].iloc[0] > 0
    with pytest.raises(FlightError, match="imu must be 'corrected' or 'raw'"):
        rec.to_flight(imu="moon")
    with pytest.raises(FlightError, match="holds no raw IMU readings"):
        dataclasses.replace(rec, raw_imu=None).to_flight(imu="raw")


def test_cli_raw_imu_flight_then_output_error(tmp_path, capsys):
    """``--raw-imu`` writes the log's readings; output-error then fits their errors."""
    scenario = reference_scenario()
    manoeuvre = dataclasses.replace(scenario.manoeuvre, window_s=(5.0, 5.5))
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, manoeuvre, rng=4)
    write_suite_log(sim.log, tmp_path / "suite.toml")
    out, flight = tmp_path / "states.csv", tmp_path / "raw.csv"
    assert main(["reconstruct", str(tmp_path / "suite.toml"), "-o", str(out),
                 "--raw-imu"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--raw-imu" in err and "--flight" in err
    assert main(["reconstruct", str(tmp_path / "suite.toml"), "-o", str(out),
                 "--flight", str(flight), "--raw-imu"]) == 0
    assert "IMU: raw" in capsys.readouterr().out
    written = read_flight(flight)
    for c in IMU_CHANNELS:
        np.testing.assert_array_equal(written[c], sim.log["imu"].channels[c])
    status = main(["estimate", str(flight), "--method", "output-error", "--json",
                   "--option", "imu_errors=bias+scale",
                   "--option", "estimate_initial_velocity=true",
                   "--option", "initial_velocity_prior=flight"])  # its sd from the sidecar
    result = json.loads(capsys.readouterr().out)
    assert status == 0, result["message"]
    truth = dict(zip([f"b{c}" for c in IMU_CHANNELS], np.concatenate(
        [sim.errors["accel_bias"].ravel(), sim.errors["gyro_bias"]]), strict=True))
    fitted, sd = result["info"]["imu_errors"], result["info"]["imu_error_stderr"]
    for name, value in truth.items():
        assert abs(fitted[name] - value) < 3.0 * sd[name], name
