"""The coast mass the airframe file does not know (``[initial_state] mass_scale``).

Reference: F = m a. In a coast the truth flown at ``s`` times the file's mass has the
same aerodynamic force at the same state but ``1/s`` the acceleration; fitted with the
file's mass, equation-error (a regression of m a on the regressors) recovers every force
coefficient times ``1/s`` exactly, and the moments as they are.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aeroid.errors import AirframeError
from aeroid.estimation import make_estimator
from aeroid.flights import (
    NoNoise,
    SensorSuite,
    load_scenario,
    simulate_scenario,
    simulate_suite,
)
from aeroid.model import NAMES, dumps_toml, reference_scenario_data

FORCES = [j for j, n in enumerate(NAMES) if n.startswith(("Cx", "Cz"))]
MOMENTS = [j for j, n in enumerate(NAMES) if j not in FORCES]
#: Equation-error on a noise-free flight at the file's own mass misses the truth by up to
#: 3.2e-5 relative (Cl0 0.0410013, Czq -172.002: measured on the clean coast); so 1e-4,
#: 200 times below the 2 % a mass not flown at its scale would show.
EE_RTOL = 1e-4
SCALE = 1.02


def _scenario_file(tmp_path, **initial_state):
    data = reference_scenario_data()
    data["airframe"]["thrust_N"] = 0.0  # a coast
    data.pop("noise")  # optional; a nested table the writer does not write
    data["initial_state"].update(initial_state)
    path = tmp_path / "s.toml"
    path.write_text(dumps_toml(data))
    return path


def test_mass_scale_is_read_and_flown_with_the_file_mass_kept(tmp_path):
    scenario = load_scenario(_scenario_file(tmp_path, mass_scale=SCALE))
    assert scenario.manoeuvre.mass_scale == SCALE
    assert "mass_scale" in scenario.manoeuvre.describe()
    assert "mass_scale" not in load_scenario(None).manoeuvre.describe()  # fingerprints
    flight = simulate_scenario(scenario, NoNoise(), rng=0)
    assert flight.airframe.mass_kg == 70.0
    assert flight.metadata["true_mass_kg"] == pytest.approx(70.0 * SCALE, rel=1e-15)
    result = make_estimator("equation-error", {}).fit(flight, rng=0)
    truth = flight.true_coefficients
    np.testing.assert_allclose(result.theta[FORCES], truth[FORCES] / SCALE, rtol=EE_RTOL)
    np.testing.assert_allclose(result.theta[MOMENTS], truth[MOMENTS], rtol=EE_RTOL)


def test_suite_log_is_flown_with_the_scaled_mass():
    """A sensor suite without accelerometer errors logs, at its first sample (the same
    initial state), the nominal flight's specific force over the scale: F / (s m) (triad 1
    at the c.g.: no angular-acceleration term, which the mass does not scale)."""
    scenario = load_scenario(None)
    coast = scenario.airframe.replace(thrust_n=0.0, accel1_position_m=(0.0, 0.0, 0.0))
    manoeuvre = dataclasses.replace(scenario.manoeuvre, window_s=(0.0, 0.05))
    suite = SensorSuite(accel_bias_mps2=(0.0, 0.0), scale_factor=(0.0, 0.0),
                        accel_noise_mps2=0.0)
    first = []
    for scale in (1.0, SCALE):
        sim = simulate_suite(coast, scenario.coefficient_vector,
                             dataclasses.replace(manoeuvre, mass_scale=scale), suite, rng=0)
        imu = sim.log.groups["imu"]
        first.append(np.array([imu.channels[c][0] for c in ("ax1", "ay1", "az1")]))
    np.testing.assert_allclose(first[1], first[0] / SCALE, rtol=1e-12)


@pytest.mark.parametrize(("value", "message"), [
    (0.0, "mass_scale must be in 0.5..2"),
    (3.0, "mass_scale must be in 0.5..2 (true mass / the airframe's mass_kg), got 3"),
    ("x", "mass_scale"),
])
def test_bad_mass_scale_is_one_line(tmp_path, value, message):
    path = _scenario_file(tmp_path, mass_scale=value)
    with pytest.raises(AirframeError) as info:
        load_scenario(path)
    assert "\n" not in str(info.value)
    assert message in str(info.value)
