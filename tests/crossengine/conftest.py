"""Session fixtures: JSBSim flights, made once per test run (treat them as read-only).

* ``climb``: the default flight (``FlightConfig()``), noise-free: ``(Flight, Truth)``.
* ``climb_noisy``: the same flight with aeroid's default Gaussian IMU noise, seed
  :data:`NOISE_SEED`.
* ``climb_delayed``: the flight with a 1 ms actuator delay, noise-free.
"""

from __future__ import annotations

import dataclasses

import pytest

from aeroid.flights import GaussianNoise

from .jsbsim_flight import FlightConfig, make_flight  # imports jsbsim only when flying

NOISE_SEED = 1
#: Actuator delay of ``climb_delayed`` [s] (16 frames at 16 kHz).
DELAY_S = 0.001


@pytest.fixture(scope="session")
def climb():
    """The default JSBSim flight, noise-free."""
    return make_flight(FlightConfig())


@pytest.fixture(scope="session")
def climb_noisy():
    """The default JSBSim flight with Gaussian IMU noise (0.05 m/s^2, 0.005 rad/s)."""
    return make_flight(FlightConfig(), noise=GaussianNoise(), rng=NOISE_SEED)


@pytest.fixture(scope="session")
def climb_delayed():
    """The default JSBSim flight with a :data:`DELAY_S` actuator delay, noise-free."""
    return make_flight(dataclasses.replace(FlightConfig(), name="xe_delayed",
                                           fin_delay_s=DELAY_S))
