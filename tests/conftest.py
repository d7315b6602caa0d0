"""Shared fixtures: the reference scenario and its simulated flights.

The flights are session-scoped (simulated once per test run): treat them as read-only
(``flight["p"]`` returns a copy; do not modify ``flight.data`` in place).

* ``reference_scenario``: the embedded reference scenario (``reference-scenario.toml``).
* ``clean_flight``: its noise-free flight (t = 5..6 s, 501 samples at 500 Hz).
* ``paper_flight``: the same flight with the paper's noise (eq. 43, xi = 0.05 on the
  accelerations and rates, 0.1 on the estimator's sensor positions), seed 1.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from aeroid.flights._flight import Flight
from aeroid.flights._noise import NoNoise, PaperNoise
from aeroid.flights._scenario import Scenario, load_scenario
from aeroid.flights._simulate import simulate_scenario
from aeroid.model._coefficients import nominal

DATA_DIR = Path(__file__).parent / "data"
#: Seed of the ``paper_flight`` fixture.
PAPER_FLIGHT_SEED = 1


@pytest.fixture(scope="session")
def reference_scenario() -> Scenario:
    """The embedded reference scenario."""
    return load_scenario(None)


@pytest.fixture(scope="session")
def clean_flight(reference_scenario: Scenario) -> Flight:
    """The reference scenario's noise-free flight (true sensor positions)."""
    return simulate_scenario(reference_scenario, NoNoise(), rng=0)


#: The prior of ``prior_off_flight``: each coefficient 20 % off, alternating sign.
PRIOR_FACTOR = np.array([1.2, 0.8, 1.2, 0.8, 1.2, 0.8, 1.2, 0.8, 1.2])


@pytest.fixture(scope="session")
def prior_off_flight(clean_flight: Flight) -> Flight:
    """The noise-free flight with an airframe prior 20 % off the truth (alternating sign):
    estimators that start from the prior must travel to the truth."""
    prior = tuple(nominal() * PRIOR_FACTOR)
    return dataclasses.replace(clean_flight,
                               airframe=clean_flight.airframe.replace(prior=prior))


@pytest.fixture(scope="session")
def paper_flight(reference_scenario: Scenario) -> Flight:
    """The reference scenario's flight with the paper's noise, seed 1."""
    return simulate_scenario(reference_scenario, PaperNoise(), rng=PAPER_FLIGHT_SEED)


@pytest.fixture(scope="session")
def reference_csv_path() -> Path:
    """Path of the independent reference flight (``tests/data/reference-flight-clean.csv``)."""
    return DATA_DIR / "reference-flight-clean.csv"


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels() -> None:
    """Compile the numba kernels once before any test (as on a warm install).

    On a fresh checkout or after an edit of the equations the first command compiles them
    and says so (``aeroid: compiling the numba kernel ...``, tested on its own in
    ``test_cli_compile_notice.py``); without this, the CLI tests that assert a single line of
    output passed or failed by the order the tests ran in (a fresh clone running only
    ``tests/integration`` failed 16 of them). The compilation happens once per test run
    either way; here it happens first.
    """
    import aeroid
    from aeroid.flights import model_constants
    from aeroid.model import HAVE_NUMBA, kernels_cached, propagate

    if not HAVE_NUMBA or kernels_cached():
        return
    # its own flight: modules override the clean_flight fixture at a narrower scope
    clean_flight = simulate_scenario(load_scenario(None), NoNoise(), rng=0)
    rng = np.random.default_rng(0)
    aeroid.make_estimator("eam-pso", {"n_particles": 4, "n_iterations": 1}).run(
        clean_flight, rng)  # weighted_cost, integrate_set
    theta = np.tile(nominal(), (2, 1))
    delta = clean_flight["delta"][:-1]
    state0 = clean_flight.states()[0]
    for parallel in (True, False):
        propagate(state0, theta, delta, clean_flight.dt, model_constants(clean_flight),
                  parallel=parallel)
