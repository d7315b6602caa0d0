"""Sidecars of long flights: the size limit grows with the data file (issue 21).

A simulated flight's sidecar carries the fin's switch knots, which grow with the flight
(the reference scenario's 10-minute flight: 5.3 MB of sidecar beside 113 MB of CSV,
measured): past ~4 minutes they outgrew the former fixed 1 MB limit and the flight came
back without its airframe and truth. The limit is now the data file's size plus 1 MB; a
larger same-stem JSON file is still not opened.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from aeroid.errors import FlightError
from aeroid.flights import make_flight, read_flight
from aeroid.flights._sidecar import MAX_SIDECAR_BYTES, sidecar_limit

TEN_MINUTES_S = 600.0


def _shifted(table, offsets):
    """Concatenate a knot table ``{"t": [...], "delta": [...]}`` shifted by each offset."""
    t = np.asarray(table["t"], dtype=float)
    delta = np.asarray(table["delta"], dtype=float)
    return {"t": np.concatenate([t + o for o in offsets]).tolist(),
            "delta": np.tile(delta, len(offsets)).tolist()}


def _ten_minutes(flight):
    """The reference flight repeated for ten minutes, its switch knots with it (the
    reference flight's switching rate; simulating 600 s would cost a minute here)."""
    n, dt = flight.n_samples - 1, flight.dt  # one period without its last sample
    repeats = int(np.ceil(TEN_MINUTES_S / (n * dt)))
    data = {c: np.concatenate([np.tile(flight[c][:n], repeats), flight[c][-1:]])
            for c in flight.channels}
    data["t"] = flight.t[0] + dt * np.arange(n * repeats + 1)
    offsets = n * dt * np.arange(repeats)
    meta = dict(flight.metadata)
    meta["delta_knots"] = _shifted(meta["delta_knots"], offsets)
    meta["command_switches"] = _shifted(meta["command_switches"], offsets)
    return make_flight(data, flight.airframe, meta)


def test_a_ten_minute_flights_sidecar_is_written_and_read_back(paper_flight, tmp_path):
    flight = _ten_minutes(paper_flight)
    assert flight.t[-1] - flight.t[0] >= TEN_MINUTES_S
    sidecar = flight.write(tmp_path / "long.csv")
    size = sidecar.stat().st_size
    assert size > 2 * MAX_SIDECAR_BYTES  # the knots outgrow the former fixed limit
    assert size < sidecar_limit(tmp_path / "long.csv")
    back = read_flight(tmp_path / "long.csv")
    assert back.airframe == flight.airframe
    assert back.metadata["delta_knots"] == json.loads(json.dumps(flight.metadata["delta_knots"]))
    assert back.metadata["command_switches"]["t"][-1] == flight.metadata["command_switches"][
        "t"][-1]
    np.testing.assert_array_equal(back.true_coefficients, paper_flight.true_coefficients)


def test_a_sidecar_larger_than_its_data_plus_the_margin_is_not_opened(paper_flight, tmp_path):
    path = tmp_path / "f.csv"
    sidecar = paper_flight.write(path)
    text = sidecar.read_text()
    padding = sidecar_limit(path) - len(text) + 1  # one byte over the limit
    sidecar.write_text(text.replace('"metadata": {', '"metadata": {"pad": "'
                                    + "x" * (padding - len('"pad": "", ')) + '", ', 1))
    assert sidecar.stat().st_size == sidecar_limit(path) + 1
    with pytest.raises(FlightError) as info:
        read_flight(path)
    message = str(info.value)
    assert "\n" not in message
    assert (f"no airframe (f.json is not an aeroid sidecar: {sidecar_limit(path) + 1} bytes, "
            f"more than its data file plus {MAX_SIDECAR_BYTES}") in message
    # one byte less is read (metadata keys aeroid does not write are kept as they are)
    sidecar.write_text(sidecar.read_text().replace("xx", "x", 1))
    assert read_flight(path).metadata["pad"].startswith("x")
