"""A reconstruction's flight carries the sd of its states: who uses it, who says it does not.

The filters start from the reconstruction's sd of u, v, w and the Euler angles (not the
noise level of the smoothed channels, which is far smaller); the methods that take the
states as exact (equation-error, the PSO methods) say so in a warning; a flight that is
not a reconstruction's gets neither.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aeroid.estimation import make_estimator
from aeroid.flights import reference_scenario, simulate_suite
from aeroid.model import STATE_NAMES
from aeroid.reconstruction import reconstruct
from baselines._common import reconstruction_sd

NAMES = ("u", "v", "w", "phi", "theta", "psi")


@pytest.fixture(scope="module")
def rec_flight():
    scenario = reference_scenario()
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         rng=np.random.default_rng(5))
    rec = reconstruct(sim.log)
    return rec, rec.to_flight()


def _exact_warning(result):
    return [w for w in result.warnings if "takes them as exact" in w]


def test_the_filters_start_from_the_reconstructions_sd(rec_flight):
    rec, flight = rec_flight
    first = rec.table.iloc[0]
    expected = np.array([first[f"sd_{n}"] for n in NAMES])
    np.testing.assert_array_equal(reconstruction_sd(flight), expected)
    setup = make_estimator("ekf", {}).setup(flight)
    sd0 = np.sqrt(np.diag(setup.P0))
    rows = [STATE_NAMES.index(n) for n in NAMES]  # the filter's state starts with the model's
    np.testing.assert_allclose(sd0[rows], expected, rtol=1e-12)
    # an option given still wins
    setup = make_estimator("ekf", {"initial_velocity_sd_mps": 0.5}).setup(flight)
    np.testing.assert_allclose(np.sqrt(np.diag(setup.P0))[:3], 0.5, rtol=1e-12)


def test_methods_that_take_the_states_as_exact_say_so(rec_flight):
    _, flight = rec_flight
    result = make_estimator("equation-error", {}).fit(flight, rng=0)
    assert len(_exact_warning(result)) == 1
    assert result.estimator in _exact_warning(result)[0]


def test_no_warning_on_a_flight_that_is_not_a_reconstruction(rec_flight):
    _, flight = rec_flight
    plain = dataclasses.replace(flight, metadata={
        k: v for k, v in flight.metadata.items() if k != "initial_state_sd"})
    assert reconstruction_sd(plain) is None
    assert not _exact_warning(make_estimator("equation-error", {}).fit(plain, rng=0))
