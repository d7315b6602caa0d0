"""Consider re-fits started from the fit's own estimate (output-error's ``warm_started``).

References: F = m a (in a coast the force coefficients, and a Cx table's points, are
proportional to the mass: d theta / d m = theta / m exactly, whatever the noise, since a
mass change is absorbed by scaling them; the moments' terms do not move), and the re-fits
started from the prior (``warm_start=False``), which reach the same optimum where they
converge.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from aeroid.errors import EstimatorError
from aeroid.estimation import consider_covariance, make_estimator
from aeroid.flights import (
    GaussianNoise,
    PaperNoise,
    load_scenario,
    record_flight,
    simulate_scenario,
    simulate_truth,
)
from aeroid.model import TableSpec

MACH_SWEEP = Path(__file__).parents[2] / "studies" / "scenarios" / "mach_sweep.toml"
#: Output-error's re-fits stop at its Gauss-Newton tolerance (1e-3 sd per step): the
#: warm and the cold re-fits' ends, each within that of the optimum, differ by a few
#: 1e-3 of a standard error; S is their difference over 2 sd of the mass, so S x sd (the
#: share) agrees to this many standard errors of the coefficient.
SAME_OPTIMUM_SE = 0.01
#: The closed form S = theta / m, relative: the re-fits' tolerance over theta's size
#: (measured 3e-7 on the noise-free coast, test_consider.py's OE_RTOL 1e-5).
CLOSED_FORM_RTOL = 1e-4


def _forces(names):
    return [j for j, n in enumerate(names) if n.startswith(("Cx", "Cz"))]


@pytest.fixture(scope="module")
def noisy_coast():
    scenario = load_scenario(None)
    airframe = scenario.airframe.replace(thrust_n=0.0, mass_sd_kg=2.1)  # 3 % of 70 kg
    return simulate_scenario(dataclasses.replace(scenario, airframe=airframe), PaperNoise(),
                             rng=4)


@pytest.fixture(scope="module")
def table_coast():
    """The first 4 s of the Mach sweep (a coast, 60 kg) with Cx and Cmq as Mach tables."""
    scenario = load_scenario(MACH_SWEEP)
    manoeuvre = dataclasses.replace(scenario.manoeuvre, window_s=(0.5, 4.5))
    truth = simulate_truth(scenario.airframe, scenario.coefficient_vector, manoeuvre,
                           tables=scenario.tables)
    flight = record_flight(scenario.airframe, scenario.coefficient_vector, manoeuvre, truth,
                           GaussianNoise(), rng=0, tables=scenario.tables)
    knots = (1.65, 1.925, 2.2)  # the truth's tables (Cx, Cmq) within the window's Mach
    spec = TableSpec((("Cx", knots), ("Cmq", knots)))
    return dataclasses.replace(flight, airframe=flight.airframe.replace(
        tables=spec, mass_sd_kg=1.8))


def _check_warm_against_cold_and_closed_form(flight):
    estimator = make_estimator("output-error", {})
    result = estimator.fit(flight, rng=0)
    assert result.success, result.message
    warm = result.consider
    assert warm.started == "the estimate" and warm.refit_messages == ()
    assert "re-fits at +-1 sd started from the estimate" in warm.describe()
    cold = consider_covariance(estimator, flight, dataclasses.replace(
        result, stderr=warm.stderr_without, covariance=warm.covariance_without),
        rng=0, warm_start=False)
    assert cold.started == "the prior" and cold.refit_messages == ()
    sd, own = warm.sd[0], warm.stderr_without
    np.testing.assert_array_less(np.abs(warm.sensitivity[:, 0] - cold.sensitivity[:, 0]) * sd,
                                 SAME_OPTIMUM_SE * own + 1e-300)
    mass = flight.airframe.mass_kg
    forces = _forces(result.names)
    np.testing.assert_allclose(warm.sensitivity[forces, 0], result.theta[forces] / mass,
                               rtol=CLOSED_FORM_RTOL)
    others = [j for j in range(len(result.names)) if j not in forces]
    assert np.all(np.abs(warm.sensitivity[others, 0]) * sd <= SAME_OPTIMUM_SE * own[others])
    return result


def test_warm_refits_of_nine_coefficients_reach_the_cold_optimum_and_f_equals_ma(noisy_coast):
    result = _check_warm_against_cold_and_closed_form(noisy_coast)
    assert result.consider.to_json_dict()["started"] == "the estimate"


def test_warm_refits_of_a_table_fit_reach_the_cold_optimum_and_f_equals_ma(table_coast):
    result = _check_warm_against_cold_and_closed_form(table_coast)
    assert [n for n in result.names if n.startswith("Cx")] == ["Cx@M1.65", "Cx@M1.925",
                                                              "Cx@M2.2"]


def test_a_warm_start_of_another_length_is_a_failed_start_not_a_wrong_one(noisy_coast):
    estimator = make_estimator("output-error", {})
    result = estimator.fit(noisy_coast, rng=0)
    short = dataclasses.replace(result, info={**result.info,
                                              "parameters": result.info["parameters"][:-1]})
    refit = estimator.warm_started(short).fit(noisy_coast, rng=0)
    assert not refit.success
    assert "the previous estimate has" in refit.message


def test_warm_start_true_without_the_methods_own_refuses_a_table_fit(table_coast):
    estimator = make_estimator("equation-error", {})
    result = estimator.run(table_coast, np.random.default_rng(0))
    with pytest.raises(EstimatorError, match="nine-coefficient prior.*\\[tables\\]"):
        consider_covariance(estimator, table_coast, result, rng=0, warm_start=True)
    cold = consider_covariance(estimator, table_coast, result, rng=0)
    assert cold.started == "the prior"


def test_the_warm_start_is_a_field_but_no_option(noisy_coast):
    """``start_parameters`` is set by ``warm_started`` on the method's own class and is no
    option: not in options(), option_names() or the option list, refused by from_options
    in one line; the warm estimator's options are the fit's."""
    estimator = make_estimator("output-error", {"max_iterations": 30})
    cls = type(estimator)
    assert "start_parameters" not in cls.option_names()
    assert "start_parameters" not in [o.name for o in cls.describe_options()]
    with pytest.raises(EstimatorError, match="start_parameters") as info:
        make_estimator("output-error", {"start_parameters": [0.0]})
    assert "\n" not in str(info.value)
    parameters = np.arange(1.0, 5.0)
    result = dataclasses.replace(estimator.fit(noisy_coast, rng=0),
                                 info={"parameters": parameters})
    warm = estimator.warm_started(result)
    assert type(warm) is cls and warm.start_parameters == (1.0, 2.0, 3.0, 4.0)
    assert warm.options() == estimator.options()
    again = warm.warm_started(dataclasses.replace(result, info={"parameters": parameters * 2}))
    assert type(again) is cls and again.start_parameters == (2.0, 4.0, 6.0, 8.0)
    assert estimator.warm_started(dataclasses.replace(
        result, info={"parameters": np.array([1.0, np.nan])})) is None
