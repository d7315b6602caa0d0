"""The consider re-fits keep the fit's holds and priors (``fit(holds=...)``).

Reference: a re-fit made by hand, the flight's mass moved by +-1 sd (and taken as exact)
and the same ``holds`` given to ``fit``: ``S = (theta(m + sd) - theta(m - sd)) / (2 sd)``.
A held coefficient is the same value in both re-fits, so its sensitivity is exactly zero
and it keeps no standard error (NaN), as without an sd. Before the fix the re-fits were
free: a held Cza moved with the mass (its S was Cza / m, F = m a) and got a standard error.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from table_truths import MACH_SWEEP, SWEEP_WINDOW_S, table_truth

from aeroid.estimation import consider_covariance, make_estimator
from aeroid.estimation._consider import refit_holds
from aeroid.flights import NoNoise, PaperNoise, load_scenario, record_flight, simulate_scenario
from aeroid.model import NAMES, TableSpec

#: Equation-error is a deterministic linear regression: the consider path's re-fits and
#: the hand-made ones are the same computation (measured equal to the last bit; 1e-12
#: leaves room for nothing but rounding).
SAME_RTOL = 1e-12
#: The mass's sd [kg] (3 % of the reference airframe's 70 kg).
MASS_SD = 2.1
CZA = NAMES.index("Cza")
CMQ = NAMES.index("Cmq")
#: The sweep's table knots (tests/unit/test_tables_holds.py: the truth's Cx and Cmq knots).
KNOTS = (1.65, 1.925, 2.2)


@pytest.fixture(scope="module")
def noisy_coast():
    scenario = load_scenario(None)
    scenario = dataclasses.replace(scenario, airframe=scenario.airframe.replace(thrust_n=0.0))
    flight = simulate_scenario(scenario, PaperNoise(), rng=4)
    return dataclasses.replace(flight, airframe=flight.airframe.replace(mass_sd_kg=MASS_SD))


def _moved(flight, step):
    a = flight.airframe
    return dataclasses.replace(flight, airframe=a.replace(mass_kg=a.mass_kg + step,
                                                          mass_sd_kg=0.0))


def _holds(flight):
    truth = flight.true_coefficients
    return {"hold": {"Cza": 1.2 * float(truth[CZA])},  # a wrong hold: it must stay held
            "prior": {"Cmq": (float(truth[CMQ]), 0.05 * abs(float(truth[CMQ])))}}


def test_held_coefficient_stays_held_in_the_refits(noisy_coast):
    est = make_estimator("equation-error", {})
    holds = _holds(noisy_coast)
    result = est.fit(noisy_coast, rng=0, holds=holds)
    assert result.success and result.held == holds["hold"]
    c = result.consider
    assert c.sensitivity[CZA, 0] == 0.0  # held in both re-fits
    assert np.isnan(result.stderr[CZA]) and np.isnan(c.stderr_without[CZA])
    assert np.all(np.isfinite(np.delete(result.stderr, CZA)))
    hand = [est.fit(_moved(noisy_coast, s), rng=0, holds=holds).theta
            for s in (MASS_SD, -MASS_SD)]
    by_hand = (hand[0] - hand[1]) / (2.0 * MASS_SD)
    np.testing.assert_allclose(c.sensitivity[:, 0], by_hand, rtol=SAME_RTOL, atol=0.0)
    share = by_hand**2 * MASS_SD**2
    free = [j for j in range(len(NAMES)) if j != CZA]
    np.testing.assert_allclose(result.stderr[free]**2,
                               c.stderr_without[free]**2 + share[free], rtol=1e-10)
    # the free re-fits (the defect) give another share: this test can tell them apart
    loose = [est.fit(_moved(noisy_coast, s), rng=0).theta for s in (MASS_SD, -MASS_SD)]
    by_loose = (loose[0] - loose[1]) / (2.0 * MASS_SD)
    assert abs(by_loose[CZA]) > 0.1 * abs(result.theta[CZA]) / 70.0
    assert not np.allclose(by_loose[free], by_hand[free], rtol=1e-3)


def test_output_error_refits_hold_too(noisy_coast):
    est = make_estimator("output-error", {})
    holds = {"hold": {"Cza": float(noisy_coast.true_coefficients[CZA])}}
    result = est.fit(noisy_coast, rng=0, holds=holds)
    assert result.success and result.consider.started == "the estimate"
    assert result.consider.sensitivity[CZA, 0] == 0.0
    assert np.isnan(result.stderr[CZA])


def test_airframe_holds_are_not_given_twice():
    """A passive fin's Czd, Cmd held at zero (on a Czd table: its points) are the
    airframe's: the re-fit's airframe declares them again, so they are not passed."""
    scenario, manoeuvre, parameters, truth = table_truth(
        MACH_SWEEP, SWEEP_WINDOW_S, {"Czd": 0.0, "Cmd": 0.0})
    flight = record_flight(scenario.airframe, parameters, manoeuvre, truth, NoNoise(), rng=0,
                           tables=scenario.tables)
    airframe = flight.airframe.replace(
        tables=TableSpec((("Cx", KNOTS), ("Cmq", KNOTS), ("Czd", (1.65, 2.2)))),
        fin="passive", delta_max_deg=None, fin_law=None, mass_sd_kg=MASS_SD)
    data = flight.data.copy()
    data["delta"] = 0.0
    flight = dataclasses.replace(flight, data=data, airframe=airframe)
    value = dict(zip(scenario.tables.parameter_names(), parameters, strict=True))["Cx@M1.925"]
    est = make_estimator("equation-error", {})
    result = est.fit(flight, rng=0, holds={"hold": {"Cx@M1.925": value}})
    assert set(result.held) == {"Cx@M1.925", "Czd@M1.65", "Czd@M2.2", "Cmd"}
    spec = refit_holds(flight, result)
    assert spec is not None and spec.held == {"Cx@M1.925": value} and spec.priors == {}
    assert refit_holds(flight, dataclasses.replace(result, held={}, priors={})) is None
    # its fit check refuses the noise-free sweep on the roll moment (test_tables_holds.py),
    # so fit() adds no share: the re-fits are made here, with the Czd table held twice
    # they would be refused ("declared twice")
    c = consider_covariance(est, flight, result, rng=0)
    held = [result.names.index(n) for n in result.held]
    np.testing.assert_array_equal(c.sensitivity[held, 0], 0.0)
    hand = [est.fit(_moved(flight, s), rng=0, holds={"hold": {"Cx@M1.925": value}}).theta
            for s in (MASS_SD, -MASS_SD)]
    np.testing.assert_allclose(c.sensitivity[:, 0], (hand[0] - hand[1]) / (2.0 * MASS_SD),
                               rtol=SAME_RTOL, atol=0.0)
