"""Airframe: the reference values, TOML round trips, one-line errors."""

from __future__ import annotations

import math
import os
import threading
import tomllib
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from aeroid.errors import AeroidWarning, AirframeError
from aeroid.flights._scenario import load_scenario
from aeroid.model._airframe import (
    Airframe,
    dumps_toml,
    load_airframe,
    reference_airframe,
    save_airframe,
)
from aeroid.model._coefficients import nominal

# the project's shared folder sits beside the repository (developers' checkouts and CI)
#: A refused read must return at once; a FIFO used to block forever.
REFUSE_WITHIN_S = 20.0
SHARED_REFERENCE = Path(__file__).resolve().parents[3] / "shared/reference/reference-scenario.toml"


def _one_line(exc_info) -> str:
    message = str(exc_info.value)
    assert "\n" not in message
    return message


def test_reference_airframe_values():
    a = reference_airframe()
    assert (a.diameter_m, a.length_m, a.mass_kg) == (0.127, 2.79, 70.0)
    assert (a.ix_kgm2, a.iy_kgm2, a.iz_kgm2, a.thrust_n) == (0.18, 40.0, 40.0, 740.0)
    np.testing.assert_array_equal(a.accel_positions, [[0.6, 0, 0], [-0.6, 0.01, 0.01]])
    assert a.area_m2 == pytest.approx(math.pi * 0.127**2 / 4, rel=1e-15)
    assert a.delta_max_rad == pytest.approx(math.radians(8.0), rel=1e-15)
    # ISA at 10 km (reference file comment): rho 0.4127 kg/m^3, a 299.46 m/s
    assert a.density_kgm3 == pytest.approx(0.4127, abs=5e-5)
    assert a.speed_of_sound_mps == pytest.approx(299.46, abs=5e-3)
    np.testing.assert_array_equal(a.prior_vector(), nominal())


def test_embedded_reference_equals_the_project_reference():
    try:
        with open(SHARED_REFERENCE, "rb") as fh:
            shared = tomllib.load(fh)
    except FileNotFoundError:
        pytest.skip("project reference folder not available")
    from aeroid.model._airframe import SCENARIO_TABLES

    assert Airframe.from_dict(shared, other_tables=SCENARIO_TABLES) == reference_airframe()


def test_toml_round_trip(tmp_path):
    prior = tuple(float(x) for x in nominal() * 1.1)
    original = reference_airframe().replace(accel2_position_m=(-0.55, 0.012, -0.009),
                                            altitude_m=3000.0, prior=prior)
    path = tmp_path / "airframe.toml"
    save_airframe(original, path)
    loaded = load_airframe(path)
    assert loaded == original
    assert loaded.prior == prior
    # the file uses the reference scenario's table and key names
    data = tomllib.loads(path.read_text())
    assert set(data) == {"airframe", "atmosphere", "prior"}
    assert data["airframe"]["Ix_kgm2"] == 0.18 and data["atmosphere"]["altitude_m"] == 3000.0


def test_scenario_file_is_not_an_airframe_file():
    # its [coefficients] would otherwise be silently ignored by an estimator
    path = resources.files("aeroid") / "data" / "reference-scenario.toml"
    with resources.as_file(path) as file, pytest.raises(AirframeError) as info:
        load_airframe(file)
    assert _one_line(info).startswith(
        f"{file}: unknown table(s) actuator, coefficients, initial_state, noise, recording "
        "(allowed: airframe, atmosphere, prior, fin_law, hold, prior_sd, tables, thrust_curve); "
        "a scenario "
        "file?")
    assert load_scenario(None).airframe == reference_airframe()


def test_malformed_toml_is_one_line(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("[airframe]\nmass_kg = = 3\n")
    with pytest.raises(AirframeError) as info:
        load_airframe(path)
    assert _one_line(info).startswith(f"{path}: malformed TOML")


def test_missing_file_is_one_line(tmp_path):
    with pytest.raises(AirframeError, match="no such file"):
        load_airframe(tmp_path / "absent.toml")


def test_missing_and_unknown_keys(tmp_path):
    table = reference_airframe().to_dict()
    del table["airframe"]["mass_kg"]
    path = tmp_path / "a.toml"
    path.write_text(dumps_toml(table))
    with pytest.raises(AirframeError) as info:
        load_airframe(path)
    assert _one_line(info) == f"{path}: [airframe] is missing mass_kg"
    table["airframe"]["mass_kg"] = 70.0
    table["airframe"]["wingspan_m"] = 1.0
    path.write_text(dumps_toml(table))
    with pytest.raises(AirframeError, match="unknown key"):
        load_airframe(path)
    path.write_text("[atmosphere]\naltitude_m = 0.0\n")
    with pytest.raises(AirframeError, match=r"no \[airframe\] table"):
        load_airframe(path)
    table["airframe"].pop("wingspan_m")
    table["fins"] = {"count": 4}
    path.write_text(dumps_toml(table))
    with pytest.raises(AirframeError) as info:
        load_airframe(path)
    assert _one_line(info) == (f"{path}: unknown table(s) fins "
                               "(allowed: airframe, atmosphere, prior, fin_law, hold, "
                               "prior_sd, tables, thrust_curve)")


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"mass_kg": -1.0}, "mass_kg must be a positive number"),
        ({"ix_kgm2": float("nan")}, "ix_kgm2 must be a positive number"),
        ({"thrust_n": float("inf")}, "thrust_n must be a finite number"),
        ({"accel1_position_m": (0.1, 0.2)}, "accel1_position_m must be 3 finite numbers"),
        ({"accel2_position_m": "abc"}, "accel2_position_m must be 3"),
        ({"prior": (1.0, 2.0)}, "airframe prior"),
    ],
)
def test_invalid_values_are_one_line(change, message):
    with pytest.raises(AirframeError) as info:
        reference_airframe().replace(**change)
    assert message in _one_line(info)


def test_invalid_value_in_a_file_names_the_file(tmp_path):
    table = reference_airframe().to_dict()
    table["airframe"]["Iy_kgm2"] = 0.0
    path = tmp_path / "zero.toml"
    path.write_text(dumps_toml(table))
    with pytest.raises(AirframeError) as info:
        load_airframe(path)
    assert _one_line(info).startswith(f"{path}: airframe: iy_kgm2 must be a positive number")


# The atmosphere is stated, never assumed ----------------------------------------------
def _write(path, table) -> Path:
    path.write_text(dumps_toml(table))
    return path


def _load_error(path) -> str:
    with pytest.raises(AirframeError) as info:
        load_airframe(path)
    return _one_line(info)


def test_missing_atmosphere_is_an_error_not_sea_level(tmp_path):
    table = reference_airframe().to_dict()
    del table["atmosphere"]
    path = _write(tmp_path / "a.toml", table)
    assert _load_error(path) == (
        f"{path}: no [atmosphere] table (exactly one of altitude_m, density_kgm3 or "
        "per_sample; aeroid assumes no sea level)")


@pytest.mark.parametrize(("atmosphere", "message"), [
    ({"altitude": 10000.0}, "[atmosphere] has unknown key(s) altitude (allowed: altitude_m, "
                            "density_kgm3, per_sample)"),
    ({}, "state the atmosphere with exactly one of altitude_m, density_kgm3 or per_sample "
         "(got none)"),
    ({"altitude_m": 100.0, "density_kgm3": 1.2}, "exactly one of altitude_m, density_kgm3 or "
                                                  "per_sample (got altitude_m, density_kgm3)"),
    ({"altitude_m": "high"}, "[atmosphere] altitude_m must be a finite number, got 'high'"),
    ({"per_sample": "pressure"}, "per_sample must be one of 'rho', 'altitude', 'qbar', "
                                 "got 'pressure'"),
    ({"per_sample": 3}, "[atmosphere] per_sample must be a non-empty string, got 3"),
])
def test_atmosphere_mistakes_are_one_line(tmp_path, atmosphere, message):
    table = reference_airframe().to_dict()
    table["atmosphere"] = atmosphere
    path = _write(tmp_path / "a.toml", table)
    assert message in _load_error(path)


def test_given_density_is_used_and_round_trips(tmp_path):
    table = reference_airframe().to_dict()
    table["atmosphere"] = {"density_kgm3": 0.9}
    airframe = load_airframe(_write(tmp_path / "a.toml", table))
    assert airframe.density_kgm3 == 0.9 and airframe.altitude_m is None
    save_airframe(airframe, tmp_path / "b.toml")
    assert load_airframe(tmp_path / "b.toml") == airframe
    with pytest.raises(AirframeError, match="speed of sound needs"):
        _ = airframe.speed_of_sound_mps


def test_per_sample_atmosphere_is_the_planned_format(tmp_path):
    table = reference_airframe().to_dict()
    table["atmosphere"] = {"per_sample": "rho"}
    airframe = load_airframe(_write(tmp_path / "a.toml", table))
    assert airframe.atmosphere_channel == "rho"
    save_airframe(airframe, tmp_path / "b.toml")
    assert load_airframe(tmp_path / "b.toml") == airframe
    with pytest.raises(AirframeError) as info:
        _ = airframe.density_kgm3
    assert "no single density: the atmosphere is per sample (channel 'rho')" in _one_line(info)


def test_length_is_optional(tmp_path):
    table = reference_airframe().to_dict()
    del table["airframe"]["length_m"]
    airframe = load_airframe(_write(tmp_path / "a.toml", table))
    assert airframe.length_m is None
    save_airframe(airframe, tmp_path / "b.toml")
    assert "length_m" not in (tmp_path / "b.toml").read_text()
    assert load_airframe(tmp_path / "b.toml") == airframe == reference_airframe().replace(
        length_m=None)


# Types and ranges ---------------------------------------------------------------------
@pytest.mark.parametrize(("table", "key", "value", "message"), [
    ("airframe", "mass_kg", True, "[airframe] mass_kg must be a finite number, got True"),
    ("airframe", "mass_kg", "70", "[airframe] mass_kg must be a finite number, got '70'"),
    ("airframe", "accel1_position_m", [0.6, 0.0],
     "[airframe] accel1_position_m must be 3 finite numbers, got [0.6, 0.0]"),
    ("airframe", "accel2_position_m", "0.6, 0, 0", "accel2_position_m must be 3 numbers"),
    ("airframe", "accel2_position_m", [0.6, True, 0.0], "must be 3 finite numbers"),
    ("airframe", "thrust_N", [740.0], "[airframe] thrust_N must be a finite number"),
    ("atmosphere", "altitude_m", False, "[atmosphere] altitude_m must be a finite number"),
    ("prior", "Cx", True, "[prior] Cx must be a finite number, got True"),
    ("prior", "Cq", 1.0, "[prior] has unknown key(s) Cq"),
])
def test_types_are_checked(tmp_path, table, key, value, message):
    data = reference_airframe().replace(prior=tuple(nominal())).to_dict()
    data[table][key] = value
    path = _write(tmp_path / "a.toml", data)
    assert _load_error(path).startswith(f"{path}: ") and message in _load_error(path)


def test_incomplete_prior(tmp_path):
    data = reference_airframe().to_dict()
    data["prior"] = {"Cx": -1.0}
    path = _write(tmp_path / "a.toml", data)
    assert "[prior] is missing Cza, Czd" in _load_error(path)


@pytest.mark.parametrize(("change", "message"), [
    ({"diameter_m": 1e-300}, "diameter_m 1e-300 is outside 0.001..10 (metres?)"),
    ({"diameter_m": 127.0}, "diameter_m 127 is outside 0.001..10"),
    ({"altitude_m": 1e6}, "altitude_m 1e+06 is outside -500..20000 (give density_kgm3"),
    ({"altitude_m": None, "given_density_kgm3": 12.0}, "density_kgm3 12 is outside"),
    ({"accel2_position_m": (0.6, 0.0, 0.0)}, "accelerometer triads 0 m apart"),
    ({"accel2_position_m": (0.6, 0.0, 0.0005)}, "triads 0.0005 m apart"),
    ({"accel1_position_m": (600.0, 0.0, 0.0)}, "farther from the c.g. than length_m 2.79"),
    ({"thrust_n": -740.0}, "thrust_n must be >= 0"),
    ({"delta_max_deg": 0.0}, "delta_max_deg must be in (0, 45] deg, got 0"),
    ({"delta_max_deg": 90.0}, "delta_max_deg must be in (0, 45] deg, got 90"),
    ({"mass_kg": True}, "mass_kg must be a positive number, got True"),
])
def test_physical_ranges(change, message):
    with pytest.raises(AirframeError) as info:
        reference_airframe().replace(**change)
    assert message in _one_line(info)


def test_tiny_fin_throw_is_a_warning():
    with pytest.warns(AeroidWarning, match=r"delta_max_deg 0.14 deg is very small \(radians\?"):
        reference_airframe().replace(delta_max_deg=0.14)


# Non-regular and oversized files --------------------------------------------------------
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")
def test_fifo_or_device_as_a_toml_file_is_refused(tmp_path):
    fifo = tmp_path / "airframe.toml"
    os.mkfifo(fifo)
    for path in (fifo, Path("/dev/zero")):
        outcome: dict[str, str] = {}

        def target(path=path, outcome=outcome) -> None:
            try:
                load_airframe(path)
            except AirframeError as exc:
                outcome["error"] = str(exc)

        thread = threading.Thread(target=target, daemon=True)
        thread.start()
        thread.join(REFUSE_WITHIN_S)
        assert not thread.is_alive(), f"reading {path} blocked"
        assert outcome["error"] == f"{path}: not a regular file (a FIFO, socket or device): " \
                                   "save the data to a file first"


def test_oversized_toml_is_refused(tmp_path):
    from aeroid.model._fileform import MAX_TOML_BYTES

    path = tmp_path / "big.toml"
    path.write_bytes(b"# " + b"x" * MAX_TOML_BYTES + b"\n")
    assert "too large for an aeroid TOML file" in _load_error(path)
