"""The consider re-fits get a larger iteration budget than the fit (REFIT_ITERATION_FACTOR).

Reference: an estimator whose estimate is the closed form F = m a (theta proportional to
the mass: d theta / d m = theta / m) only when its ``max_iterations`` reaches a budget it
is told; below it, it stops unconverged with a finite, wrong estimate, as output-error
does at its iteration limit.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest

import aeroid
from aeroid.estimation import EstimationResult, Estimator
from aeroid.estimation._consider import REFIT_ITERATION_FACTOR
from aeroid.flights import NoNoise, load_scenario, simulate_scenario

#: The fit needs 30 iterations; a re-fit off by one sd of the mass needs 150.
FIT_NEEDS, REFIT_NEEDS = 30, 150


@dataclass(frozen=True, kw_only=True)
class _SlowToConverge(Estimator):
    """theta = nominal * mass / 70 once converged; a re-fit (mass moved) needs more steps."""

    name: ClassVar[str] = "slow"
    max_iterations: int = 50

    def run(self, flight, rng):
        mass = flight.airframe.mass_kg
        needs = FIT_NEEDS if mass == 70.0 else REFIT_NEEDS
        converged = self.max_iterations >= needs
        theta = aeroid.nominal() * (mass / 70.0 if converged else 1.3)
        return EstimationResult(estimator=self.name, theta=theta,
                                stderr=np.full(theta.size, 1e-3), success=converged,
                                message="" if converged else "max_iterations reached")


@pytest.fixture(scope="module")
def coast():
    scenario = load_scenario(None)
    flight = simulate_scenario(scenario, NoNoise(), rng=0)
    return dataclasses.replace(flight, airframe=flight.airframe.replace(mass_sd_kg=1.4))


def test_refits_get_the_larger_budget_and_their_sensitivity_is_the_closed_form(coast):
    assert 50 * REFIT_ITERATION_FACTOR >= REFIT_NEEDS
    result = _SlowToConverge(max_iterations=50).fit(coast, rng=0)
    assert result.success and result.consider.refit_messages == ()
    np.testing.assert_allclose(result.consider.sensitivity[:, 0], result.theta / 70.0,
                               rtol=1e-12)


def test_a_refit_that_still_stops_is_named_in_the_result(coast):
    # 35 iterations: the fit converges, 35 x 4 = 140 < 150 leaves the re-fits unconverged
    result = _SlowToConverge(max_iterations=35).fit(coast, rng=0)
    assert result.success
    assert len(result.consider.refit_messages) == 2
    assert "2 ended unsuccessful, their estimates used" in result.consider.describe()


@dataclass(frozen=True, kw_only=True)
class _LightNeverConverges(_SlowToConverge):
    """As :class:`_SlowToConverge`, but a re-fit with the mass moved down never converges
    (it stops at its limit with the wrong 1.3 x nominal), one moved up converges at once."""

    def run(self, flight, rng):
        mass = flight.airframe.mass_kg
        converged = mass >= 70.0
        theta = aeroid.nominal() * (mass / 70.0 if converged else 1.3)
        return EstimationResult(estimator=self.name, theta=theta,
                                stderr=np.full(theta.size, 1e-3), success=converged,
                                message="" if converged else "max_iterations reached")


def test_one_unconverged_end_gives_way_to_the_other_ends_one_sided_difference(coast):
    # the central difference with the stopped end's estimate would be (theta(m + h) -
    # 1.3 nominal) / 2h, nothing like theta / m; the forward difference from the fit is
    # the closed form, exactly (theta is linear in m)
    result = _LightNeverConverges().fit(coast, rng=0)
    assert result.success
    np.testing.assert_allclose(result.consider.sensitivity[:, 0], result.theta / 70.0,
                               rtol=1e-12)
    (said,) = result.consider.refit_messages
    assert "max_iterations reached (not used: the one-sided difference at mass_kg +1 sd" in said
    assert "one-sided difference where one end did" in result.consider.describe()
