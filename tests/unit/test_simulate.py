"""The simulator against the independent reference flight and its own conventions."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from aeroid.flights._flight import REQUIRED_CHANNELS
from aeroid.flights._noise import NoNoise
from aeroid.flights._scenario import Manoeuvre
from aeroid.flights._simulate import simulate
from aeroid.model._actuator import FinLaw
from aeroid.model._coefficients import NAMES, as_dict
from aeroid.model._dynamics import air_data
from aeroid.model._inputs import Schedule
from aeroid.model._integrate import HAVE_NUMBA

#: Noise-free flight versus tests/data/reference-flight-clean.csv (an independent
#: implementation with the same conventions), relative to each channel's max |value|.
#: The CSV carries 11 significant digits and the measured agreement is 1.6e-11; 1e-8 is
#: far below a modelling difference (RK4 at 2 ms instead of 0.25 ms moves the states by
#: ~1e-5 of their range, test_integrate; a relay switch moved by one sample, by more).
REFERENCE_RTOL = 1e-8
#: numba (fast-math) versus numpy backends through the closed relay loop: rounding only
#: (no relay switch lands within 1e-9 of its threshold in this flight).
BACKEND_RTOL = 1e-10

#: aeroid channel -> reference CSV column (units in the name).
REFERENCE_COLUMNS = {
    "t": "t_s", "ax1": "a1x_mps2", "ay1": "a1y_mps2", "az1": "a1z_mps2", "ax2": "a2x_mps2",
    "ay2": "a2y_mps2", "az2": "a2z_mps2", "p": "p_radps", "q": "q_radps", "r": "r_radps",
    "delta": "delta_rad", "u": "u_mps", "v": "v_mps", "w": "w_mps", "alpha": "alpha_rad",
    "beta": "beta_rad", "phi": "phi_rad", "theta": "theta_rad", "psi": "psi_rad",
}


def test_clean_flight_matches_the_independent_reference(clean_flight, reference_csv_path):
    ref = pd.read_csv(reference_csv_path)
    assert sorted(ref.columns) == sorted(REFERENCE_COLUMNS.values())
    assert len(ref) == clean_flight.n_samples == 501
    assert set(REFERENCE_COLUMNS) == set(REQUIRED_CHANNELS)
    for channel, column in REFERENCE_COLUMNS.items():
        expected = ref[column].to_numpy()
        scale = np.max(np.abs(expected))
        error = np.max(np.abs(clean_flight[channel] - expected)) / scale
        assert error < REFERENCE_RTOL, f"{channel}: {error:.2e} of max |{column}|"


def test_window_and_sampling(clean_flight, reference_scenario):
    t = clean_flight.t
    assert t[0] == pytest.approx(5.0, abs=1e-12) and t[-1] == pytest.approx(6.0, abs=1e-12)
    np.testing.assert_allclose(np.diff(t), 1 / 500, rtol=1e-9)
    assert clean_flight.dt == pytest.approx(reference_scenario.manoeuvre.dt, rel=1e-12)
    clean_flight.validate()


def test_recorded_delta_is_the_relay_at_each_sample(clean_flight, reference_scenario):
    airframe, manoeuvre = reference_scenario.airframe, reference_scenario.manoeuvre
    relay = FinLaw(delta_max_rad=airframe.delta_max_rad,
                   command_amplitude=manoeuvre.command_amplitude,
                   command_phase_deg=manoeuvre.command_phase_deg)
    phi = clean_flight["phi"]
    np.testing.assert_array_equal(clean_flight["delta"], relay(phi))
    # the closed form of the relay law, sign(0) = +1
    switching = np.sin(2 * phi) + 0.5 * np.sin(phi + math.radians(60.0))
    expected = np.where(switching >= 0, 1.0, -1.0) * math.radians(8.0)
    np.testing.assert_array_equal(clean_flight["delta"], expected)
    switches = np.count_nonzero(np.diff(clean_flight["delta"]))
    assert switches == 32  # reference README: 32 relay switches in the window


def test_air_data_channels_and_flight_regime(clean_flight):
    speed, alpha, beta = air_data(clean_flight.states())
    np.testing.assert_array_equal(clean_flight["alpha"], alpha)
    np.testing.assert_array_equal(clean_flight["beta"], beta)
    # reference README: Mach 1.68-1.70 (a = 299.46 m/s), alpha and beta within ~2 deg,
    # roll rate 49.2 -> 53.0 rad/s
    mach = speed / 299.46
    assert mach.min() > 1.67 and mach.max() < 1.71
    assert np.degrees(np.abs(alpha)).max() < 2.5 and np.degrees(np.abs(beta)).max() < 2.5
    assert clean_flight["p"][0] == pytest.approx(49.2, abs=0.05)
    assert clean_flight["p"][-1] == pytest.approx(53.0, abs=0.05)


def test_metadata_records_the_truth(clean_flight, reference_scenario):
    meta = clean_flight.metadata
    assert meta["noise"] == {"model": "none"}
    assert meta["seed"] == 0
    assert meta["true_coefficients"] == as_dict(reference_scenario.coefficient_vector)
    np.testing.assert_array_equal(clean_flight.true_coefficients,
                                  reference_scenario.coefficient_vector)
    assert meta["true_accel_positions_m"] == reference_scenario.airframe.accel_positions.tolist()


def test_coefficients_as_mapping_and_generator_seed(reference_scenario, clean_flight):
    mapping = dict(zip(NAMES, reference_scenario.coefficient_vector, strict=True))
    flight = simulate(reference_scenario.airframe, mapping, reference_scenario.manoeuvre,
                      rng=np.random.default_rng(5))
    np.testing.assert_array_equal(flight.data.to_numpy(), clean_flight.data.to_numpy())
    assert flight.metadata["seed"] is None  # a Generator has no integer seed to record


@pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")
def test_numpy_backend_gives_the_same_flight(reference_scenario, clean_flight):
    short = Manoeuvre(window_s=(0.5, 0.6), truth_substeps=8)
    args = (reference_scenario.airframe, reference_scenario.coefficient_vector, short, NoNoise())
    fast = simulate(*args, rng=0, backend="numba")
    slow = simulate(*args, rng=0, backend="numpy")
    a, b = fast.data.to_numpy(), slow.data.to_numpy()
    scale = np.max(np.abs(b), axis=0)
    assert np.max(np.abs(a - b) / np.where(scale > 0, scale, 1)) < BACKEND_RTOL


def test_bad_coefficients_raise_one_line(reference_scenario):
    with pytest.raises(ValueError, match="missing"):
        simulate(reference_scenario.airframe, {"Cx": -1.0}, reference_scenario.manoeuvre)
    with pytest.raises(ValueError, match="last axis of length 9"):
        simulate(reference_scenario.airframe, np.zeros(8), reference_scenario.manoeuvre)


def test_latched_flight_records_its_knots_and_switches(clean_flight):
    meta = clean_flight.metadata
    t, delta = clean_flight.t, clean_flight["delta"]
    knots = Schedule(np.array(meta["delta_knots"]["t"]), np.array(meta["delta_knots"]["delta"]))
    hold = Schedule.hold(t, delta)
    fine = np.linspace(t[0], t[-1], 100_001)
    np.testing.assert_array_equal(knots.at(fine), hold.at(fine))
    # the relay switched at every change of the logged delta, and (from the sample before
    # the window) at the window's first sample
    change = np.concatenate([[0], np.flatnonzero(np.diff(delta)) + 1])
    assert meta["command_switches"] == {"t": t[change].tolist(), "delta": delta[change].tolist()}
    assert meta["actuator"] == {"command_amplitude": 0.5, "command_phase_deg": 60.0,
                                "delay_s": 0.0, "evaluation": "latched"}
