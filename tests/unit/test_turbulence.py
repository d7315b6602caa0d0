"""The simulator's moving air (issue 26): Dryden gusts against their closed forms, a steady
wind in the scenario format, still air unchanged.

References: MIL-F-8785C's Dryden autocorrelations, written out here
(``sd^2 exp(-V t / L)`` longitudinal, ``sd^2 (1 - V t / (2 L)) exp(-V t / L)``
transverse); scipy's rotations for the air-relative angles.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from aeroid.errors import AirframeError
from aeroid.flights import (
    NoNoise,
    Wind,
    path_axes,
    read_flight,
    reference_scenario,
    scenario_from_dict,
    shaping_filters,
    simulate,
    simulate_truth,
    write_flight,
)
from aeroid.model import reference_scenario_data

#: The sampled filters reproduce the continuous autocorrelation exactly (expm and a
#: Lyapunov solve: rounding only).
EXACT_RTOL = 1e-9
#: Dryden setting of the tests: MIL-F-8785C's moderate-turbulence intensity at altitude,
#: its scale length, and the reference flight's airspeed; dt puts L / V on the grid.
SD, LENGTH, SPEED = 3.0, 533.4, 500.0
LAG_SAMPLES = 200
DT = LENGTH / SPEED / LAG_SAMPLES


def _closed_form(lag_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    xi = lag_s * SPEED / LENGTH
    return SD ** 2 * np.exp(-xi), SD ** 2 * (1.0 - xi / 2.0) * np.exp(-xi)


def test_the_sampled_filters_have_drydens_autocorrelation_at_every_lag() -> None:
    lags = np.arange(0, 4 * LAG_SAMPLES + 1, 25)
    longitudinal, transverse = _closed_form(lags * DT)
    for f, expected in zip(shaping_filters(DT, sd=SD, scale_length_m=LENGTH,
                                           airspeed_mps=SPEED),
                           (longitudinal, transverse, transverse), strict=True):
        # stationary: the start's covariance propagates to itself
        q = f.noise_sqrt @ f.noise_sqrt.T
        np.testing.assert_allclose(f.phi @ f.stationary @ f.phi.T + q, f.stationary,
                                   rtol=EXACT_RTOL, atol=EXACT_RTOL * np.max(f.stationary))
        implied = [(f.c @ np.linalg.matrix_power(f.phi, int(k)) @ f.stationary @ f.c.T).item()
                   for k in lags]
        np.testing.assert_allclose(implied, expected, rtol=0, atol=EXACT_RTOL * SD ** 2)
    # at the scale length over the airspeed: e^-1 and e^-1 / 2 of the variance
    assert longitudinal[lags == LAG_SAMPLES] == pytest.approx(SD ** 2 / np.e)
    assert transverse[lags == LAG_SAMPLES] == pytest.approx(SD ** 2 / (2 * np.e))


@pytest.mark.slow
def test_drawn_gusts_have_the_sd_and_the_correlation_at_l_over_v() -> None:
    """Independent paths flown north (path axes = NED): the sample variance at the start
    and at L / V, and the lag-(L / V) covariance, within 4 standard errors."""
    rng = np.random.default_rng(2026)
    wind = Wind(turbulence_sd_mps=SD, scale_length_m=LENGTH)
    n_paths, coarse = 3000, 10  # the filters are exact at any dt: L / V in 10 steps
    draws = np.array([wind.gusts(coarse + 1, DT * LAG_SAMPLES / coarse,
                                 np.array([SPEED, 0.0, 0.0]), rng) for _ in range(n_paths)])
    first, last = draws[:, 0, :], draws[:, -1, :]
    se_var = SD ** 2 * np.sqrt(2.0 / n_paths)
    np.testing.assert_allclose(np.mean(first ** 2, axis=0), SD ** 2, atol=4 * se_var)
    np.testing.assert_allclose(np.mean(last ** 2, axis=0), SD ** 2, atol=4 * se_var)
    rho = np.array([1 / np.e, 1 / (2 * np.e), 1 / (2 * np.e)])
    se_cov = SD ** 2 * np.sqrt((1.0 + rho ** 2) / n_paths)
    covariance = np.mean(first * last, axis=0)
    assert np.all(np.abs(covariance - SD ** 2 * rho) <= 4 * se_cov), (covariance, SD ** 2 * rho)


def test_gusts_repeat_with_the_generator_and_lie_in_the_path_axes() -> None:
    wind = Wind(turbulence_sd_mps=SD)
    velocity = np.array([300.0, 300.0, -50.0])
    a = wind.gusts(50, DT, velocity, np.random.default_rng(1))
    np.testing.assert_array_equal(a, wind.gusts(50, DT, velocity, np.random.default_rng(1)))
    assert not np.array_equal(a, wind.gusts(50, DT, velocity, np.random.default_rng(2)))
    # the path axes: u_g along the path, v_g horizontal, a right-handed orthonormal triad
    axes = path_axes(velocity)
    np.testing.assert_allclose(axes @ axes.T, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(np.cross(axes[0], velocity), 0.0, atol=1e-12)
    assert axes[1][2] == 0.0 and np.linalg.det(axes) == pytest.approx(1.0)
    np.testing.assert_allclose(path_axes(np.array([0.0, 0.0, -300.0])) @ [0.0, 0.0, -1.0],
                               [1.0, 0.0, 0.0], atol=1e-15)  # climbing vertically: defined


def _with_wind(**table) -> dict:
    data = reference_scenario_data()
    data["wind"] = table
    return data


def test_the_scenario_wind_table_and_its_mistakes() -> None:
    s = scenario_from_dict(_with_wind(north_mps=3.0, east_mps=4.0, turbulence_sd_mps=1.5))
    assert s.manoeuvre.wind == Wind(steady_ned_mps=(3.0, 4.0, 0.0), turbulence_sd_mps=1.5)
    assert "wind" not in reference_scenario().manoeuvre.describe()  # fingerprints as before
    for table, message in (({"north": 1.0}, r"\[wind\] has unknown key"),
                           ({"turbulence_sd_mps": -1.0}, r"\[wind\]: turbulence_sd_mps must "),
                           ({"scale_length_m": 0.0}, "scale_length_m must be positive"),
                           ({"east_mps": "x"}, r"\[wind\] east_mps must be a finite number")):
        with pytest.raises(AirframeError, match=message) as info:
            scenario_from_dict(_with_wind(**table))
        assert "\n" not in str(info.value)


def test_zero_wind_is_still_air_to_the_bit(clean_flight) -> None:
    s = reference_scenario()
    calm = dataclasses.replace(s.manoeuvre, wind=Wind())
    flight = simulate(s.airframe, s.coefficient_vector, calm, NoNoise(), rng=0)
    for channel in clean_flight.channels:
        np.testing.assert_array_equal(flight[channel], clean_flight[channel], err_msg=channel)


def test_a_steady_wind_flight_records_the_air_relative_angles(tmp_path) -> None:
    s = reference_scenario()
    steady = (3.0, 4.0, 0.0)
    windy = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=steady))
    flight = simulate(s.airframe, s.coefficient_vector, windy, NoNoise(), rng=0)
    x = flight.states()
    body = Rotation.from_euler("ZYX", x[:, [8, 7, 6]]).inv().apply(steady)
    air = x[:, :3] - body
    np.testing.assert_allclose(flight["alpha"], np.arctan2(air[:, 2], air[:, 0]), atol=1e-14)
    np.testing.assert_allclose(flight["beta"], np.arcsin(air[:, 1] / np.linalg.norm(air, axis=1)),
                               atol=1e-14)
    assert flight.metadata["wind"]["north_mps"] == 3.0
    write_flight(flight, tmp_path / "windy.csv")
    back = read_flight(tmp_path / "windy.csv")  # the wind travels in the sidecar
    assert back.metadata["wind"] == flight.metadata["wind"]
    np.testing.assert_array_equal(back["beta"], flight["beta"])
    # the wind moved the flight: the inertial and air-relative angles differ by ~0.5 deg
    assert np.max(np.abs(flight["beta"] - np.arcsin(x[:, 1] / np.linalg.norm(x[:, :3], axis=1)))
                  ) > 1e-3


def test_a_turbulent_flight_is_seeded_and_refused_where_it_cannot_be_simulated() -> None:
    s = reference_scenario()
    gusty = dataclasses.replace(s.manoeuvre, window_s=(0.5, 0.7),
                                wind=Wind(turbulence_sd_mps=SD))
    a = simulate(s.airframe, s.coefficient_vector, gusty, NoNoise(), rng=5)
    b = simulate(s.airframe, s.coefficient_vector, gusty, NoNoise(), rng=5)
    c = simulate(s.airframe, s.coefficient_vector, gusty, NoNoise(), rng=6)
    np.testing.assert_array_equal(a["az1"], b["az1"])
    assert np.max(np.abs(a["az1"] - c["az1"])) > 0.1  # other gusts, other loads
    assert a.metadata["seed"] == 5 and a.metadata["wind"]["turbulence_sd_mps"] == SD
    with pytest.raises(AirframeError, match="turbulence needs the simulation's random"):
        simulate_truth(s.airframe, s.coefficient_vector, gusty)
    delayed = dataclasses.replace(gusty, delay_s=0.001)
    with pytest.raises(AirframeError, match="latched relay only"):
        simulate(s.airframe, s.coefficient_vector, delayed, NoNoise(), rng=5)
