"""Fits of a coefficient table in the total angle of attack (issue 23) on the reference flight
whose Cma varies by +-10 % across its 0.3-2.0 deg (studies/scenarios/alpha_table.toml)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from table_truths import ALPHA_TABLE, table_truth

import aeroid
from aeroid.errors import EstimatorError
from aeroid.flights import (
    GaussianNoise,
    NoNoise,
    Windows,
    cut_windows,
    load_scenario,
    record_flight,
)
from aeroid.model import TableSpec

SCENARIO = ALPHA_TABLE
#: Output-error on noise-free data integrates the same table the truth was simulated
#: with, but with 2 RK4 steps per 2 ms sample against the truth's 8 at a 60-90 rad/s roll
#: rate: measured 1.4e-6 relative on Czq (the table points 1e-7); 1e-5 leaves room for
#: another CPU's rounding and is 1e-3 of the noisy fit's standard errors.
OE_NOISE_FREE_TOL = 1e-5
#: Every fitted table point within this many of its standard errors of the truth (issue
#: 23). The constants are not asserted here: seed 0 puts Cx at 3.3 se in both fits (one
#: draw; over 20 seeds Cx's mean z is -0.11, sd 1.09: benchmarks/bench_mach_sweep.py
#: --scenario studies/scenarios/alpha_table.toml measures every parameter's coverage).
Z_LIMIT = 3.0
#: Output-error's standard error against the Cramer-Rao floor at the estimate: equal in
#: expectation; measured 0.96-1.02 on the Mach sweep. A 30 % band is far from a wrong
#: covariance (a factor 2 or sqrt(n)).
FLOOR_BAND = (0.7, 1.3)


@pytest.fixture(scope="module")
def flights():
    """The scenario's truth recorded noise-free and with the tactical IMU (seed 0)."""
    scenario, _, _, truth = table_truth(SCENARIO)
    out = [record_flight(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         truth, noise, rng=0, tables=scenario.tables)
           for noise in (NoNoise(), GaussianNoise())]
    values = dict(zip(scenario.tables.parameter_names(), scenario.coefficients, strict=True))
    return out, values


def test_output_error_recovers_a_noise_free_angle_table(flights):
    (clean, _), truth = flights
    result = aeroid.make_estimator("output-error").fit(clean, rng=0)
    assert result.success, result.message
    assert result.names == tuple(truth)
    for name, value in zip(result.names, result.theta, strict=True):
        assert value == pytest.approx(truth[name], rel=OE_NOISE_FREE_TOL), name


@pytest.mark.parametrize("method", ["output-error", "equation-error"])
def test_noisy_fit_holds_every_point_within_3_se(flights, method):
    (_, noisy), truth = flights
    result = aeroid.make_estimator(method).fit(noisy, rng=0)
    assert result.success, result.message
    z = (result.theta - np.array([truth[n] for n in result.names])) / result.stderr
    points = np.array(["@A" in n for n in result.names])
    assert points.sum() == 3
    assert np.all(np.abs(z[points]) < Z_LIMIT), dict(zip(result.names, z.round(2),
                                                          strict=True))
    floor = result.info["table_floor"]
    assert set(floor) == set(result.names)
    if method == "output-error":
        ratio = [s / floor[n] for n, s in zip(result.names, result.stderr, strict=True)
                 if "@A" in n]
        assert FLOOR_BAND[0] < min(ratio) and max(ratio) < FLOOR_BAND[1], ratio


def test_a_constant_cma_is_flagged_where_the_table_passes(flights):
    (_, noisy), _ = flights
    constant = dataclasses.replace(noisy, airframe=noisy.airframe.replace(tables=None))
    oe = aeroid.make_estimator("output-error")
    flagged = oe.fit(constant, rng=0)
    assert not flagged.success and "structure" in flagged.message, flagged.message
    assert oe.fit(noisy, rng=0).success


def test_knots_the_data_do_not_reach_are_refused_or_held_in_one_line(flights):
    (_, noisy), _ = flights
    ee = aeroid.make_estimator("equation-error")
    # 3 deg is beyond the data (0.4-2.1 deg) but its hat holds below it: only 5 is empty
    far = noisy.airframe.replace(tables=TableSpec((), None, (("Cma", (3.0, 5.0)),)))
    with pytest.raises(EstimatorError, match=r"no sample informs Cma@A5deg \(the flight "
                       r"spans the total angle of attack 0.\d+-2.\d+ deg\)"):
        ee.fit(dataclasses.replace(noisy, airframe=far), rng=0)
    narrow = noisy.airframe.replace(tables=TableSpec((), None, (("Cma", (0.5, 1.5)),)))
    result = ee.fit(dataclasses.replace(noisy, airframe=narrow), rng=0)
    assert any("below 0.5 and above 1.5 deg, beyond Cma's knots" in w for w in result.warnings)
    # held coefficients beside an angle table: tests/unit/test_tables_alpha_holds.py
    held = ee.fit(noisy, rng=0, holds={"hold": {"Cmd": -20.9}})
    assert held.success and held.held == {"Cmd": -20.9}


#: One window stacked once is the same least squares (tests/unit/test_tables_windows.py's).
EE_ONE_WINDOW_RTOL = 1e-10


def test_angle_tables_over_windows(flights):
    (_, noisy), truth = flights
    ee = aeroid.make_estimator("equation-error")
    one = ee.fit(cut_windows(noisy, ((5.0, 6.0),)), rng=0)
    np.testing.assert_allclose(one.theta, ee.fit(noisy, rng=0).theta, rtol=EE_ONE_WINDOW_RTOL)
    # two windows with a gap: counted knots span both windows' total angle together
    windows = cut_windows(noisy, ((5.0, 5.4), (5.6, 6.0)))
    counted = Windows(tuple(dataclasses.replace(f, airframe=f.airframe.replace(
        tables=TableSpec((), None, (("Cma", 3),)))) for f in windows), windows.names)
    alpha = np.degrees(np.concatenate([aeroid.model.tables.total_angle(*f.states()[:, :3].T)
                                       for f in windows]))
    result = ee.fit(counted, rng=0)
    knots = [aeroid.model.tables.split_point(n)[2] for n in result.names if "@A" in n]
    assert alpha.min() - 0.1 < np.degrees(knots[0]) <= alpha.min()
    assert alpha.max() <= np.degrees(knots[-1]) < alpha.max() + 0.1
    fit = aeroid.make_estimator("output-error").fit(windows, rng=0)
    assert fit.success, fit.message
    for name in ("Cma@A0.2deg", "Cma@A1.2deg", "Cma@A2.2deg"):
        i = fit.names.index(name)
        assert abs(fit.theta[i] - truth[name]) < Z_LIMIT * fit.stderr[i], name


def test_a_mach_table_and_an_angle_table_in_one_fit(flights):
    (_, noisy), _ = flights
    both = noisy.airframe.replace(tables=TableSpec((("Cx", 2),), None, (("Cma", 3),)))
    flight = dataclasses.replace(noisy, airframe=both)
    result = aeroid.make_estimator("output-error").fit(flight, rng=0)
    assert result.success, result.message
    tables = both.mach_tables(noisy.states())
    assert result.names == tables.parameter_names()
    assert [n for n in result.names if "@" in n][:2] == [f"Cx@M{k:g}"
                                                        for k in tables.knots_of("Cx")]
    # the truth: Cx constant, Cma linear in the total angle between 0.2 and 2.2 deg
    scenario = load_scenario(SCENARIO)
    values = list(scenario.coefficient_vector)
    for name, value, se in zip(result.names, result.theta, result.stderr, strict=True):
        base, kind, knot = aeroid.model.tables.split_point(name)
        want = scenario.tables.coefficients(values, knot if kind == "mach" else 1.7,
                                            knot if kind == "alpha" else 0.0)
        want = float(want[aeroid.model.NAMES.index(base)])
        assert abs(value - want) < Z_LIMIT * se, (name, value, want, se)
