"""Barometer pressure and temperature: the ISA, the suite log's units, the reconstruction."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from aeroid.cli import main
from aeroid.errors import AirframeError, FlightError
from aeroid.flights import (
    SensorSuite,
    exogenous,
    read_flight,
    read_suite_log,
    reference_scenario,
    simulate_suite,
    write_suite_log,
)
from aeroid.model import (
    EXOGENOUS,
    G0,
    H_TROPOPAUSE,
    P0,
    R_AIR,
    T0,
    TableSpec,
    density,
    isa_pressure,
    isa_temperature,
    pressure_altitude,
)
from aeroid.reconstruction import reconstruct

#: ISA table values (U.S. Standard Atmosphere 1976, rounded as printed): 11 km 22632.06 Pa
#: 216.65 K 0.36392 kg/m^3; 20 km 5474.89 Pa; sea level 1.2250 kg/m^3. The table's R* / M
#: (287.0531 J/(kg K)) is 8.1e-7 above aeroid's 287.05287, which moves ln p by 1.5x that
#: at 11 km and 2.9x at 20 km (d ln p / d ln R): 1.2e-6 and 2.3e-6 (measured 0.9e-6 and
#: 2.3e-6 with the table's rounding).
TABLE_RTOL = 3e-6
DENSITY_RTOL = 2e-5  # the table's 5 significant digits
#: 1 psi [Pa] and 1 atm [psi] (NIST SP 811).
PSI_PA = 6894.757293168361
ATM_PSI = 14.695948775513


def test_isa_table_values():
    assert float(isa_pressure(11000.0)) == pytest.approx(22632.06, rel=TABLE_RTOL)
    assert float(isa_temperature(11000.0)) == pytest.approx(216.65, rel=1e-12)
    assert float(density(11000.0)) == pytest.approx(0.36392, rel=DENSITY_RTOL)
    assert float(isa_pressure(20000.0)) == pytest.approx(5474.89, rel=TABLE_RTOL)
    assert float(density(0.0)) == pytest.approx(1.2250, rel=DENSITY_RTOL)
    assert (float(isa_pressure(0.0)), float(isa_temperature(0.0))) == (P0, T0)
    assert H_TROPOPAUSE == 11000.0


def test_pressure_altitude_inverts_pressure():
    h = np.array([0.0, 1234.5, 2500.0, 10999.0, 11000.0, 11001.0, 15000.0, 20000.0])
    np.testing.assert_allclose(pressure_altitude(isa_pressure(h)), h, rtol=0, atol=1e-8)


def test_hydrostatic_identity_through_the_complex_step():
    """dp/dh = -g p / (R T) on both sides of the tropopause (the barometer's Jacobian)."""
    h = np.array([500.0, 2500.0, 9000.0, 13000.0])
    step = 1e-30
    slope = isa_pressure(h + 1j * step).imag / step
    np.testing.assert_allclose(slope, -G0 * isa_pressure(h) / (R_AIR * isa_temperature(h)),
                               rtol=1e-13)


def _baro_log(folder, pressure_unit, temperature_unit, pressure, temperature):
    (folder / "baro.csv").write_text(
        "t,p,T\n" + "".join(f"{k * 0.02},{pressure[k]!r},{temperature[k]!r}\n"
                            for k in range(len(pressure))))
    (folder / "log.toml").write_text(f"""
[groups.baro]
file = "baro.csv"
time = ["t", "s"]
[groups.baro.columns]
pressure = ["p", "{pressure_unit}"]
temperature = ["T", "{temperature_unit}"]
""")
    return read_suite_log(folder / "log.toml")


@pytest.mark.parametrize(("pressure_unit", "temperature_unit", "pressure", "temperature"), [
    ("Pa", "K", [101325.0, 22632.06], [288.15, 216.65]),
    ("hPa", "degC", [1013.25, 226.3206], [15.0, -56.5]),
    ("mbar", "degC", [1013.25, 226.3206], [15.0, -56.5]),
    ("psi", "K", [ATM_PSI, 22632.06 / PSI_PA], [288.15, 216.65]),
])
def test_units_converted(tmp_path, pressure_unit, temperature_unit, pressure, temperature):
    baro = _baro_log(tmp_path, pressure_unit, temperature_unit, pressure, temperature)["baro"]
    np.testing.assert_allclose(baro.channels["pressure"], [101325.0, 22632.06], rtol=1e-12)
    np.testing.assert_allclose(baro.channels["temperature"], [288.15, 216.65], rtol=1e-12)


def test_wrong_unit_kind_refused(tmp_path):
    with pytest.raises(FlightError, match="'p': unit 'degC' is not a unit of Pa"):
        _baro_log(tmp_path, "degC", "K", [1.0], [1.0])


@pytest.fixture(scope="module")
def pressure_sim():
    scenario = reference_scenario()
    suite = SensorSuite(baro_channels=("pressure", "temperature"))
    return simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                          suite, rng=np.random.default_rng(11))


def test_simulated_pressure_and_round_trip(tmp_path, pressure_sim):
    baro = pressure_sim.log["baro"]
    assert set(baro.channels) == {"pressure", "temperature"}
    truth = pressure_sim.truth
    # the truth is the ISA of the true altitude; the log adds the stated noise
    np.testing.assert_allclose(truth["pressure"], isa_pressure(truth["altitude"]), rtol=1e-15)
    noise = baro.channels["pressure"] - truth["pressure"][::20]
    assert np.std(noise) == pytest.approx(SensorSuite().baro_pressure_sd_pa, rel=0.3)
    write_suite_log(pressure_sim.log, tmp_path / "log.toml")
    back = read_suite_log(tmp_path / "log.toml")["baro"]
    for channel in ("pressure", "temperature"):
        np.testing.assert_array_equal(back.channels[channel], baro.channels[channel])
    assert back.noise_sd == baro.noise_sd
    np.testing.assert_array_equal(back.t, baro.t)


def test_suite_refuses_unknown_baro_channels():
    with pytest.raises(AirframeError, match="baro_channels must be one of"):
        SensorSuite(baro_channels=("temperature",))


def test_reconstruction_from_pressure_and_temperature(pressure_sim):
    rec = reconstruct(pressure_sim.log)
    truth = pressure_sim.truth
    z = (rec.table["altitude"].to_numpy() - truth["altitude"]) / rec.table["sd_altitude"]
    assert np.mean(np.abs(z) < 3.0) >= 0.97  # the criterion of test_reconstruction.py
    assert rec.nis["baro"]["consistent"], rec.nis["baro"]
    # rho = p / (R T): against the ISA density of the true altitude, within what the
    # temperature's noise (0.2 K at about 270 K, one sample) allows
    rel = rec.table["rho"].to_numpy() / density(truth["altitude"]) - 1.0
    temperature_rel_sd = SensorSuite().baro_temperature_sd_k / truth["temperature"].min()
    assert np.max(np.abs(rel)) < 5 * temperature_rel_sd
    assert any("rho = p / (R T)" in note for note in rec.notes)

    # a temperature 10 K too warm: the density follows it by T / (T + 10), exactly
    baro = pressure_sim.log["baro"]
    warm = dataclasses.replace(baro, channels={
        **baro.channels, "temperature": baro.channels["temperature"] + 10.0})
    rec_warm = reconstruct(dataclasses.replace(pressure_sim.log,
                                               groups={**pressure_sim.log.groups,
                                                       "baro": warm}))
    temperature = np.interp(rec.table["t"], baro.t, baro.channels["temperature"])
    np.testing.assert_allclose(rec_warm.table["rho"] / rec.table["rho"],
                               temperature / (temperature + 10.0), rtol=1e-6)


@pytest.mark.parametrize(("channels", "needle"), [
    (("altitude", "pressure"), "both altitude and pressure"),
    (("altitude", "temperature"), "needs the static pressure"),
])
def test_reconstruction_refuses_ambiguous_baro(pressure_sim, channels, needle):
    baro = pressure_sim.log["baro"]
    values = {"altitude": pressure_altitude(baro.channels["pressure"]),
              **baro.channels}
    odd = dataclasses.replace(baro, channels={c: values[c] for c in channels},
                              noise_sd=dict.fromkeys(channels, 1.0))
    log = dataclasses.replace(pressure_sim.log, groups={**pressure_sim.log.groups, "baro": odd})
    with pytest.raises(FlightError, match=needle) as info:
        reconstruct(log)
    assert "\n" not in str(info.value)


def test_reconstruction_refuses_pressure_without_sd(pressure_sim):
    baro = pressure_sim.log["baro"]
    odd = dataclasses.replace(baro, noise_sd={"temperature": 0.2})
    log = dataclasses.replace(pressure_sim.log, groups={**pressure_sim.log.groups, "baro": odd})
    with pytest.raises(FlightError, match="no noise_sd for pressure"):
        reconstruct(log)


# The barometer's density on the reconstruction's flight -----------------------------------
#: rho = p / (R T) through the flight's per-sample atmosphere against the closed form from
#: the log's temperature and the reconstructed altitude: the same arithmetic in another
#: order (measured 0 to 1 ulp).
CLOSED_FORM_RTOL = 1e-12


def _flight_density(flight) -> np.ndarray:
    return exogenous(flight)[:, EXOGENOUS.index("rho")]


def _note(flight) -> str:
    return next(n for n in flight.metadata["notes"] if n.startswith("flight density"))


def test_flight_gets_the_barometers_density(pressure_sim):
    rec = reconstruct(pressure_sim.log)
    assert rec.metadata["density"] == "barometer"
    baro, t = pressure_sim.log["baro"], rec.table["t"].to_numpy()
    temperature = np.interp(t, baro.t, baro.channels["temperature"])
    closed_form = isa_pressure(rec.table["altitude"].to_numpy()) / (R_AIR * temperature)

    flight = rec.to_flight(atmosphere="per-sample")
    assert flight.airframe.atmosphere_channel == "rho" and "altitude" not in flight.channels
    rho = _flight_density(flight)
    np.testing.assert_allclose(rho, closed_form, rtol=CLOSED_FORM_RTOL)
    assert _note(flight).startswith("flight density: rho = p / (R T) per sample")
    # and it is the truth's density within 5 temperature sd (as the table's, above)
    truth = pressure_sim.truth
    rel = rho / density(truth["altitude"]) - 1.0
    assert np.max(np.abs(rel)) < 5 * SensorSuite().baro_temperature_sd_k / truth[
        "temperature"].min()

    # a known-wrong density: the ISA of the altitude differs from p / (R T) by more than
    # the temperature's noise allows, and the note says p / (R T) was not used
    isa = rec.to_flight(atmosphere="altitude")
    assert isa.airframe.atmosphere_channel == "altitude"
    np.testing.assert_allclose(_flight_density(isa), density(rec.table["altitude"]),
                               rtol=CLOSED_FORM_RTOL)
    assert "rho = p / (R T) not used" in _note(isa)
    assert np.max(np.abs(_flight_density(isa) / rho - 1.0)) > 1e-4
    assert _note(rec.to_flight()) == "flight density: the airframe's atmosphere"
    with pytest.raises(FlightError, match="atmosphere must be one of 'airframe', "
                                          "'per-sample', 'altitude', got 'rho'"):
        rec.to_flight(atmosphere="rho")


def test_per_sample_without_temperature_is_the_isa(pressure_sim):
    baro = pressure_sim.log["baro"]
    only_p = dataclasses.replace(baro, channels={"pressure": baro.channels["pressure"]},
                                 noise_sd={"pressure": baro.noise_sd["pressure"]})
    rec = reconstruct(dataclasses.replace(pressure_sim.log,
                                          groups={**pressure_sim.log.groups, "baro": only_p}))
    assert rec.metadata["density"] == "isa"
    flight = rec.to_flight(atmosphere="per-sample")
    assert flight.airframe.atmosphere_channel == "altitude"
    np.testing.assert_allclose(_flight_density(flight), density(rec.table["altitude"]),
                               rtol=CLOSED_FORM_RTOL)
    assert "(no baro temperature for p / (R T))" in _note(flight)


def test_cli_per_sample_density_from_the_barometer(tmp_path, capsys):
    scenario = reference_scenario()
    manoeuvre = dataclasses.replace(scenario.manoeuvre, window_s=(5.0, 5.3))
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, manoeuvre,
                         SensorSuite(baro_channels=("pressure", "temperature")), rng=4)
    write_suite_log(sim.log, tmp_path / "suite.toml")
    out, path = tmp_path / "states.csv", tmp_path / "flight.csv"
    assert main(["reconstruct", str(tmp_path / "suite.toml"), "-o", str(out),
                 "--flight", str(path), "--per-sample-density"]) == 0
    assert "flight density: rho = p / (R T) per sample" in capsys.readouterr().out
    written = read_flight(path)
    assert written.airframe.atmosphere_channel == "rho"
    table = pd.read_csv(out)
    np.testing.assert_allclose(written["rho"], table["rho"], rtol=1e-12)


def test_reconstruction_of_a_log_whose_airframe_has_tables(pressure_sim):
    """The density probe is the atmosphere's alone: an airframe with [tables] (Mach from
    the ISA at its altitude) reconstructs to the same states and density as without."""
    log = pressure_sim.log
    tabled = dataclasses.replace(log, airframe=log.airframe.replace(
        tables=TableSpec((("Cx", 3),))))
    assert tabled.airframe.tables is not None and tabled.airframe.altitude_m is not None
    plain, with_tables = reconstruct(log), reconstruct(tabled)
    for column in ("u", "v", "w", "altitude", "rho"):
        np.testing.assert_array_equal(with_tables.table[column], plain.table[column])
