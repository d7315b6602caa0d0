"""Logs as loggers write them: dropped and unused columns, units, wrapped angles, paths."""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from aeroid.errors import FlightError
from aeroid.flights import read_column_map, read_flight
from aeroid.model import G0, save_airframe

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
#: Values through a CSV at 17 digits and a unit factor and back: round-off only.
UNIT_RTOL = 1e-12


def _log(tmp_path: Path, flight, extra: dict | None = None, **changes) -> tuple[Path, Path]:
    """Write ``flight`` as a plain CSV (no sidecar) with changed/extra columns; return the
    CSV and the airframe TOML."""
    frame = flight.data.copy()
    for name, values in (changes or {}).items():
        frame[name] = values
    for name, values in (extra or {}).items():
        frame[name] = values
    path = tmp_path / "log.csv"
    frame.to_csv(path, index=False, float_format="%.17g")
    airframe = tmp_path / "airframe.toml"
    save_airframe(flight.airframe, airframe)
    return path, airframe


def _map(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "map.toml"
    path.write_text(text)
    return path


def test_a_column_mapped_to_empty_is_dropped(tmp_path, clean_flight) -> None:
    qbar = 0.5 * 0.4 * np.sum(clean_flight.states()[:, :3] ** 2, axis=1)
    path, airframe = _log(tmp_path, clean_flight, extra={"qbar": qbar})
    kept = read_flight(path, airframe=airframe)
    assert "qbar" in kept.channels
    with pytest.raises(FlightError, match="qbar"):  # an input the model does not use
        kept.validate()
    dropped = read_flight(path, airframe=airframe, columns=_map(tmp_path, 'qbar = ""'))
    assert "qbar" not in dropped.channels
    assert any("dropped by the column map: qbar" in n for n in dropped.notes)
    dropped.validate()


def test_unused_columns_are_named_in_one_notice(tmp_path, clean_flight, caplog) -> None:
    path, airframe = _log(tmp_path, clean_flight,
                          extra={"gps_sats": np.ones(clean_flight.n_samples),
                                 "baro_hpa": np.ones(clean_flight.n_samples)})
    with caplog.at_level(logging.INFO, logger="aeroid"):
        flight = read_flight(path, airframe=airframe)
    lines = [r.getMessage() for r in caplog.records if "not read" in r.getMessage()]
    assert len(lines) == 1 and "gps_sats, baro_hpa" in lines[0]
    assert any("not read" in n for n in flight.notes)


def test_units_in_the_column_map_are_converted_and_recorded(tmp_path, clean_flight) -> None:
    deg = 180.0 / math.pi
    path, airframe = _log(tmp_path, clean_flight, p=clean_flight["p"] * deg,
                          phi=clean_flight["phi"] * deg, az1=clean_flight["az1"] / G0,
                          u=clean_flight["u"] / 0.3048)
    columns = _map(tmp_path, 'p = {channel = "p", unit = "deg/s"}\n'
                             'phi = {channel = "phi", unit = "deg"}\n'
                             'az1 = {channel = "az1", unit = "g"}\n'
                             'u = {channel = "u", unit = "ft/s"}\n')
    flight = read_flight(path, airframe=airframe, columns=columns)
    for name in ("p", "phi", "az1", "u", "q"):
        np.testing.assert_allclose(flight[name], clean_flight[name], rtol=UNIT_RTOL)
    # alpha and beta are derived from the converted u, v, w
    np.testing.assert_allclose(flight["alpha"], clean_flight["alpha"], rtol=1e-9)
    note = next(n for n in flight.notes if n.startswith("converted"))
    for part in ("p (deg/s -> rad/s)", "phi (deg -> rad)", "az1 (g -> m/s^2)",
                 "u (ft/s -> m/s)"):
        assert part in note


def test_a_unit_wins_over_degrees_for_its_column(tmp_path, clean_flight) -> None:
    deg = 180.0 / math.pi
    frame = {c: clean_flight[c] * deg for c in ("p", "q", "r", "delta", "phi", "theta",
                                                 "psi", "alpha", "beta")}
    path, airframe = _log(tmp_path, clean_flight, **{**frame, "q": clean_flight["q"]})
    columns = _map(tmp_path, 'q = {channel = "q", unit = "rad/s"}\n')
    flight = read_flight(path, airframe=airframe, columns=columns, degrees=True)
    for name in ("p", "q", "phi", "delta"):
        np.testing.assert_allclose(flight[name], clean_flight[name], rtol=UNIT_RTOL)


@pytest.mark.parametrize(("text", "match"), [
    ('p = {channel = "p", unit = "furlong"}', "unknown unit 'furlong'"),
    ('p = {channel = "p", unit = "deg"}',
     "unit 'deg' measures angle, channel 'p' is rate (rad/s, deg/s)"),
    ('p = {channel = "p", unit = "deg/s", scale = 2}', "column map values"),
    ('p = {unit = "deg/s"}', "column map values"),
])
def test_a_bad_unit_is_one_line(tmp_path, text, match) -> None:
    with pytest.raises(FlightError) as info:
        read_column_map(_map(tmp_path, text))
    assert match in str(info.value) and "\n" not in str(info.value)


def _wrapped(angle: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * angle))  # to (-pi, pi]


def test_a_wrapped_roll_angle_is_unwrapped_with_a_note(tmp_path, paper_flight) -> None:
    phi = paper_flight["phi"]
    wrapped = _wrapped(phi)
    assert np.sum(np.abs(np.diff(wrapped)) > math.pi) > 3  # the roll angle turns often
    path, airframe = _log(tmp_path, paper_flight, phi=wrapped, psi=_wrapped(paper_flight["psi"]))
    flight = read_flight(path, airframe=airframe)
    # continuous again: the logged angle plus a whole number of turns, the same at every
    # sample (the offset of the first sample is what the log says, within one turn)
    turns = (flight["phi"] - phi) / (2.0 * math.pi)
    np.testing.assert_allclose(turns, np.round(turns[0]), atol=1e-9)
    assert np.max(np.abs(np.diff(flight["phi"]))) < math.pi
    assert any(n.startswith("phi was wrapped") for n in flight.notes)
    flight.validate()


def test_a_jump_the_rates_do_not_explain_is_left_to_the_check(tmp_path, clean_flight) -> None:
    phi = clean_flight["phi"]
    glitch = phi.copy()
    glitch[200:] += 4.0  # not a whole turn
    path, airframe = _log(tmp_path, clean_flight, phi=glitch)
    flight = read_flight(path, airframe=airframe)
    np.testing.assert_array_equal(flight["phi"], glitch)
    assert not any("wrapped" in n for n in flight.notes)
    with pytest.raises(FlightError, match="phi jumps"):
        flight.validate()


def test_sparse_samples_are_not_unwrapped(tmp_path, clean_flight) -> None:
    """Every 40th sample: the roll rate moves phi by ~3.9 rad per sample (> pi): the
    wraps cannot be resolved and the angle is left as logged."""
    sparse = clean_flight.data.iloc[::40].reset_index(drop=True)
    wrapped = _wrapped(sparse["phi"].to_numpy())
    path = tmp_path / "log.csv"
    sparse.assign(phi=wrapped).to_csv(path, index=False, float_format="%.17g")
    flight = read_flight(path, airframe=clean_flight.airframe)
    np.testing.assert_array_equal(flight["phi"], wrapped)
    assert not any("wrapped" in n for n in flight.notes)


def test_read_flight_takes_paths_and_degrees() -> None:
    from aeroid.model import load_airframe

    log = EXAMPLES / "flight-log.csv"
    by_path = read_flight(log, airframe=EXAMPLES / "airframe.toml",
                          columns=EXAMPLES / "columns.toml", degrees=True)
    by_object = read_flight(log, airframe=load_airframe(EXAMPLES / "airframe.toml"),
                            columns=read_column_map(EXAMPLES / "columns.toml"),
                            angles_in_degrees=True)
    pd.testing.assert_frame_equal(by_path.data, by_object.data)
    raw = pd.read_csv(log)
    np.testing.assert_allclose(by_path["p"], np.radians(raw["gyro_x_dps"]), rtol=UNIT_RTOL)


def test_a_column_map_given_as_a_dict_takes_units(tmp_path, clean_flight) -> None:
    path, airframe = _log(tmp_path, clean_flight, q=np.degrees(clean_flight["q"]))
    flight = read_flight(path, airframe=airframe,
                         columns={"q": {"channel": "q", "unit": "deg/s"}, "psi": ""})
    np.testing.assert_allclose(flight["q"], clean_flight["q"], rtol=UNIT_RTOL)
    assert "psi" not in flight.channels
    with pytest.raises(FlightError, match="unknown unit"):
        read_flight(path, airframe=airframe, columns={"q": {"channel": "q", "unit": "x"}})
