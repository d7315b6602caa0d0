"""Logged air-data angles: used by equation-error (option ``air_data``) or said ignored.

References: the air-relative velocity of a simulated windy flight (the simulator's own
wind, against the wind :func:`aeroid.estimation.air_data_wind` recovers from the logged
angles alone); the inertial fit on a still-air flight (identity); the fit check's verdict
on the inertial angles of a windy flight (a known-wrong input).
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np
import pytest

import aeroid
from aeroid import estimation as rc
from aeroid.errors import EstimatorError, FlightError
from aeroid.estimation import EstimationResult, Estimator
from aeroid.flights import NoNoise, Wind, simulate
from aeroid.model import equations
from baselines.equation_error import EquationErrorEstimator

#: A crosswind (east) across the reference flight's northward path: the airspeed differs
#: from the inertial speed only to second order (module aeroid/estimation/_air_data.py).
CROSSWIND = (0.0, 5.0, 0.0)
#: Rounding of the wind recovered from exact angles [m/s] (speeds ~500 m/s: 1e-13 relative).
WIND_ATOL = 1e-9
#: Noise-free crosswind flight with the logged angles: the airspeed is taken as the
#: inertial speed, off by the wind's component along the path (the path is not exactly
#: north: measured 0.027 % on the largest coefficient). 0.1 % leaves room for rounding and
#: is 100x below the inertial fit's error.
MEASURED_RTOL = 1e-3
#: The inertial angles on the same flight: off by 0.4 deg RMS; the fit is tens of % off.
INERTIAL_MIN_ERROR = 0.10
#: Regressors from the angles of u, v, w passed as "logged": the wind they imply is
#: rounding, so the regressors are those of still air to 1e-12 relative.
SAME_RTOL = 1e-12


@pytest.fixture(scope="module")
def crosswind_flight(reference_scenario):
    s = reference_scenario
    windy = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=CROSSWIND))
    return simulate(s.airframe, s.coefficient_vector, windy, NoNoise(), rng=0)


def test_the_recovered_wind_is_the_true_one_up_to_the_path(crosswind_flight) -> None:
    f = crosswind_flight
    wind = rc.air_data_wind(f)
    phi, theta, psi = f["phi"], f["theta"], f["psi"]
    # the logged angles fix the air velocity's direction, not its length: the recovered
    # wind differs from the true one along the air velocity only
    off = np.stack(equations.ned_to_body(phi, theta, psi, *(wind - CROSSWIND).T), axis=1)
    const = aeroid.model.constants(f.airframe)._replace(
        wind_n=CROSSWIND[0], wind_e=CROSSWIND[1], wind_d=CROSSWIND[2])
    air = np.stack(equations.air_velocity(aeroid.model.as_state(f.states()), const), axis=1)
    direction = air / np.linalg.norm(air, axis=1, keepdims=True)
    across = off - np.sum(off * direction, axis=1, keepdims=True) * direction
    assert np.max(np.abs(across)) < WIND_ATOL
    assert np.max(np.abs(off)) > 1e-3  # along the path it is not the true wind
    assert np.max(np.abs(wind[:, 1] - CROSSWIND[1])) < 0.1  # the crosswind is there


def test_measured_angles_recover_a_windy_flight_inertial_do_not(crosswind_flight,
                                                                caplog) -> None:
    f = crosswind_flight
    truth = f.metadata["true_coefficients"]
    truth = np.array([truth[n] for n in aeroid.NAMES])
    with caplog.at_level(logging.INFO, logger="aeroid"):
        measured = EquationErrorEstimator().fit(f)  # auto: the logged angles
    assert measured.success, measured.message
    assert measured.info["air_data"] == "measured"
    notices = [r.message for r in caplog.records if "logged alpha, beta" in r.message]
    assert len(notices) == 1 and "\n" not in notices[0]
    assert np.max(np.abs(measured.theta / truth - 1.0)) < MEASURED_RTOL
    assert not any("ignores" in w for w in measured.warnings)
    # the airspeed assumption said with its size: 2 / V per m/s along the path
    said = [w for w in measured.warnings if "airspeed taken as |u, v, w|" in w]
    assert len(said) == 1
    speed = np.mean(np.linalg.norm(f.states()[:, :3], axis=1))
    assert f"{200.0 / speed:.2g} %" in said[0]
    inertial = EquationErrorEstimator(air_data="inertial").fit(f)
    assert inertial.info["air_data"] == "inertial"
    assert not inertial.success  # the fit check refuses the known-wrong angles
    assert "does not fit" in inertial.message
    assert np.max(np.abs(inertial.theta / truth - 1.0)) > INERTIAL_MIN_ERROR
    one_step = EquationErrorEstimator(one_step=True).fit(f)  # the one-step form uses them too
    assert np.max(np.abs(one_step.theta / truth - 1.0)) < MEASURED_RTOL


def test_still_air_angles_are_the_inertial_ones(clean_flight) -> None:
    f = clean_flight
    assert not rc.has_air_data(f)
    # a log of 6 significant digits is still air, not air data
    rounded = {c: np.array([float(f"{x:.6g}") for x in f[c]])
               for c in ("u", "v", "w", "alpha", "beta")}
    assert not rc.has_air_data(dataclasses.replace(f, data=f.data.assign(**rounded)))
    auto = EquationErrorEstimator().fit(f)
    inertial = EquationErrorEstimator(air_data="inertial").fit(f)
    assert auto.info["air_data"] == "inertial"
    np.testing.assert_array_equal(auto.theta, inertial.theta)
    # the logged (here: inertial) angles through the wind path are still air
    wind = rc.air_data_wind(f)
    assert np.max(np.abs(wind)) < WIND_ATOL
    (_, _, still), = rc.regressor_blocks(f, block=f.n_samples)
    (_, _, through), = rc.regressor_blocks(f, block=f.n_samples, wind=wind)
    np.testing.assert_allclose(through, still, rtol=SAME_RTOL, atol=SAME_RTOL * np.abs(still).max())
    with pytest.raises(FlightError, match="air_data = 'measured'") as err:
        EquationErrorEstimator(air_data="measured").fit(f)
    assert "\n" not in str(err.value)


def test_a_bad_air_data_option_is_one_line() -> None:
    with pytest.raises(EstimatorError, match="air_data") as err:
        EquationErrorEstimator.from_options({"air_data": "probe"})
    assert "\n" not in str(err.value)
    assert "air_data" in [o.name for o in EquationErrorEstimator.describe_options()]


@dataclasses.dataclass(frozen=True, kw_only=True)
class _Truthful(Estimator):
    """A method that returns the flight's true coefficients (for the fit's own hooks)."""

    name = "truthful"
    description = "returns the true coefficients"

    def run(self, flight, rng):
        theta = np.array([flight.metadata["true_coefficients"][n] for n in aeroid.NAMES])
        return EstimationResult(estimator=self.name, theta=theta, stderr=None,
                                covariance=None, cost=0.0, success=True, message="",
                                n_evaluations=1, n_iterations=1, info={})


def test_other_methods_say_they_ignore_the_logged_angles(crosswind_flight,
                                                         clean_flight) -> None:
    warned = [w for w in _Truthful().fit(crosswind_flight).warnings if "ignores" in w]
    assert len(warned) == 1 and "\n" not in warned[0]
    assert "logged alpha, beta" in warned[0]
    assert not [w for w in _Truthful().fit(clean_flight).warnings if "ignores" in w]
    assert not Estimator.uses_air_data and EquationErrorEstimator.uses_air_data


def test_what_is_not_built_with_logged_angles_is_refused_in_one_line(crosswind_flight) -> None:
    f = crosswind_flight
    windows = aeroid.flights.Windows((f, f), ("a", "b"))
    with pytest.raises(EstimatorError, match="several windows are not built") as err:
        EquationErrorEstimator().fit(windows)
    assert "\n" not in str(err.value)
    assert EquationErrorEstimator(air_data="inertial").fit(windows).theta.shape == (
        len(aeroid.NAMES),)
    tables = aeroid.model.TableSpec((("Cx", (1.7,)),))
    tabled = dataclasses.replace(f, airframe=f.airframe.replace(tables=tables))
    with pytest.raises(EstimatorError, match=r"\[tables\] are not built") as err:
        EquationErrorEstimator().fit(tabled)
    assert "\n" not in str(err.value)
