"""Flight: lossless files, validation messages, users' own logs."""

from __future__ import annotations

import importlib.util
import json
import math

import numpy as np
import pandas as pd
import pytest

from aeroid.errors import FlightError
from aeroid.flights import (
    ANGLE_CHANNELS,
    REQUIRED_CHANNELS,
    make_flight,
    read_flight,
    sidecar_path,
)
from aeroid.model import N_STATE

HAVE_PYARROW = importlib.util.find_spec("pyarrow") is not None
#: degrees -> radians after radians -> degrees: a few ulp.
DEGREES_RTOL = 4e-16


def _assert_same_flight(read, original):
    pd.testing.assert_frame_equal(read.data, original.data, check_exact=True)
    assert read.airframe == original.airframe
    meta = {k: v for k, v in read.metadata.items() if k != "source"}
    assert meta == original.metadata


def test_csv_round_trip_is_lossless(paper_flight, tmp_path):
    path = tmp_path / "flight.csv"
    sidecar = paper_flight.write(path)
    assert sidecar == sidecar_path(path) == tmp_path / "flight.json"
    assert json.loads(sidecar.read_text())["format"] == "aeroid-flight/1"
    read = read_flight(path)
    _assert_same_flight(read, paper_flight)
    assert read.metadata["source"] == str(path)
    for channel in paper_flight.channels:  # bit for bit
        np.testing.assert_array_equal(read[channel], paper_flight[channel])
    np.testing.assert_array_equal(read.true_coefficients, paper_flight.true_coefficients)


@pytest.mark.skipif(not HAVE_PYARROW, reason="pyarrow not installed")
def test_parquet_round_trip_is_lossless(paper_flight, tmp_path):
    path = tmp_path / "flight.parquet"
    paper_flight.write(path)
    _assert_same_flight(read_flight(path), paper_flight)


def test_accessors_return_copies_with_the_right_shapes(clean_flight):
    p = clean_flight["p"]
    p[:] = 0.0
    assert clean_flight["p"][0] != 0.0
    assert clean_flight.states().shape == (501, N_STATE)
    acc = clean_flight.accelerations()
    assert acc.shape == (501, 2, 3)
    np.testing.assert_array_equal(acc[:, 1, 2], clean_flight["az2"])
    with pytest.raises(FlightError, match="no channel 'mach'"):
        clean_flight["mach"]


def _broken(flight, **changes):
    """A copy of ``flight`` with some channels (or rows) replaced."""
    data = {c: flight[c] for c in flight.channels}
    for name, value in changes.items():
        if value is None:
            del data[name]
        else:
            data[name] = value
    return make_flight(data, flight.airframe)


def _one_line_error(flight) -> str:
    with pytest.raises(FlightError) as info:
        flight.validate()
    message = str(info.value)
    assert "\n" not in message
    return message


def test_valid_flight_validates(clean_flight):
    assert clean_flight.validate() is clean_flight
    assert clean_flight.problems() == []


def test_validate_missing_column(clean_flight):
    message = _one_line_error(_broken(clean_flight, ax2=None, r=None))
    assert "missing required column(s): ax2, r" in message


def test_validate_nan_names_column_and_row(clean_flight):
    q = clean_flight["q"]
    q[[17, 40]] = np.nan
    message = _one_line_error(_broken(clean_flight, q=q))
    assert "column 'q' has 2 NaN/inf or non-numeric value(s), first at row 17" in message


def test_validate_non_increasing_time(clean_flight):
    t = clean_flight.t
    t[100] = t[99]
    assert "time is not increasing at row 100" in _one_line_error(_broken(clean_flight, t=t))


def test_validate_non_uniform_time(clean_flight):
    t = clean_flight.t
    t[300:] += 0.0005
    assert "time base is not uniform" in _one_line_error(_broken(clean_flight, t=t))
    assert "at row 300" in _one_line_error(_broken(clean_flight, t=t))


def test_validate_airspeed(clean_flight):
    u = clean_flight["u"]
    u[5] = 0.0
    v, w = clean_flight["v"], clean_flight["w"]
    v[5] = w[5] = 0.0
    broken = _broken(clean_flight, u=u, v=v, w=w)
    assert "implausible airspeed V <= 0 at row 5" in _one_line_error(broken)


def test_validate_alpha_suggests_degrees(clean_flight):
    alpha = clean_flight["alpha"]
    alpha[42] = math.radians(75.0)
    message = _one_line_error(_broken(clean_flight, alpha=alpha))
    assert "implausible |alpha| > 60 deg at row 42 (75.0 deg" in message


def test_validate_reports_every_problem_on_one_line(clean_flight):
    q = clean_flight["q"]
    q[3] = np.inf
    alpha = clean_flight["alpha"]
    alpha[7] = 2.0
    message = _one_line_error(_broken(clean_flight, q=q, alpha=alpha, psi=None))
    parts = ["missing required column(s): psi", "column 'q' has 1", "alpha| > 60 deg at row 7"]
    positions = [message.find(part) for part in parts]
    assert message.startswith("flight: ") and -1 not in positions
    assert positions == sorted(positions)


def test_read_own_log_with_column_map_and_degrees(clean_flight, reference_scenario, tmp_path):
    # a user's log: own column names, angles in degrees and rates in deg/s, no sidecar
    names = {c: f"LOG_{c.upper()}" for c in REQUIRED_CHANNELS}
    frame = pd.DataFrame({names[c]: (np.degrees(clean_flight[c]) if c in ANGLE_CHANNELS
                                     else clean_flight[c]) for c in REQUIRED_CHANNELS})
    path = tmp_path / "log.csv"
    frame.to_csv(path, index=False, float_format="%.17g")
    assert not sidecar_path(path).exists()
    columns = {v: k for k, v in names.items()}
    read = read_flight(path, airframe=reference_scenario.airframe, columns=columns,
                       angles_in_degrees=True)
    read.validate()
    assert read.airframe == reference_scenario.airframe
    for c in REQUIRED_CHANNELS:
        np.testing.assert_allclose(read[c], clean_flight[c], rtol=DEGREES_RTOL, atol=0,
                                   err_msg=c)
    # without the degree flag the same file is implausible (alpha of ~1 deg read as rad)
    raw = read_flight(path, airframe=reference_scenario.airframe, columns=columns)
    assert any("alpha" in p for p in raw.problems())


def test_log_without_sidecar_or_airframe_is_an_error(clean_flight, tmp_path):
    path = tmp_path / "log.csv"
    clean_flight.data.to_csv(path, index=False)
    with pytest.raises(FlightError, match=r"no airframe \(no sidecar log.json"):
        read_flight(path)


@pytest.mark.parametrize(
    ("columns", "message"),
    [({"X": "mach"}, "unknown channel"), ({"nope": "p"}, "not in the file")],
)
def test_bad_column_map(clean_flight, reference_scenario, tmp_path, columns, message):
    path = tmp_path / "log.csv"
    clean_flight.data.to_csv(path, index=False)
    with pytest.raises(FlightError, match=message):
        read_flight(path, airframe=reference_scenario.airframe, columns=columns)


def test_missing_file(tmp_path):
    with pytest.raises(FlightError, match="no such file"):
        read_flight(tmp_path / "absent.csv")


def test_make_flight_derives_air_data(clean_flight):
    data = {c: clean_flight[c] for c in clean_flight.channels if c not in ("alpha", "beta")}
    flight = make_flight(data, clean_flight.airframe)
    np.testing.assert_array_equal(flight["alpha"], clean_flight["alpha"])
    np.testing.assert_array_equal(flight["beta"], clean_flight["beta"])
    assert flight.channels[: len(REQUIRED_CHANNELS)] == REQUIRED_CHANNELS
