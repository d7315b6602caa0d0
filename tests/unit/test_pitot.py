"""A pitot-static probe's pressures: the formulas, their inverse, the simulator's channels,
the airspeed they give and its refusals.

References: NACA Report 1135's tables (isentropic p/p0; normal-shock p02/p1); the normal
shock composed in this file (the static-pressure jump, the Mach number behind the shock,
then the isentropic ratio there: a second derivation of Rayleigh's formula); central
finite differences of the formulas and of the airspeed; the simulator's clean air-relative
velocity (its states less the steady wind, rotated here) with the ISA pressure; a
chi-square band on the noise.
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np
import pandas as pd
import pytest
from scipy import stats
from scipy.optimize import brentq

from aeroid.errors import AirframeError, FlightError
from aeroid.flights import (
    GaussianNoise,
    Wind,
    Windows,
    make_flight,
    make_noise,
    noise_from_dict,
    pitot_airspeed,
    pitot_ratio,
    pitot_ratio_slope,
    read_flight,
    simulate,
    with_pitot_airspeed,
)
from aeroid.flights._pitot import MAX_MACH, SONIC_RATIO, mach_from_pitot
from aeroid.model import isa_pressure

G = 1.4
WIND_NED = (3.0, 4.0, 0.0)
TOTAL_SD_PA, STATIC_SD_PA = 50.0, 30.0
#: Two-sided probability of a correct sd falling outside the chi-square band (per check).
BAND_P = 1e-6
#: NACA 1135: isentropic p0/p (1/(p/p0) of its table I, 5 digits) and the normal shock's
#: p02/p1 (table II, 4 digits): (Mach, ratio, digits' tolerance).
NACA_1135 = ((0.5, 1.1862, 1e-4), (0.8, 1.5243, 1e-4), (1.0, 1.8929, 1e-4),
             (1.5, 3.413, 1e-3), (2.0, 5.640, 1e-3), (3.0, 12.06, 1e-2))


def _normal_shock(mach):
    """p02/p1 composed: p2/p1 across the shock, M2 behind it, isentropic p02/p2 there."""
    m = np.asarray(mach, dtype=float)
    p2 = 1.0 + 2.0 * G / (G + 1.0) * (m * m - 1.0)
    m2 = (1.0 + 0.5 * (G - 1.0) * m * m) / (G * m * m - 0.5 * (G - 1.0))
    return p2 * (1.0 + 0.5 * (G - 1.0) * m2) ** (G / (G - 1.0))


def _sd_band(n: int, sd: float) -> tuple[float, float]:
    lo, hi = stats.chi2.ppf([BAND_P / 2, 1 - BAND_P / 2], n)
    return sd * np.sqrt(lo / n), sd * np.sqrt(hi / n)


def _body(phi, theta, psi, ned):
    """NED vector in body axes, the 3-2-1 rotation written out (not the model's)."""
    cf, sf, ct, st, cp, sp = (np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta),
                              np.cos(psi), np.sin(psi))
    n, e, d = ned
    return (ct * cp * n + ct * sp * e - st * d,
            (sf * st * cp - cf * sp) * n + (sf * st * sp + cf * cp) * e + sf * ct * d,
            (cf * st * cp + sf * sp) * n + (cf * st * sp - sf * cp) * e + cf * ct * d)


# ------------------------------------------------------------------ the formulas


@pytest.mark.parametrize(("mach", "ratio", "tol"), NACA_1135)
def test_ratio_equals_naca_1135(mach, ratio, tol) -> None:
    assert float(pitot_ratio(mach)) == pytest.approx(ratio, abs=tol)


def test_rayleigh_equals_the_composed_normal_shock() -> None:
    m = np.linspace(1.0, 5.0, 81)
    np.testing.assert_allclose(pitot_ratio(m), _normal_shock(m), rtol=1e-13)


def test_continuous_with_its_slope_at_mach_one() -> None:
    below, above = pitot_ratio([1.0 - 1e-10, 1.0 + 1e-10])
    assert below == pytest.approx(SONIC_RATIO, rel=1e-9) and above == pytest.approx(
        SONIC_RATIO, rel=1e-9)
    assert pytest.approx(1.2 ** 3.5, rel=1e-15) == SONIC_RATIO
    s_below, s_above = pitot_ratio_slope([1.0 - 1e-9, 1.0 + 1e-9])
    assert s_below == pytest.approx(s_above, rel=1e-7)


@pytest.mark.parametrize("mach", [0.2, 0.7, 0.999, 1.001, 1.68, 2.5, 4.0])
def test_slope_equals_a_finite_difference(mach) -> None:
    h = 1e-6 * mach
    fd = (pitot_ratio(mach + h) - pitot_ratio(mach - h)) / (2 * h)
    assert float(pitot_ratio_slope(mach)) == pytest.approx(float(fd), rel=1e-7)


def test_inversion_round_trip() -> None:
    m = np.r_[np.linspace(0.1, 3.0, 291), 1.0, 1.0 - 1e-12, 1.0 + 1e-12]
    np.testing.assert_allclose(mach_from_pitot(pitot_ratio(m)), m, rtol=0, atol=1e-11)
    assert mach_from_pitot(np.ones((2, 2))).shape == (2, 2)
    assert float(mach_from_pitot(1.0)) == 0.0


def test_inversion_equals_brentq_on_the_composed_shock() -> None:
    """A second solver (brentq, per sample) on the second derivation of the formula."""
    m = np.array([1.0 + 1e-6, 1.2, 1.68, 2.2, 3.7, 9.5])
    ratio = _normal_shock(m)
    reference = [brentq(lambda x, r=r: float(_normal_shock(x)) - r, 1.0, MAX_MACH, xtol=1e-14)
                 for r in ratio]
    np.testing.assert_allclose(mach_from_pitot(ratio), reference, rtol=0, atol=1e-10)
    np.testing.assert_allclose(reference, m, rtol=0, atol=1e-10)


@pytest.mark.parametrize("ratio", [0.99, np.nan, np.inf, float(pitot_ratio(MAX_MACH)) * 1.01])
def test_inversion_refuses_what_no_mach_gives(ratio) -> None:
    with pytest.raises(ValueError, match="at sample 1"):
        mach_from_pitot([2.0, ratio])


# ------------------------------------------------------------------ the simulator


@pytest.fixture(scope="module")
def probe_pair(reference_scenario):
    s = reference_scenario
    windy = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND_NED))
    vane = np.radians(0.1)
    probe = GaussianNoise(alpha_sd_rad=vane, beta_sd_rad=vane,
                          total_pressure_sd_pa=TOTAL_SD_PA, static_pressure_sd_pa=STATIC_SD_PA)
    speed = GaussianNoise(alpha_sd_rad=vane, beta_sd_rad=vane, airspeed_sd_mps=0.5)
    return (simulate(s.airframe, s.coefficient_vector, windy, probe, rng=3),
            simulate(s.airframe, s.coefficient_vector, windy, speed, rng=3))


def _true_air(f):
    wx, wy, wz = _body(f["phi"], f["theta"], f["psi"], WIND_NED)
    u, v, w = f["u"] - wx, f["v"] - wy, f["w"] - wz  # the states are clean
    return np.sqrt(u * u + v * v + w * w)


def test_simulated_pressures_against_the_truth(probe_pair) -> None:
    f, _ = probe_pair
    altitude = f.airframe.altitude_m
    static = float(isa_pressure(altitude))  # rho R T of the ISA is its pressure
    mach = _true_air(f) / np.sqrt(G * 287.05287 * (288.15 - 0.0065 * altitude))
    assert np.all(mach > 1.6)
    for error, sd in ((f["static_pressure"] - static, STATIC_SD_PA),
                      (f["total_pressure"] - static * _normal_shock(mach), TOTAL_SD_PA)):
        lo, hi = _sd_band(error.size, sd)
        assert lo < float(np.sqrt(np.mean(error**2))) < hi
        assert abs(np.mean(error)) < 5 * sd / np.sqrt(error.size)


def test_probe_drawn_last_and_off_by_default(probe_pair, reference_scenario) -> None:
    probe, speed = probe_pair
    assert {"total_pressure", "static_pressure"} <= set(probe.channels)
    assert "airspeed" not in probe.channels and "total_pressure" not in speed.channels
    for c in speed.channels:
        if c != "airspeed":
            np.testing.assert_array_equal(probe[c], speed[c], err_msg=c)
    s = reference_scenario
    plain = simulate(s.airframe, s.coefficient_vector, s.manoeuvre, GaussianNoise(), rng=1)
    assert not {"total_pressure", "static_pressure"} & set(plain.channels)
    assert not GaussianNoise().logs_pitot


def test_settings_round_trip_and_refusals() -> None:
    model = make_noise("gaussian", total_pressure_sd_pa=50.0, static_pressure_sd_pa=20.0)
    assert noise_from_dict(model.to_dict()) == model
    assert "total_pressure_sd_pa" not in GaussianNoise().to_dict()  # older sidecars as they were
    with pytest.raises(AirframeError, match="total_pressure_sd_pa must be a finite number"):
        make_noise("gaussian", total_pressure_sd_pa=-1.0)
    with pytest.raises(AirframeError, match="two airspeeds"):
        make_noise("gaussian", airspeed_sd_mps=0.5, static_pressure_sd_pa=20.0)


def test_simulator_refuses_a_probe_without_a_temperature(reference_scenario) -> None:
    s = reference_scenario
    given = s.airframe.replace(altitude_m=None, given_density_kgm3=0.41)
    with pytest.raises(AirframeError, match="need the air temperature"):
        simulate(given, s.coefficient_vector, s.manoeuvre,
                 GaussianNoise(total_pressure_sd_pa=50.0), rng=1)


# ------------------------------------------------------------------ the airspeed


def test_airspeed_and_its_sd(probe_pair) -> None:
    f, _ = probe_pair
    derived = pitot_airspeed(f)  # the sd from the simulator's metadata
    assert derived.sd is not None and "\n" not in derived.note
    z = (derived.airspeed - _true_air(f)) / derived.sd
    lo, hi = stats.chi2.ppf([BAND_P / 2, 1 - BAND_P / 2], z.size)
    assert lo < float(np.sum(z**2)) < hi  # the propagated sd is the airspeed's noise
    # the derivatives the sd propagates, against a central difference of the airspeed
    for name, slope in (("total_pressure", derived.dv_dtotal),
                        ("static_pressure", derived.dv_dstatic)):
        steps = []
        for h in (1.0, -1.0):
            data = f.data.copy()
            data[name] = data[name] + h
            steps.append(pitot_airspeed(dataclasses.replace(f, data=data)).airspeed)
        np.testing.assert_allclose(slope, (steps[0] - steps[1]) / 2.0, rtol=1e-6)
    said = pitot_airspeed(f, total_sd_pa=0.0, static_sd_pa=0.0)
    assert said.sd is not None and np.all(said.sd == 0)
    no_sd = pitot_airspeed(dataclasses.replace(f, metadata={}))
    assert no_sd.sd is None and "no sd given" in no_sd.note


def test_speed_of_sound_from_the_logged_temperature(probe_pair) -> None:
    f, _ = probe_pair
    hot = dataclasses.replace(f, data=f.data.assign(air_temperature=240.0))
    derived = pitot_airspeed(hot)
    np.testing.assert_allclose(derived.airspeed / pitot_airspeed(f).airspeed,
                               np.sqrt(240.0 / 223.15), rtol=1e-12)
    assert "logged air_temperature" in derived.note


def test_speed_of_sound_from_the_tables_or_the_altitude_channel(probe_pair) -> None:
    """The Mach tables' order: ``[tables] temperature_K`` before the ISA; a per-sample
    ``altitude`` channel gives the ISA temperature of each sample."""
    from aeroid.model import TableSpec

    f, _ = probe_pair
    isa = pitot_airspeed(f).airspeed
    tabled = f.airframe.replace(tables=TableSpec((("Cx", (1.5,)),), temperature_k=240.0))
    derived = pitot_airspeed(dataclasses.replace(f, airframe=tabled))
    np.testing.assert_allclose(derived.airspeed / isa, np.sqrt(240.0 / 223.15), rtol=1e-12)
    assert "[tables] temperature_K = 240 K" in derived.note
    per_sample = f.airframe.replace(altitude_m=None, atmosphere_channel="altitude")
    altitude = np.full(f.n_samples, 10000.0)
    altitude[::2] = 5000.0  # ISA 255.65 K at 5 km
    derived = pitot_airspeed(dataclasses.replace(f, airframe=per_sample,
                                                 data=f.data.assign(altitude=altitude)))
    np.testing.assert_allclose(derived.airspeed[1::2], isa[1::2], rtol=1e-12)
    np.testing.assert_allclose(derived.airspeed[::2] / isa[::2], np.sqrt(255.65 / 223.15),
                               rtol=1e-12)
    assert "ISA at the altitude channel" in derived.note


def test_fit_copy_carries_the_airspeed(probe_pair, caplog) -> None:
    f, _ = probe_pair
    with caplog.at_level(logging.INFO, logger="aeroid"):
        g = with_pitot_airspeed(f)
    assert "airspeed" in g.channels and "total_pressure" not in g.channels
    assert "total_pressure" in f.channels  # the input unchanged
    np.testing.assert_array_equal(g["airspeed"], pitot_airspeed(f).airspeed)
    assert any("airspeed from the probe's" in r.getMessage() for r in caplog.records)
    assert with_pitot_airspeed(g) is g
    both = with_pitot_airspeed(Windows((f, f), ("a", "b")))
    assert all("airspeed" in w.channels for w in both.flights)


def _with(f, **columns):
    return dataclasses.replace(f, data=f.data.assign(**columns))


@pytest.mark.parametrize(("change", "match"), [
    (lambda f: _with(f, total_pressure=f["static_pressure"] - 1.0),
     "must be above 'static_pressure'.*501 value"),
    (lambda f: _with(f, static_pressure=-f["static_pressure"]), "air pressure in .*rows 0-500"),
    (lambda f: _with(f, static_pressure=f["static_pressure"] / 1e3),
     r"kPa read as Pa\?"),
    (lambda f: _with(f, total_pressure=np.where(np.arange(f.n_samples) // 10 == 3, np.nan,
                                                 f["total_pressure"])),
     "'total_pressure' has NaN/inf: 10 value.*1 run.*rows 30-39"),
    (lambda f: dataclasses.replace(f, data=f.data.drop(columns="static_pressure")),
     "without 'static_pressure'"),
    (lambda f: _with(f, airspeed=500.0), "two airspeeds"),
    (lambda f: _with(f, total_pressure=f["static_pressure"] * 1e6), "Mach 0..20"),
])
def test_refusals_in_one_line(probe_pair, change, match) -> None:
    f = dataclasses.replace(change(probe_pair[0]), metadata={"source": "log.csv"})
    with pytest.raises(FlightError, match=match) as info:
        with_pitot_airspeed(f)
    assert str(info.value).startswith("log.csv: ") and "\n" not in str(info.value)


def test_the_flight_check_names_them_too(probe_pair) -> None:
    f = probe_pair[0]
    bad = _with(f, total_pressure=f["static_pressure"] - 1.0)
    assert any("must be above 'static_pressure'" in p for p in bad.problems())
    nan = _with(f, total_pressure=np.nan)
    assert sum("total_pressure" in p for p in nan.problems()) == 1  # NaN said once
    assert f.problems() == []


def test_a_static_pressure_alone_is_a_barometer(probe_pair, caplog) -> None:
    f = dataclasses.replace(probe_pair[0], data=probe_pair[0].data.drop(
        columns="total_pressure"))
    assert f.problems() == []
    with caplog.at_level(logging.INFO, logger="aeroid"):
        fitted = with_pitot_airspeed(f)
    assert "static_pressure" not in fitted.channels and "airspeed" not in fitted.channels
    assert fitted.channels == tuple(c for c in f.channels if c != "static_pressure")
    assert any("static_pressure not used" in r.getMessage() for r in caplog.records)


def test_no_temperature_is_assumed(probe_pair) -> None:
    f = probe_pair[0]
    given = f.airframe.replace(altitude_m=None, given_density_kgm3=0.41)
    with pytest.raises(FlightError, match="needs the air temperature"):
        pitot_airspeed(dataclasses.replace(f, airframe=given))


def test_read_in_other_units(probe_pair, tmp_path) -> None:
    f = probe_pair[0]
    frame = f.data.assign(total_pressure=f["total_pressure"] / 1e3,
                          static_pressure=f["static_pressure"] / 100.0)
    path = tmp_path / "probe.csv"
    make_flight(pd.DataFrame(frame), f.airframe, {}).write(path)
    columns = {"total_pressure": {"channel": "total_pressure", "unit": "kPa"},
               "static_pressure": {"channel": "static_pressure", "unit": "hPa"}}
    back = read_flight(path, columns=columns)
    np.testing.assert_allclose(back["total_pressure"], f["total_pressure"], rtol=1e-14)
    np.testing.assert_allclose(back["static_pressure"], f["static_pressure"], rtol=1e-14)
    np.testing.assert_allclose(pitot_airspeed(back).airspeed, pitot_airspeed(f).airspeed,
                               rtol=1e-12)
