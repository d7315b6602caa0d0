"""The EKF and UKF with coefficient tables (issue 23; baselines/_kalman_tables.py).

References: the augmented model's Jacobians against central finite differences of its
own transition and measurement; with flat tables it is the filters' model of the nine
coefficients (baselines/_augmented.py, an independent CasADi graph); the batched
functions (the UKF's) equal the single ones. On the first 6 s of the Mach sweep (Cx and
Cmq +-15 % over the coast): the EKF with a constant Cx is refused by the fit check,
with Cx and Cmq tables every point is within 3 of its standard error; a point held at its
truth is reported held and the other points' standard errors are no larger.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from table_truths import ALPHA_TABLE, MACH_SWEEP, SWEEP_WINDOW_S, table_truth

import aeroid
from aeroid.errors import EstimatorError
from aeroid.estimation import CoefficientSpec
from aeroid.flights import (
    GaussianNoise,
    cut_windows,
    flight_record,
    record_flight,
)
from aeroid.model import N_STATE, TableSpec
from baselines._augmented import augmented_model
from baselines._kalman_tables import table_model, table_setup

SCENARIOS = Path(__file__).parents[2] / "studies" / "scenarios"
#: The Mach sweep's first 6 s span Mach 2.19-1.68: the truth's knots within it.
KNOTS = (1.65, 1.925, 2.2)
#: The sweep's roll rate is 60-90 rad/s at 4 ms samples: 4 RK4 steps per sample, as the
#: Mach-sweep study's output-error (the EKF's default 1 puts Cma 15 se off: measured).
SUBSTEPS = 4
Z_LIMIT = 3.0
#: Central differences of a smooth RK4 step with steps of 1e-6 relative: truncation
#: ~1e-12 and rounding ~1e-10 relative to the row; measured 2.5e-8 at most.
FD_RTOL = 1e-6
#: The same equations in two CasADi graphs (tables flat at the coefficients) and mapped
#: against single evaluations: rounding.
SAME_RTOL = 1e-12
#: Holding a point removes its state: in one pass (one noise law) the neighbouring points'
#: standard errors fall (measured 0.94, 0.95 of the free fit's). Over the passes the noise
#: law is refitted to each run's own innovations (ax1's ``a`` came out 18 % higher with the
#: point held), which moves the standard errors by up to that law's change: measured
#: +1.9 % on Cx@M2.2 after 6 passes.
HELD_SE_RTOL = 3e-2
#: The UKF against the EKF on the angle-table flight (a nearly linear problem at the
#: estimate): measured 0.011 of a standard error apart, standard errors 3e-5 apart.
UKF_EKF_SE = 0.05
UKF_EKF_SE_RTOL = 1e-3
#: The EKF's smoothed passes against its carried ones on that flight: measured 0.023 of a
#: standard error apart, standard errors 3.1 % apart (different passes, one fixed point).
SMOOTHED_SE = 0.1
#: A prior of sd 1e-8 of its mean against the hold: the filter's update of that state is
#: ~(sd / se)^2 = 1e-11 of the data's; the others within this many se of the held fit.
TINY_SD = 1e-8
PRIOR_LIMIT_SE = 1e-3
SMOOTHED_SE_RTOL = 0.1


@pytest.fixture(scope="module")
def alpha_flight():
    """1 s at Mach 1.7 (studies/scenarios/alpha_table.toml), Cma a table in the total angle
    of attack, Cx given a Mach table too (2 knots), tactical IMU."""
    scenario, _, _, truth = table_truth(ALPHA_TABLE)
    flight = record_flight(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                           truth, GaussianNoise(), rng=0, tables=scenario.tables)
    spec = TableSpec((("Cx", (1.6, 1.8)),), None, (("Cma", (0.2, 1.2, 2.2)),))
    return dataclasses.replace(flight, airframe=flight.airframe.replace(tables=spec))


@pytest.fixture(scope="module")
def sweep():
    scenario, manoeuvre, p, truth = table_truth(MACH_SWEEP, SWEEP_WINDOW_S)
    flight = record_flight(scenario.airframe, p, manoeuvre, truth, GaussianNoise(), rng=0,
                           tables=scenario.tables)
    flight = dataclasses.replace(flight, airframe=flight.airframe.replace(
        tables=TableSpec((("Cx", KNOTS), ("Cmq", KNOTS)))))
    return flight, dict(zip(scenario.tables.parameter_names(), p, strict=True))


@pytest.fixture(scope="module")
def ekf_free(sweep):
    flight, _ = sweep
    return aeroid.make_estimator("ekf", {"substeps": SUBSTEPS}).fit(flight, rng=0)


def _z(result, truth):
    return (result.theta - np.array([truth[n] for n in result.names])) / result.stderr


# -- the model -----------------------------------------------------------------------------
def _state(flight, tables, k):
    """An augmented state at sample k: the logged state, tables that are not flat."""
    p = tables.expand(flight.airframe.prior_vector())
    p *= 1.0 + 0.05 * np.sin(np.arange(p.size))  # each point its own value
    return np.concatenate([flight.states()[k], p, [0.01, -0.02]])


def _central(fun, z, k):
    base = fun(z, k)[0]
    J = np.empty((base.size, z.size))
    for i in range(z.size):
        h = 1e-6 * max(abs(z[i]), 1.0)
        up, down = z.copy(), z.copy()
        up[i] += h
        down[i] -= h
        J[:, i] = (fun(up, k)[0] - fun(down, k)[0]) / (2 * h)
    return J


def test_jacobians_equal_finite_differences(alpha_flight):
    tables = alpha_flight.airframe.mach_tables(alpha_flight.states())
    model = table_model(alpha_flight, 2, tables, position_free=(0, 4))
    for k in (0, 200, 450):
        z = _state(alpha_flight, tables, k)
        for fun in (model.transition, model.observe):
            exact = fun(z, k)[1]
            fd = _central(fun, z, k)
            scale = np.abs(exact).max(axis=1, keepdims=True)  # per output row
            assert np.all(np.abs(exact - fd) <= FD_RTOL * scale), (
                fun.__name__, k, float(np.max(np.abs(exact - fd) / scale)))


def test_flat_tables_are_the_model_of_the_nine_coefficients(alpha_flight):
    tables = alpha_flight.airframe.mach_tables(alpha_flight.states())
    record = flight_record(alpha_flight)
    ours = table_model(alpha_flight, 2, tables, record, position_free=(0, 4))
    theirs = augmented_model(alpha_flight, 2, record, position_free=(0, 4))
    coefficients = alpha_flight.airframe.prior_vector()
    for k in (0, 300):
        x = alpha_flight.states()[k]
        z_tab = np.concatenate([x, tables.expand(coefficients), [0.01, -0.02]])
        z_nine = np.concatenate([x, coefficients, [0.01, -0.02]])
        np.testing.assert_allclose(ours.transition(z_tab, k)[0][:N_STATE],
                                   theirs.transition(z_nine, k)[0][:N_STATE], rtol=SAME_RTOL)
        np.testing.assert_allclose(ours.observe(z_tab, k)[0], theirs.observe(z_nine, k)[0],
                                   rtol=SAME_RTOL, atol=SAME_RTOL)


def test_the_batched_functions_equal_the_single_ones(alpha_flight):
    tables = alpha_flight.airframe.mach_tables(alpha_flight.states())
    model = table_model(alpha_flight, 2, tables, position_free=(0, 4))
    Z = np.stack([_state(alpha_flight, tables, 100) * (1 + 1e-3 * j) for j in range(5)])
    np.testing.assert_allclose(model.transition_batch(Z, 100),
                               np.stack([model.transition(z, 100)[0] for z in Z]),
                               rtol=SAME_RTOL)
    np.testing.assert_allclose(model.observe_batch(Z, 100),
                               np.stack([model.observe(z, 100)[0] for z in Z]),
                               rtol=SAME_RTOL, atol=SAME_RTOL)


def test_each_point_starts_as_its_coefficient(alpha_flight):
    est = aeroid.make_estimator("ekf")
    tables = alpha_flight.airframe.mach_tables(alpha_flight.states())
    nine, wide = est.setup(alpha_flight), table_setup(est.setup(alpha_flight), tables)
    n_c, n_p = aeroid.model.N_COEFFICIENTS, tables.n_parameters
    points = slice(N_STATE, N_STATE + n_p)
    np.testing.assert_array_equal(wide.x0[points], tables.expand(nine.x0[N_STATE:N_STATE + n_c]))
    np.testing.assert_array_equal(np.diag(wide.P0)[points],
                                  tables.expand(np.diag(nine.P0)[N_STATE:N_STATE + n_c]))
    block = wide.P0[points, points]
    assert not np.any(block - np.diag(np.diag(block)))  # the points independent
    np.testing.assert_array_equal(wide.P0[:N_STATE, :N_STATE], nine.P0[:N_STATE, :N_STATE])
    np.testing.assert_array_equal(wide.x0[N_STATE + n_p:], nine.x0[N_STATE + n_c:])


# -- the fits --------------------------------------------------------------------------------
def test_ekf_constant_cx_is_refused_and_its_table_is_within_3_se(sweep, ekf_free):
    flight, truth = sweep
    constant = dataclasses.replace(flight, airframe=flight.airframe.replace(tables=None))
    refused = aeroid.make_estimator("ekf", {"substeps": SUBSTEPS}).fit(constant, rng=0)
    assert not refused.success and "does not fit the data" in refused.message, refused.message
    assert ekf_free.success, ekf_free.message
    assert ekf_free.names == flight.airframe.mach_tables(flight.states()).parameter_names()
    z = _z(ekf_free, truth)
    points = np.array(["@M" in n for n in ekf_free.names])
    assert points.sum() == 2 * len(KNOTS)
    assert np.all(np.abs(z[points]) < Z_LIMIT), dict(zip(ekf_free.names, z.round(2),
                                                         strict=True))
    assert set(ekf_free.info["table_floor"]) == set(ekf_free.names)
    assert ekf_free.info["tables"] == {"Cx": list(KNOTS), "Cmq": list(KNOTS)}


def test_ekf_holds_a_table_point(sweep, ekf_free):
    flight, truth = sweep
    name = "Cx@M1.925"
    held = aeroid.make_estimator("ekf", {"substeps": SUBSTEPS}).fit(
        flight, rng=0, holds=CoefficientSpec.parse([f"{name}={truth[name]}"]))
    assert held.success, held.message
    j = held.names.index(name)
    assert held.held == {name: truth[name]} and held.theta[j] == truth[name]
    assert np.isnan(held.stderr[j]) and np.isnan(held.info["table_floor"][name])
    points = [i for i, n in enumerate(held.names) if "@M" in n and i != j]
    assert np.all(held.stderr[points] <= ekf_free.stderr[points] * (1 + HELD_SE_RTOL))
    z = _z(held, truth)
    assert np.all(np.abs(z[points]) < Z_LIMIT), dict(zip(held.names, z.round(2), strict=True))
    one = aeroid.make_estimator("ekf", {"substeps": SUBSTEPS, "max_passes": 1})
    free_1 = one.fit(flight, rng=0)
    held_1 = one.fit(flight, rng=0, holds=CoefficientSpec.parse([f"{name}={truth[name]}"]))
    neighbours = [i for i, n in enumerate(held.names) if n.startswith("Cx@") and i != j]
    assert np.all(held_1.stderr[neighbours] < free_1.stderr[neighbours])  # one law: smaller


def test_ukf_fits_an_angle_table_as_the_ekf(alpha_flight):
    truth = {"Cx@M1.6": -0.98, "Cx@M1.8": -0.98, "Cma@A0.2deg": -30.42, "Cma@A1.2deg": -33.8,
             "Cma@A2.2deg": -37.18}
    ekf = aeroid.make_estimator("ekf").fit(alpha_flight, rng=0)
    ukf = aeroid.make_estimator("ukf").fit(alpha_flight, rng=0)
    assert ekf.success and ukf.success, (ekf.message, ukf.message)
    assert ukf.names == ekf.names
    for result in (ekf, ukf):
        for name, value in truth.items():
            j = result.names.index(name)
            assert abs(result.theta[j] - value) < Z_LIMIT * result.stderr[j], (
                result.estimator, name, result.theta[j], result.stderr[j])
    # the two filters on one record: the same estimate to a fraction of its se
    assert np.all(np.abs(ukf.theta - ekf.theta) < UKF_EKF_SE * ekf.stderr)
    np.testing.assert_allclose(ukf.stderr, ekf.stderr, rtol=UKF_EKF_SE_RTOL)


def test_a_prior_on_a_point_is_its_state_start(alpha_flight):
    """A prior N(mu, sd^2) on a point starts its state at mu with sd (each pass afresh): a
    vanishing sd keeps the point at mu and gives the fit with the point held."""
    name, value = "Cma@A1.2deg", -33.8
    est = aeroid.make_estimator("ekf")
    held = est.fit(alpha_flight, rng=0, holds=CoefficientSpec.parse([f"{name}={value}"]))
    tight = est.fit(alpha_flight, rng=0, holds=CoefficientSpec.parse(
        [], [f"{name}={value}:{abs(value) * TINY_SD}"]))
    wide = est.fit(alpha_flight, rng=0, holds=CoefficientSpec.parse([], [f"{name}={value}:1"]))
    assert held.success and tight.success and wide.success
    assert tight.priors == {name: (value, abs(value) * TINY_SD)}
    j = tight.names.index(name)
    assert tight.theta[j] == pytest.approx(value, rel=TINY_SD)
    others = [i for i in range(len(held.names)) if i != j]
    assert np.all(np.abs(tight.theta[others] - held.theta[others])
                  < PRIOR_LIMIT_SE * held.stderr[others])
    free = est.fit(alpha_flight, rng=0)  # a prior of sd 1 (10x the point's se) adds little
    assert free.stderr[j] * (1 - 1e-9) > wide.stderr[j] > free.stderr[j] / 1.01


def test_smoothed_passes_fit_tables_as_the_carried_ones(alpha_flight):
    """The EKF's smoothed passes (each after the first from the original prior, along the
    last pass's RTS-smoothed trajectory) reach the carried passes' estimate."""
    carried = aeroid.make_estimator("ekf").fit(alpha_flight, rng=0)
    smoothed = aeroid.make_estimator("ekf", {"passes": "smoothed"}).fit(alpha_flight, rng=0)
    assert carried.success and smoothed.success, (carried.message, smoothed.message)
    assert smoothed.names == carried.names
    assert np.all(np.abs(smoothed.theta - carried.theta) < SMOOTHED_SE * carried.stderr)
    np.testing.assert_allclose(smoothed.stderr, carried.stderr, rtol=SMOOTHED_SE_RTOL)


# -- refusals -----------------------------------------------------------------------------
def test_what_the_filters_do_not_do_with_tables_is_one_line(alpha_flight):
    with pytest.raises(EstimatorError, match=r"ekf: with \[tables\] the filter estimates the "
                       r"table points .*imu_errors = bias is not available with tables"):
        aeroid.make_estimator("ekf", {"imu_errors": "bias"}).fit(alpha_flight)
    windows = cut_windows(alpha_flight, ((5.0, 5.45), (5.55, 6.0)))
    with pytest.raises(EstimatorError, match=r"ukf: several windows with \[tables\] are not "
                       "built for the filters"):
        aeroid.make_estimator("ukf").fit(windows)
    # air data as the filters' outputs (built in parallel with the tables): refused, not
    # silently dropped from the tabled filter
    with pytest.raises(EstimatorError, match=r"ekf: with \[tables\] .*air_data = measured is "
                       "not available with tables"):
        aeroid.make_estimator("ekf", {"air_data": "measured"}).fit(alpha_flight)


@pytest.mark.parametrize("method", ["eam-pso", "ebm-pso", "sebm-pso", "pyswarms"])
def test_the_swarms_refuse_tables_in_one_line(alpha_flight, method):
    with pytest.raises(EstimatorError, match=rf"{method}: the airframe's \[tables\] makes Cx, "
                       r"Cma tables .* this method fits constant coefficients"):
        aeroid.make_estimator(method).fit(alpha_flight)


def test_a_study_of_tables_takes_the_ekf(tmp_path):
    """`aeroid study` on a scenario with [tables] runs the EKF and scores its points (the
    study's own truth per point: tests/integration/test_study_tables.py)."""
    import re

    from aeroid.study import loads_study, run_study

    text = (SCENARIOS / "mach_sweep.toml").read_text()
    text = re.sub(r"window_s = \[0.5, 20.5\]", "window_s = [0.5, 6.5]", text)
    text = re.sub(r"^(Cx|Cmq) = \[1.1, .*\]$", rf"\1 = {list(KNOTS)}", text, flags=re.M)
    scenario = tmp_path / "sweep6.toml"
    scenario.write_text(text)
    study = loads_study(f"""
[study]
name = "sweep"
runs = 1
seed = 7
scenario = "{scenario}"
[[noise]]
label = "gauss"
model = "gaussian"
[[estimators]]
label = "EKF"
method = "ekf"
options = {{ substeps = {SUBSTEPS} }}
""")
    (record,) = run_study(study, tmp_path / "out", progress=False).records
    assert record["success"], record["message"]
    names = list(record["names"])
    assert names == list(TableSpec((("Cx", KNOTS), ("Cmq", KNOTS))).resolve(1.0).parameter_names())
    truth = dict(zip(names, record["truth"], strict=True))
    assert truth["Cx@M1.925"] == pytest.approx(-0.90)
    assert truth["Cmq@M2.2"] == pytest.approx(-1893.0)  # the scenario file's rows
    z = (np.array(record["theta"]) - np.array(record["truth"])) / np.array(record["stderr"])
    points = np.array(["@M" in n for n in names])
    assert np.all(np.abs(z[points]) < Z_LIMIT), dict(zip(names, z.round(2), strict=True))
