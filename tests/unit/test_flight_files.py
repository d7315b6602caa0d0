"""Flight files: the sidecar's tag and precedence, column maps, non-regular files, Parquet."""

from __future__ import annotations

import json
import os
import sys
import threading

import numpy as np
import pandas as pd
import pytest

from aeroid.errors import FlightError
from aeroid.flights import read_flight, sidecar_path

#: A read that is refused must return at once; a FIFO used to block forever.
REFUSE_WITHIN_S = 20.0


def _files():
    """The file module (imported late: it is where the reading lives)."""
    from aeroid.flights import _files as files

    return files


def read_column_map(path):
    """``aeroid.flights.read_column_map``."""
    return _files().read_column_map(path)


def _one_line(call, *args, **kwargs) -> str:
    with pytest.raises(FlightError) as info:
        call(*args, **kwargs)
    message = str(info.value)
    assert "\n" not in message
    return message


def _log(tmp_path, flight, name="log.csv"):
    """``flight``'s data as a log without sidecar."""
    path = tmp_path / name
    flight.data.to_csv(path, index=False, float_format="%.17g")
    return path


# Sidecar --------------------------------------------------------------------------
def test_foreign_json_beside_the_log_is_not_a_sidecar(clean_flight, tmp_path):
    path = _log(tmp_path, clean_flight)
    sidecar_path(path).write_text(json.dumps({"logger": "XYZ-9", "rate_hz": 500}))
    read = read_flight(path, airframe=clean_flight.airframe)
    assert read.airframe == clean_flight.airframe
    assert read.metadata == {"source": str(path)}
    message = _one_line(read_flight, path)
    assert "no airframe (log.json is not an aeroid sidecar: no \"format\": " \
           "\"aeroid-flight/1\"; give --airframe FILE)" in message


def test_airframe_given_wins_and_sidecar_metadata_is_kept(paper_flight, tmp_path):
    path = tmp_path / "f.csv"
    paper_flight.write(path)
    other = paper_flight.airframe.replace(mass_kg=71.0)
    read = read_flight(path, airframe=other)
    assert read.airframe == other
    np.testing.assert_array_equal(read.true_coefficients, paper_flight.true_coefficients)
    assert read.metadata["seed"] == paper_flight.metadata["seed"]
    # the sidecar's airframe is not read at all: a broken one does not matter
    payload = json.loads(sidecar_path(path).read_text())
    payload["airframe"]["airframe"]["mass_kg"] = "heavy"
    sidecar_path(path).write_text(json.dumps(payload))
    assert read_flight(path, airframe=other).airframe == other
    message = _one_line(read_flight, path)
    assert "f.json airframe: [airframe] mass_kg must be a finite number, got 'heavy'" in message


def _sidecar_with(tmp_path, flight, edit):
    path = tmp_path / "f.csv"
    flight.write(path)
    payload = json.loads(sidecar_path(path).read_text())
    edit(payload)
    sidecar_path(path).write_text(json.dumps(payload))
    return path


@pytest.mark.parametrize(("edit", "fragment"), [
    (lambda p: p.update(metadata="abc"), "metadata must be a table, got 'abc'"),
    (lambda p: p["metadata"].update(seed="one"), "metadata seed must be an integer or null"),
    (lambda p: p["metadata"].update(seed=True), "metadata seed must be an integer or null"),
    (lambda p: p["metadata"].update(true_coefficients=[1, 2]),
     "metadata true_coefficients must be a table"),
    (lambda p: p["metadata"]["true_coefficients"].update(Cx="big"),
     "true_coefficients must be 9 finite numbers"),
    (lambda p: p["metadata"]["true_coefficients"].pop("Cmq"), "is missing Cmq"),
    (lambda p: p["metadata"].update(true_accel_positions_m=[[0, 0]]),
     "true_accel_positions_m must be 2 x 3 numbers"),
    (lambda p: p["metadata"]["noise"].update(rates_xi="x"),
     "noise model 'paper': rates_xi must be a finite number >= 0, got 'x'"),
    (lambda p: p["metadata"]["manoeuvre"].update(window_s="soon"),
     "manoeuvre window_s must be a number"),
    (lambda p: p["airframe"]["airframe"].update(mass_kg=True),
     "[airframe] mass_kg must be a finite number, got True"),
    (lambda p: p.update(extra=1), "f.json has unknown key(s) extra"),
    (lambda p: p.update(format="aeroid-flight/2"), "sidecar format 'aeroid-flight/2' is not"),
])
def test_sidecar_values_of_the_wrong_type_are_one_line(paper_flight, tmp_path, edit, fragment):
    path = _sidecar_with(tmp_path, paper_flight, edit)
    message = _one_line(read_flight, path)
    assert fragment in message and "f.json" in message


def test_malformed_sidecar_is_not_aeroids(clean_flight, tmp_path):
    path = tmp_path / "f.csv"
    clean_flight.write(path)
    sidecar_path(path).write_text("{not json")
    assert "f.json is not an aeroid sidecar: not JSON" in _one_line(read_flight, path)
    assert read_flight(path, airframe=clean_flight.airframe).n_samples == 501


# Column maps ------------------------------------------------------------------------
def test_two_columns_to_one_channel_is_one_line(clean_flight, tmp_path):
    data = clean_flight.data.rename(columns={"p": "gyro_x", "q": "gyro_y"})
    path = tmp_path / "log.csv"
    data.to_csv(path, index=False)
    message = _one_line(read_flight, path, airframe=clean_flight.airframe,
                        columns={"gyro_x": "p", "gyro_y": "p"})
    assert "column map sends both 'gyro_x' and 'gyro_y' to channel 'p'" in message
    columns = tmp_path / "map.toml"
    columns.write_text('gyro_x = "p"\ngyro_y = "p"\n')
    assert "sends both" in _one_line(read_column_map, columns)


def test_map_onto_a_column_the_file_already_has(clean_flight, tmp_path):
    data = clean_flight.data.assign(gyro_x=clean_flight["p"])
    path = tmp_path / "log.csv"
    data.to_csv(path, index=False)
    message = _one_line(read_flight, path, airframe=clean_flight.airframe,
                        columns={"gyro_x": "p"})
    assert "sends 'gyro_x' to 'p', but the file already has a column 'p'" in message
    # renaming the file's own 'p' away too is fine: a swap
    swapped = read_flight(path, airframe=clean_flight.airframe, columns={"p": "q", "q": "p"})
    np.testing.assert_array_equal(swapped["q"], clean_flight["p"])


def test_duplicate_header_is_one_line(clean_flight, tmp_path):
    path = tmp_path / "log.csv"
    frame = clean_flight.data.copy()
    frame.columns = [*frame.columns[:-1], "p"]  # 'psi' header reads 'p'
    frame.to_csv(path, index=False)
    assert "column 'p' appears twice in the header" in _one_line(
        read_flight, path, airframe=clean_flight.airframe)


def test_column_map_file_checks(tmp_path):
    path = tmp_path / "map.toml"
    path.write_text('[columns]\ngx = "p"\n\nextra = 1\n')
    with pytest.raises(FlightError, match="must be channel names"):
        read_column_map(path)  # 'extra' sits inside [columns]
    path.write_text('other = "x"\n[columns]\ngx = "p"\n')
    assert "unknown key(s) other" in _one_line(read_column_map, path)
    path.write_text('gx = "roll_rate"\n')
    assert "unknown channel(s) ['roll_rate']" in _one_line(read_column_map, path)
    path.write_text('[columns]\ngx = "p"\ngy = "q"\n')
    assert read_column_map(path) == {"gx": "p", "gy": "q"}


def test_no_channel_in_the_file(clean_flight, tmp_path):
    path = tmp_path / "log.csv"
    pd.DataFrame({"a": [1.0, 2.0], "b": [3.0, 4.0]}).to_csv(path, index=False)
    assert "no aeroid channel among the columns ('a', 'b'); map them with --columns" in \
        _one_line(read_flight, path, airframe=clean_flight.airframe)


def test_other_columns_are_not_read(clean_flight, tmp_path):
    path = tmp_path / "log.csv"
    clean_flight.data.assign(gps_fix="3D").to_csv(path, index=False, float_format="%.17g")
    read = read_flight(path, airframe=clean_flight.airframe)
    assert read.channels == clean_flight.channels
    pd.testing.assert_frame_equal(read.data, clean_flight.data, check_exact=True)


def test_text_and_booleans_in_a_column_are_reported_by_row(clean_flight, tmp_path):
    frame = clean_flight.data.astype(object)
    frame.loc[7, "q"] = "n/a"
    frame.loc[9, "r"] = True
    path = tmp_path / "log.csv"
    frame.to_csv(path, index=False)
    problems = read_flight(path, airframe=clean_flight.airframe).problems()
    assert "column 'q' has 1 NaN/inf or non-numeric value(s), first at row 7" in problems
    assert "column 'r' has 1 NaN/inf or non-numeric value(s), first at row 9" in problems


# Non-regular and large files ----------------------------------------------------------
def _refused_in_time(call) -> str:
    outcome: dict[str, str] = {}

    def target() -> None:
        try:
            call()
        except FlightError as exc:
            outcome["error"] = str(exc)

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(REFUSE_WITHIN_S)
    assert not thread.is_alive(), "the read blocked"
    return outcome["error"]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")
def test_fifo_as_the_flight_is_refused(clean_flight, tmp_path):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    message = _refused_in_time(lambda: read_flight(fifo, airframe=clean_flight.airframe))
    assert f"{fifo}: not a regular file (a FIFO, socket or device)" in message


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero")
def test_device_as_the_flight_is_refused(clean_flight):
    message = _refused_in_time(lambda: read_flight("/dev/zero", airframe=clean_flight.airframe))
    assert "/dev/zero: not a regular file" in message


def test_a_log_larger_than_memory_is_refused_before_parsing(clean_flight, tmp_path,
                                                            monkeypatch):
    path = _log(tmp_path, clean_flight)
    files = _files()
    monkeypatch.setattr(files, "_SAMPLE_BYTES", 4096)  # the estimate from the first 4 kB
    monkeypatch.setattr(files, "available_memory_bytes", lambda: 100_000)
    message = _one_line(read_flight, path, airframe=clean_flight.airframe)
    assert "rows x 19 channels need about" in message and "cut the log" in message
    monkeypatch.setattr(files, "available_memory_bytes", lambda: None)  # unknown: read
    assert read_flight(path, airframe=clean_flight.airframe).n_samples == 501


def test_blocks_are_joined_in_order(clean_flight, tmp_path, monkeypatch):
    monkeypatch.setattr(_files(), "CSV_BLOCK_ROWS", 64)
    path = tmp_path / "f.csv"
    clean_flight.write(path)
    pd.testing.assert_frame_equal(read_flight(path).data, clean_flight.data, check_exact=True)


# Parquet ----------------------------------------------------------------------------
def test_parquet_without_pyarrow_is_one_line(clean_flight, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyarrow", None)  # import pyarrow raises ImportError
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    path = tmp_path / "f.parquet"
    message = _one_line(clean_flight.write, path)
    assert "writing Parquet needs pyarrow (pip install 'aeroid-toolkit[parquet]')" in message
    assert not path.exists() and not sidecar_path(path).exists()
    path.write_bytes(b"PAR1")
    assert "reading Parquet needs pyarrow" in _one_line(read_flight, path,
                                                        airframe=clean_flight.airframe)


def test_data_named_like_its_sidecar_is_refused(clean_flight, tmp_path):
    assert "cannot be .json" in _one_line(clean_flight.write, tmp_path / "f.json")


def test_alpha_and_beta_are_derived_in_place(clean_flight, tmp_path):
    path = tmp_path / "log.csv"
    clean_flight.data.drop(columns=["alpha", "beta"]).to_csv(path, index=False,
                                                              float_format="%.17g")
    read = read_flight(path, airframe=clean_flight.airframe)
    assert read.channels == clean_flight.channels
    pd.testing.assert_frame_equal(read.data, clean_flight.data, check_exact=True)


def test_a_file_without_line_breaks_is_not_read_whole(clean_flight, tmp_path):
    path = tmp_path / "blob.csv"
    path.write_text("x," * 100_000)
    assert "header row longer than" in _one_line(read_flight, path,
                                                 airframe=clean_flight.airframe)
