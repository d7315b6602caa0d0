"""The reconstruction's steady wind from a suite log's air group (issues 22 and 26).

Reference: the suite simulation's true states and a chosen NED wind ``W`` give the
probe's readings, ``air_data(v_body - C_nb' W)`` with white noise; the kinematic
reconstruction does not see the aerodynamics, so a still-air simulation with a probe in
``W`` is a consistent windy log for it. The wind must come back within 3 of its sd, the
still air within 3 sd of zero, a gusty wind must be called not steady, and a log without
air data must say the wind cannot be estimated.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aeroid.flights import (
    SensorGroup,
    body_to_ned,
    read_suite_log,
    reference_scenario,
    simulate_suite,
    write_suite_log,
)
from aeroid.model import equations
from aeroid.reconstruction import reconstruct

WIND = np.array([3.0, 4.0, -0.5])
#: A vane's 0.1 deg and a pitot's 0.5 m/s.
SD = {"alpha": float(np.radians(0.1)), "beta": float(np.radians(0.1)), "airspeed": 0.5}
#: Every 10th IMU sample: 100 Hz.
EVERY = 10
N_SD = 3.0


@pytest.fixture(scope="module")
def sim():
    s = reference_scenario()
    return simulate_suite(s.airframe, s.coefficient_vector, s.manoeuvre,
                          rng=np.random.default_rng(11))


def air_group(sim, wind, *, gust_mps=0.0, seed=0, channels=("alpha", "beta", "airspeed")):
    """A probe at the c.g. in ``wind`` (plus sinusoidal gusts of ``gust_mps``) at 100 Hz."""
    gen = np.random.default_rng(seed)
    tr, t = sim.truth, sim.log["imu"].t
    k = np.arange(0, t.size, EVERY)
    v = np.column_stack([tr[c][k] for c in ("u", "v", "w")])
    wind_k = wind + gust_mps * np.column_stack([np.sin(2 * np.pi * f * t[k])
                                                for f in (1.3, 0.7, 1.0)])
    c_nb = body_to_ned(tr["phi"][k], tr["theta"][k], tr["psi"][k])
    speed, alpha, beta = equations.air_data(*(v - np.einsum("kji,kj->ki", c_nb, wind_k)).T)
    true = {"alpha": alpha, "beta": beta, "airspeed": speed}
    return SensorGroup("air", t[k], {c: true[c] + SD[c] * gen.standard_normal(k.size)
                                     for c in channels}, {c: SD[c] for c in channels})


def with_air(sim, group):
    return dataclasses.replace(sim.log, groups={**sim.log.groups, "air": group})


def test_the_steady_wind_within_3_sd(sim) -> None:
    rec = reconstruct(with_air(sim, air_group(sim, WIND)))
    wind, sd = np.array(rec.metadata["wind_ned_mps"]), np.array(rec.metadata["wind_stderr_mps"])
    assert np.all(np.abs(wind - WIND) <= N_SD * sd)
    assert np.all(sd < 0.5)  # informative: a tenth of the wind
    assert rec.metadata["wind_steady"]
    note = [n for n in rec.notes if n.startswith("steady wind from the air data")]
    assert len(note) == 1 and "; steady" in note[0] and "\n" not in note[0]


def test_still_air_and_gusts(sim) -> None:
    still = reconstruct(with_air(sim, air_group(sim, np.zeros(3), seed=1))).metadata
    assert np.all(np.abs(still["wind_ned_mps"]) <= N_SD * np.array(still["wind_stderr_mps"]))
    gusty = reconstruct(with_air(sim, air_group(sim, WIND, gust_mps=2.0))).metadata
    assert not gusty["wind_steady"] and gusty["wind_scatter"] > 2.0


def test_without_air_data_it_says_it_cannot(sim) -> None:
    rec = reconstruct(sim.log)
    assert "wind_ned_mps" not in rec.metadata
    assert any("steady wind cannot be estimated" in n for n in rec.notes)
    angles_only = reconstruct(with_air(sim, air_group(sim, WIND, channels=("alpha", "beta"))))
    assert "wind_ned_mps" not in angles_only.metadata
    assert any("lacks airspeed" in n for n in angles_only.notes)


def test_the_air_group_is_written_and_read(sim, tmp_path) -> None:
    group = air_group(sim, WIND)
    path = tmp_path / "suite.toml"
    write_suite_log(with_air(sim, group), path)
    read = read_suite_log(path)["air"]
    for c in ("alpha", "beta", "airspeed"):
        np.testing.assert_allclose(read.channels[c], group.channels[c], rtol=1e-15)
        assert read.noise_sd[c] == SD[c]


def test_the_flight_carries_the_wind_to_the_regressions(sim) -> None:
    from aeroid.estimation import resolve_air_data

    rec = reconstruct(with_air(sim, air_group(sim, WIND)))
    flight = rec.to_flight(air="wind")  # the wind only: carried air samples win (auto)
    assert flight.metadata["wind_ned_mps"] == rec.metadata["wind_ned_mps"]
    air = resolve_air_data(flight, "auto", "equation-error")
    assert air.source == "reconstruction" and air.wind is not None
    np.testing.assert_array_equal(air.wind[-1], rec.metadata["wind_ned_mps"])
    assert "steady wind is taken as exact" in str(air.warning)
