"""The suite simulator's windy probe through the reconstruction and into ``to_flight``.

References: the simulated wind (the truth) for the reconstruction's steady wind, which
must come back within 3 of its own sd with an airspeed channel, with a probe's pressures
and with a probe off the c.g. (whose ``omega x r`` left out must be seen); the log's own
air samples for the flight's channels (identity at the IMU's clock, linear
interpolation between the samples at a lower rate, checked against numpy).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aeroid.errors import FlightError
from aeroid.flights import AirProbe, SensorSuite, Wind, reference_scenario, simulate_suite
from aeroid.reconstruction import reconstruct

WIND = np.array([3.0, 4.0, -0.5])
N_SD = 3.0


@pytest.fixture(scope="module")
def scenario():
    s = reference_scenario()
    return dataclasses.replace(s, manoeuvre=dataclasses.replace(
        s.manoeuvre, wind=Wind(steady_ned_mps=tuple(WIND))))


def _rec(scenario, probe, seed=3):
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         SensorSuite(air_probe=probe), rng=seed)
    return sim, reconstruct(sim.log)


@pytest.mark.parametrize("probe", [
    AirProbe(),
    AirProbe(airspeed_sd_mps=0.0, total_pressure_sd_pa=50.0, static_pressure_sd_pa=50.0),
    AirProbe(position_m=(0.5, 0.05, -0.02)),
], ids=["airspeed", "pressures", "off-cg"])
def test_the_reconstructions_wind_within_3_sd_of_the_simulated_one(scenario, probe) -> None:
    _, rec = _rec(scenario, probe)
    wind = np.array(rec.metadata["wind_ned_mps"])
    sd = np.array(rec.metadata["wind_stderr_mps"])
    assert np.all(np.abs(wind - WIND) <= N_SD * sd), (wind - WIND) / sd
    assert np.all(sd < 0.5) and rec.metadata["wind_steady"]
    note = next(n for n in rec.notes if n.startswith("steady wind from the air data"))
    assert "\n" not in note
    if probe.total_pressure_sd_pa:
        assert "from the probe's total_pressure and static_pressure" in note
    if probe.position_m[1]:
        assert "probe at [0.5, 0.05, -0.02] m" in note


def test_a_probe_off_the_cg_taken_at_it_is_seen(scenario) -> None:
    sim, _ = _rec(scenario, AirProbe(position_m=(0.5, 0.05, -0.02)))
    unstated = dataclasses.replace(sim.log["air"], probe_position_m=None)
    log = dataclasses.replace(sim.log, groups={**sim.log.groups, "air": unstated})
    meta = reconstruct(log).metadata
    # 50 rad/s of roll times 5 cm across: 2.5 m/s turning with the roll, not a steady wind
    assert not meta["wind_steady"] and meta["wind_scatter"] > 2.0


def test_the_air_samples_in_the_flight(scenario) -> None:
    sim, rec = _rec(scenario, AirProbe(position_m=(0.5, 0.0, 0.0)))
    flight, group = rec.to_flight(air="interpolate"), sim.log["air"]
    t = flight["t"]
    k = np.arange(0, t.size, 10)  # the probe's instants: its samples as logged
    np.testing.assert_allclose(t[k], group.t, rtol=0, atol=1e-12)
    for c in ("alpha", "beta", "airspeed"):
        np.testing.assert_array_equal(flight[c][k], group.channels[c])
        np.testing.assert_allclose(flight[c], np.interp(t, group.t, group.channels[c]),
                                   rtol=1e-15)
    assert flight.metadata["air_data_probe"] == {"position_m": [0.5, 0.0, 0.0]}
    note = next(n for n in flight.metadata["notes"] if n.startswith("air: "))
    assert "linearly interpolated to the IMU's 1001 instants" in note and "10 IMU" in note
    assert flight.metadata["wind_ned_mps"] == rec.metadata["wind_ned_mps"]
    for air in ("auto", "wind"):  # 100 Hz is not the IMU's clock: the steady wind only
        plain = rec.to_flight(air=air)
        assert "airspeed" not in plain.channels and "air_data_probe" not in plain.metadata
        note = next(n for n in plain.metadata["notes"] if n.startswith("air: "))
        assert "not carried" in note and "\n" not in note
        assert plain.metadata["wind_ned_mps"] == rec.metadata["wind_ned_mps"]
    with pytest.raises(FlightError, match="needs an air sample at every IMU instant"):
        rec.to_flight(air="samples")
    with pytest.raises(FlightError, match="air must be one of"):
        rec.to_flight(air="yes")


@pytest.mark.parametrize("air", ["auto", "samples"])
def test_on_the_imus_clock_the_samples_as_logged(scenario, air) -> None:
    sim, rec = _rec(scenario, AirProbe(rate_hz=1000.0, airspeed_sd_mps=0.0,
                                       total_pressure_sd_pa=50.0, static_pressure_sd_pa=50.0))
    flight, group = rec.to_flight(air=air), sim.log["air"]
    for c in ("alpha", "beta", "total_pressure", "static_pressure"):
        np.testing.assert_array_equal(flight[c], group.channels[c])
    assert any("at the IMU's instants (the same clock): as logged" in n
               for n in flight.metadata["notes"])
    assert flight.metadata["air_data_probe"] == {"position_m": [0.0, 0.0, 0.0]}


def test_an_air_group_short_of_the_imu_is_refused(scenario) -> None:
    sim, _ = _rec(scenario, AirProbe())
    group = sim.log["air"]
    short = dataclasses.replace(group, t=group.t[:-5],
                                channels={c: v[:-5] for c, v in group.channels.items()})
    rec = reconstruct(dataclasses.replace(sim.log, groups={**sim.log.groups, "air": short}))
    with pytest.raises(FlightError, match="not resampled beyond its times") as info:
        rec.to_flight(air="interpolate")
    assert "\n" not in str(info.value)
    assert "airspeed" not in rec.to_flight(air="wind").channels


def test_without_an_air_group_samples_are_refused(scenario) -> None:
    _, rec = _rec(scenario, None)
    assert "airspeed" not in rec.to_flight().channels
    with pytest.raises(FlightError, match="needs an air group in the log"):
        rec.to_flight(air="samples")


def test_in_dryden_turbulence_the_wind_is_not_steady(scenario) -> None:
    gusty = dataclasses.replace(scenario, manoeuvre=dataclasses.replace(
        scenario.manoeuvre, wind=Wind(steady_ned_mps=tuple(WIND), turbulence_sd_mps=3.0)))
    _, rec = _rec(gusty, AirProbe())
    assert not rec.metadata["wind_steady"] and rec.metadata["wind_scatter"] > 2.0
    assert any("not steady" in n for n in rec.notes)
