"""Shared fixtures: the reference scenario and its simulated flights.

The flights are session-scoped (simulated once per test run): treat them as read-only
(``flight["p"]`` returns a copy; do not modify ``flight.data`` in place).

* ``reference_scenario``: the embedded reference scenario (``reference-scenario.toml``).
* ``clean_flight``: its noise-free flight (t = 5..6 s, 501 samples at 500 Hz).
* ``paper_flight``: the same flight with the paper's noise (eq. 43, xi = 0.05 on the
  accelerations and rates, 0.1 on the estimator's sensor positions), seed 1.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
from collections.abc import Iterator
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


#: Why ``-n auto`` ran no workers (:func:`pytest_xdist_auto_num_workers`), for the header.
_IN_PROCESS_REASON = pytest.StashKey[str]()


@pytest.hookimpl(optionalhook=True)  # a pytest-xdist hook: no error without it
def pytest_xdist_auto_num_workers(config: pytest.Config) -> int | None:
    """``-n auto`` (pyproject's ``addopts``): one pytest-xdist worker per CPU this process
    may run on; none (the tests run in the pytest process itself, as with ``-n 0``) on a
    one-CPU machine or with ``-s``, whose prints xdist's workers would swallow (the header
    says so). ``PYTEST_XDIST_AUTO_NUM_WORKERS`` set: xdist's own rule reads it."""
    if os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS"):
        return None
    if config.getoption("capture") == "no":
        config.stash[_IN_PROCESS_REASON] = "-s"
        return 0
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # no sched_getaffinity (macOS, Windows)
        cpus = os.cpu_count() or 1
    if cpus == 1:
        config.stash[_IN_PROCESS_REASON] = "one CPU"
        return 0
    return cpus


def pytest_report_header(config: pytest.Config) -> str | None:
    """Say in one line when ``-n auto`` was turned into ``-n 0``."""
    reason = config.stash.get(_IN_PROCESS_REASON, None)
    if reason is None:
        return None
    return f"aeroid: -n auto with {reason}: the tests run in this process (-n 0)"


@contextlib.contextmanager
def _one_worker_at_a_time(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """Hold a lock shared by the pytest-xdist workers of this run (nothing without xdist).

    The workers' temporary directories share a parent made for the run; the lock file lives
    there. Where ``fcntl`` is missing (Windows) there is no lock: each worker compiles.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        fcntl = None
    if os.environ.get("PYTEST_XDIST_WORKER") is None or fcntl is None:
        yield
        return
    lock = tmp_path_factory.getbasetemp().parent / "aeroid-compile.lock"
    with open(lock, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Compile the numba kernels once before any test (as on a warm install).

    On a fresh checkout or after an edit of the equations the first command compiles them
    and says so (``aeroid: compiling the numba kernel ...``, tested on its own in
    ``test_cli_compile_notice.py``); without this, the CLI tests that assert a single line of
    output passed or failed by the order the tests ran in (a fresh clone running only
    ``tests/integration`` failed 16 of them). The compilation happens once per test run
    either way; here it happens first. Under pytest-xdist one worker compiles while the
    others wait, then find the kernels in numba's disk cache (no two workers writing the
    same cache files at once, no compilation repeated per worker).
    """
    with _one_worker_at_a_time(tmp_path_factory):
        _compile_kernels()


def _compile_kernels() -> None:
    """Compile the kernels :func:`compiled_kernels` needs, unless numba's cache has them."""
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
