"""Table fits of a flight in non-ISA air (ISA + 20 K, issue 23): with the logged air
temperature they recover the table; assuming the ISA their points are the truth at knots
shifted in Mach by the closed-form ratio of the speeds of sound."""

from __future__ import annotations

import dataclasses
import logging
import math
from pathlib import Path

import numpy as np
import pytest

import aeroid
from aeroid.flights import NoNoise, make_flight, record_flight, scenario_from_dict, simulate_truth
from aeroid.model import TableSpec, read_toml

MACH_SWEEP = Path(__file__).parents[2] / "studies" / "scenarios" / "mach_sweep.toml"
#: The air: ISA + 20 K at the sweep's 5 km (255.65 K).
DELTA_T_K = 20.0
T_ISA_K = 255.65
#: True Cx and Cmq: linear in Mach over the whole sweep (rows at Mach 1.0 and 2.5), so the
#: truth at any Mach, and at a knot shifted in Mach, is a closed form.
TRUE_ROWS = {"Cx": ((1.0, -1.2), (2.5, -0.8)), "Cmq": ((1.0, -2600.0), (2.5, -1850.0))}
#: The fits' knots: around the first 2 s (true Mach 1.91-2.11, ISA-assumed 1.99-2.19).
KNOTS = (1.85, 2.25)
#: Output-error integrating with the truth's RK4 step on noise-free data: rounding and
#: the solver's tolerance (as tests/unit/test_tables_fits.py's OE_TOL).
OE_TOL = 1e-6
#: Equation-error's axial points: Cx regresses on the axial force with no derivative.
EE_AXIAL_TOL = 1e-8


def _true(name: str, mach: float) -> float:
    (m0, c0), (m1, c1) = TRUE_ROWS[name]
    return c0 + (c1 - c0) * (mach - m0) / (m1 - m0)


@pytest.fixture(scope="module")
def warm_flights():
    data = read_toml(MACH_SWEEP)
    data["coefficients"].update({n: [list(r) for r in rows] for n, rows in TRUE_ROWS.items()})
    data["recording"].update(window_s=[0.5, 2.5], truth_rk4_substeps=4)
    data["air"] = {"delta_T_K": DELTA_T_K, "log_temperature": True}
    scenario = scenario_from_dict(data, source="warm-sweep")
    truth = simulate_truth(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                           tables=scenario.tables)
    flight = record_flight(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                           truth, NoNoise(), rng=0, tables=scenario.tables)
    spec = TableSpec((("Cx", KNOTS), ("Cmq", KNOTS)))
    logged = dataclasses.replace(flight, airframe=flight.airframe.replace(tables=spec))
    channels = {c: logged[c] for c in logged.channels if c != "air_temperature"}
    isa = make_flight(channels, logged.airframe, dict(logged.metadata))
    return logged, isa, scenario


def _points(result) -> dict[str, float]:
    return {n: float(v) for n, v in zip(result.names, result.theta, strict=True) if "@M" in n}


def test_the_simulated_air_is_isa_plus_the_offset(warm_flights):
    logged, isa, scenario = warm_flights
    np.testing.assert_allclose(logged["air_temperature"], T_ISA_K + DELTA_T_K, rtol=1e-12)
    assert "air_temperature" not in isa.channels
    tables = aeroid.flights.flight_mach_tables(logged)
    assert tables.per_sample_temperature
    assert not aeroid.flights.flight_mach_tables(isa).per_sample_temperature
    ratio = math.sqrt((T_ISA_K + DELTA_T_K) / T_ISA_K)  # a_true / a_ISA
    np.testing.assert_allclose(
        aeroid.flights.flight_mach_tables(isa).mach(isa.states()),
        ratio * tables.mach(logged.states(), logged["air_temperature"]), rtol=1e-12)


def test_output_error_with_the_temperature_recovers_and_isa_is_shifted(warm_flights, caplog):
    logged, isa, _ = warm_flights
    oe = aeroid.make_estimator("output-error", {"substeps": 4})
    with caplog.at_level(logging.INFO, logger="aeroid"):
        right = oe.fit(logged, rng=0)
    assert right.success, right.message
    assert any("speed of sound per sample from the logged air_temperature" in r.message
               for r in caplog.records)
    assert "per sample" in right.info["speed_of_sound"]
    for name, value in _points(right).items():
        coefficient, knot = name.split("@M")
        assert value == pytest.approx(_true(coefficient, float(knot)), rel=OE_TOL), name
    wrong = oe.fit(isa, rng=0)
    assert "ISA at [atmosphere] altitude_m = 5000 m" in wrong.info["speed_of_sound"]
    # assuming the ISA, Mach is a_true / a_ISA times the true one: the point at knot K
    # holds the truth at Mach K a_ISA / a_true (the knot shifted down in Mach)
    ratio = math.sqrt((T_ISA_K + DELTA_T_K) / T_ISA_K)
    for name, value in _points(wrong).items():
        coefficient, knot = name.split("@M")
        shifted = _true(coefficient, float(knot) / ratio)
        assert value == pytest.approx(shifted, rel=OE_TOL), name
        assert abs(value - _true(coefficient, float(knot))) > 100 * OE_TOL * abs(shifted)


def test_equation_error_with_the_temperature_recovers_and_isa_is_shifted(warm_flights):
    logged, isa, _ = warm_flights
    ee = aeroid.make_estimator("equation-error")
    ratio = math.sqrt((T_ISA_K + DELTA_T_K) / T_ISA_K)
    for flight, factor in ((logged, 1.0), (isa, ratio)):
        result = ee.run(flight, np.random.default_rng(0))
        for knot in KNOTS:
            value = _points(result)[f"Cx@M{knot:g}"]
            assert value == pytest.approx(_true("Cx", knot / factor), rel=EE_AXIAL_TOL), knot


def test_a_constant_fit_says_the_temperature_is_not_used(warm_flights):
    logged, _, _ = warm_flights
    plain = dataclasses.replace(logged, airframe=logged.airframe.replace(tables=None))
    result = aeroid.make_estimator("equation-error").fit(plain, rng=0)
    assert any("air_temperature: not used (the airframe has no [tables]" in w
               for w in result.warnings)


def test_windows_with_a_logged_temperature_are_refused(warm_flights):
    logged, _, _ = warm_flights
    windows = aeroid.flights.cut_windows(logged, [(0.5, 1.4), (1.6, 2.5)])
    with pytest.raises(aeroid.EstimatorError, match="air_temperature channel"):
        aeroid.make_estimator("equation-error").fit(windows)


def test_a_temperature_profile_in_time_is_flown_and_fitted_per_sample():
    # the air cools by 40 K over the 1 s window (the speed of sound by 7 %): the
    # simulator's stage-wise temperature and output-error's, interpolated between samples,
    # are one linear function of time, so the noise-free fit is exact
    data = read_toml(MACH_SWEEP)
    data["coefficients"].update({n: [list(r) for r in rows] for n, rows in TRUE_ROWS.items()})
    data["recording"].update(window_s=[0.5, 1.5], truth_rk4_substeps=4)
    data["air"] = {"temperature_K": [[0.0, 310.0], [1.5, 250.0]], "log_temperature": True}
    scenario = scenario_from_dict(data, source="cooling")
    flight = aeroid.flights.simulate_scenario(scenario, NoNoise(), rng=0)
    np.testing.assert_allclose(flight["air_temperature"], 310.0 - 40.0 * flight.t, rtol=1e-12)
    knots = (1.9, 2.4)
    flight = dataclasses.replace(flight, airframe=flight.airframe.replace(
        tables=TableSpec((("Cx", knots), ("Cmq", knots)))))
    mach = aeroid.flights.flight_mach_tables(flight).mach(flight.states(),
                                                          flight["air_temperature"])
    isa = aeroid.model.tables.mach_number(*flight.states()[:, :3].T, 320.5293)
    assert np.ptp(mach / isa) > 0.07  # sqrt(290 / 250) - 1 = 0.077 over the record
    result = aeroid.make_estimator("output-error", {"substeps": 4}).fit(flight, rng=0)
    assert result.success, result.message
    for name, value in _points(result).items():
        coefficient, knot = name.split("@M")
        assert value == pytest.approx(_true(coefficient, float(knot)), rel=OE_TOL), name


def test_the_filters_tabled_step_takes_mach_from_the_logged_temperature(warm_flights):
    # the EKF/UKF's augmented RK4 step (baselines._kalman_tables, built beside the
    # temperature) at the true table points carries each logged state to the next: the
    # simulator's truth (4 RK4 steps a sample, as here); Mach from the ISA misses it
    from baselines._kalman_tables import table_model

    logged, isa, scenario = warm_flights
    truth = dict(zip(scenario.tables.parameter_names(), scenario.coefficient_vector,
                     strict=True))
    misses = []
    for flight in (logged, isa):
        tables = aeroid.flights.flight_mach_tables(flight)
        p = np.array([_true(name.split("@M")[0], float(name.split("@M")[1]))
                      if "@M" in name else float(truth[name])
                      for name in tables.parameter_names()])
        model = table_model(flight, 4, tables)
        states = flight.states()
        scale = np.maximum(np.abs(states).max(axis=0), 1e-12)
        misses.append(max(float(np.max(np.abs(
            model.transition(np.concatenate([states[k], p]), k)[0][:states.shape[1]]
            - states[k + 1]) / scale)) for k in (0, 100, 300)))
    assert misses[0] <= OE_TOL, misses  # measured 0 (the same RK4 on the same inputs)
    assert misses[1] > 100 * OE_TOL, misses  # measured 2e-5 to 1e-4 of each state's range
