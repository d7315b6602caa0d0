"""Airframe: the reference values, TOML round trips, one-line errors."""

from __future__ import annotations

import math
import tomllib
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from aeroid.errors import AirframeError
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
    assert Airframe.from_dict(shared) == reference_airframe()


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


def test_scenario_file_is_an_airframe_file():
    # a whole scenario file is a valid airframe file: the other tables are ignored
    path = resources.files("aeroid") / "data" / "reference-scenario.toml"
    with resources.as_file(path) as file:
        assert load_airframe(file) == reference_airframe()
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
