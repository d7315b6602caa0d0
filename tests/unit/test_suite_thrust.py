"""Thrust in the sensor-suite simulator (issue 25): the flight computer's IMU sees the motor.

References: the suite's axial accelerometer on a noise-free, error-free board against the
closed form ``(T - D) / m - (q^2 + r^2) x1`` (thrust and mass from the curve's own points
by ``numpy.interp``, drag ``D = -rho V^2 S Cx / 2`` from the truth's speed, the lever arm's
centripetal term at the triad's position), drag-free (``Cx = 0``: ``T / m``) and with drag;
and the axial-drag fit of the burnout's axial-only log across the burn: with the curve a
success with Cx within 3 se, without it (thrust 0 in the model) not a success.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import tomllib
from pathlib import Path

import numpy as np
import pytest

from aeroid.errors import EstimatorError
from aeroid.estimation import make_estimator
from aeroid.flights import SensorSuite, load_scenario, simulate_suite
from aeroid.model import NAMES, density

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "studies" / "scenarios" / "rocket_burnout.toml"
#: The closed form and the suite evaluate the same arithmetic in another order: 1e-12 of
#: the 66 m/s^2 thrust acceleration, with margin (measured 1.4e-14).
CLOSED_FORM_ATOL_MPS2 = 1e-10
#: An error-free, noise-free board: the truth's specific force exactly.
CLEAN = dict(imu_rate_hz=100.0, gnss_rate_hz=10.0, baro_rate_hz=0.0, ins_rate_hz=0.0,
             fin_rate_hz=0.0, accel_bias_mps2=(0.0, 0.0), gyro_bias_radps=(0.0, 0.0),
             scale_factor=(0.0, 0.0), accel_noise_mps2=0.0, gyro_noise_radps=0.0)
#: The fitted Cx within this many of its standard errors (seed 3: 0.6, measured).
WITHIN_SE = 3.0


def _curve_points() -> dict:
    return tomllib.loads(SCENARIO.read_text())["thrust_curve"]


@pytest.mark.parametrize("cx", [0.0, -0.45])
def test_axial_specific_force_is_thrust_minus_drag_over_mass(cx) -> None:
    scenario = load_scenario(SCENARIO)
    coefficients = np.zeros(len(NAMES))  # no lateral force or moment: Cx alone
    coefficients[NAMES.index("Cx")] = cx
    sim = simulate_suite(scenario.airframe, coefficients, scenario.manoeuvre,
                         SensorSuite(**CLEAN), rng=0)
    truth, airframe = sim.truth, scenario.airframe
    t = truth["t"]
    points = _curve_points()
    start, end = points["burn_s"]
    clock = t - points["origin_s"]
    thrust = np.where((t >= start) & (t <= end),
                      np.interp(clock, points["time_s"], points["thrust_N"]), 0.0)
    mass = np.interp(np.clip(t, start, end) - points["origin_s"], points["time_s"],
                     points["mass_kg"])
    speed2 = truth["u"] ** 2 + truth["v"] ** 2 + truth["w"] ** 2
    drag = -0.5 * density(airframe.altitude_m) * speed2 * airframe.area_m2 * cx
    x1 = airframe.accel_positions[0, 0]
    expected = (thrust - drag) / mass - (truth["q"] ** 2 + truth["r"] ** 2) * x1
    assert np.any(thrust > 600.0) and np.any(thrust == 0.0)  # the burn and the coast
    np.testing.assert_allclose(truth["thrust"], thrust, rtol=0, atol=1e-12)
    np.testing.assert_allclose(truth["mass"], mass, rtol=1e-15)
    np.testing.assert_allclose(sim.log["imu"].channels["ax1"], expected, rtol=0,
                               atol=CLOSED_FORM_ATOL_MPS2)
    assert "thrust curve of 6 points" in sim.log.metadata["thrust"]


@pytest.fixture(scope="module")
def burn_log():
    spec = importlib.util.spec_from_file_location(
        "make_axial_log", ROOT / "examples" / "make_axial_log.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    scenario = load_scenario(SCENARIO)
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         SensorSuite(**example.FLIGHT_COMPUTER), rng=3)
    return example.axial_only(sim.log), float(scenario.coefficient_vector[NAMES.index("Cx")])


def test_axial_drag_across_the_burn_with_the_curve_fits_and_without_is_refused(
        burn_log) -> None:
    log, cx = burn_log
    with_curve = make_estimator("axial-drag", {}).fit(log, rng=1)
    assert with_curve.success, with_curve.message
    assert abs(with_curve.theta[0] - cx) < WITHIN_SE * with_curve.stderr[0]
    assert with_curve.info["fit_check"]["passed"]
    assert any("inside the burn" in n for n in with_curve.info["notes"])
    without = dataclasses.replace(log, airframe=log.airframe.replace(thrust_curve=None))
    result = make_estimator("axial-drag", {}).fit(without, rng=1)
    assert not result.success
    assert result.info["fit_check"]["ratio"]["accel"] > 10.0  # the thrust it lacks


def test_a_burn_without_mass_or_with_a_mass_sd_is_refused(burn_log) -> None:
    log, _ = burn_log
    curve = log.airframe.thrust_curve
    massless = dataclasses.replace(curve, mass_kg=None)
    for airframe, match in [
            (log.airframe.replace(thrust_curve=massless), "has no mass along the burn"),
            (log.airframe.replace(mass_sd_kg=0.3), "not built")]:
        with pytest.raises(EstimatorError, match=match) as info:
            make_estimator("axial-drag", {}).fit(dataclasses.replace(log, airframe=airframe),
                                                 rng=1)
        assert "\n" not in str(info.value)
