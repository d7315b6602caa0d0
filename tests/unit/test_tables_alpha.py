"""Coefficient tables in the total angle of attack (issue 23): basis, variable, CasADi, files."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

import aeroid
from aeroid.errors import AirframeError
from aeroid.model import MachTables, TableSpec, symbolic
from aeroid.model import tables as T

#: numpy and CasADi evaluate the same element-wise definition (test_tables.CASADI_TOL).
CASADI_TOL = 1e-12
#: The total angle's cross-flow floor (1e-6 m/s) moves it by 1e-6 / V rad: at V >= 100 m/s
#: below this.
FLOOR_TOL = 1e-8
ALPHA_DEG = (0.0, 1.5, 3.0, 6.0)


def _tables() -> MachTables:
    return MachTables((("Cx", (1.1, 1.6, 2.2)),), 320.0,
                      (("Cma", tuple(math.radians(a) for a in ALPHA_DEG)),))


def _states(rng: np.random.Generator, n: int) -> np.ndarray:
    states = rng.normal(0.0, 1.0, (n, aeroid.model.N_STATE))
    states[:, aeroid.model.U] = rng.uniform(300.0, 750.0, n)
    states[:, aeroid.model.V:aeroid.model.W + 1] *= 40.0  # up to ~15 deg: beyond the knots
    states[:, aeroid.model.P] *= 50.0
    return states


def test_hat_basis_equals_numpy_interp():
    knots = np.radians(ALPHA_DEG)
    x = np.radians(np.linspace(-1.0, 9.0, 1001))  # inside and beyond both end knots
    B = T.basis(knots, x)
    for i in range(knots.size):
        np.testing.assert_allclose(B[:, i], np.interp(x, knots, np.eye(knots.size)[i]),
                                   rtol=0, atol=1e-15)
    values = np.array([-30.0, -32.5, -36.0, -41.0])
    np.testing.assert_allclose(T.table_value(x, tuple(knots), values),
                               np.interp(x, knots, values), rtol=0, atol=1e-13)


def test_total_angle_is_the_angle_between_body_axis_and_velocity():
    rng = np.random.default_rng(3)
    u, v, w = rng.uniform(100.0, 700.0, 500), rng.normal(0, 30, 500), rng.normal(0, 30, 500)
    got = T.MachTables((), 300.0).alpha_total(np.stack([u, v, w, *np.zeros((6, 500))], -1))
    np.testing.assert_allclose(got, np.arccos(u / np.sqrt(u * u + v * v + w * w)),
                               rtol=0, atol=FLOOR_TOL)
    # in the pitch plane (v = 0) it is |alpha| of the model's air data
    _, alpha, _ = aeroid.model.equations.air_data(u, 0.0 * u, w)
    np.testing.assert_allclose(T.MachTables((), 300.0).alpha_total(
        np.stack([u, 0 * u, w, *np.zeros((6, 500))], -1)), np.abs(alpha), rtol=0, atol=FLOOR_TOL)


def test_names_layout_and_evaluation():
    tables = _tables()
    names = tables.parameter_names()
    assert names.count("Cma@A1.5deg") == 1 and "Cx@M1.6" in names and "Cma" not in names
    assert tables.n_parameters == len(names) == aeroid.model.N_COEFFICIENTS - 2 + 3 + len(
        ALPHA_DEG)
    rng = np.random.default_rng(4)
    p = tables.expand(aeroid.model.nominal()) * rng.uniform(0.8, 1.2, tables.n_parameters)
    states = _states(rng, 400)
    got = tables.coefficient_array(p, states)
    j = aeroid.model.NAMES.index("Cma")
    s = dict(tables.layout)["Cma"]
    alpha_t = np.arccos(states[:, 0] / np.linalg.norm(states[:, :3], axis=1))
    np.testing.assert_allclose(got[:, j], np.interp(alpha_t, np.radians(ALPHA_DEG), p[s]),
                               rtol=1e-9)
    with pytest.raises(AirframeError, match="angle of attack"):
        tables.coefficients(list(p), 1.5)


def test_casadi_angle_table_equals_numpy_and_has_finite_derivatives_at_zero_incidence():
    rng = np.random.default_rng(5)
    tables = _tables()
    p = tables.expand(aeroid.model.nominal()) * rng.uniform(0.8, 1.2, tables.n_parameters)
    states = _states(rng, 300)
    states[0, 1:3] = 0.0  # zero incidence: sqrt(v^2 + w^2) has no derivative there
    x = ca.SX.sym("x", aeroid.model.N_STATE)
    theta = ca.SX.sym("theta", tables.n_parameters)
    const = aeroid.model.constants(aeroid.model.reference_airframe())
    xdot, _ = symbolic.rhs(x, 0.02, theta, const, tables)
    f = ca.Function("f", [x, theta], [xdot, ca.jacobian(xdot, ca.vertcat(x, theta))])
    got, jac = f.map(len(states))(states.T, np.tile(p, (len(states), 1)).T)
    got = np.array(got).T
    want = aeroid.model.state_derivative(states, 0.02, tables.coefficient_array(p, states),
                                         const)
    assert np.max(np.abs(got - want) / (np.abs(want).max(axis=0) + 1e-300)) < CASADI_TOL
    assert np.all(np.isfinite(np.array(jac)))


def test_table_spec_reads_checks_and_resolves_angle_tables():
    spec = TableSpec.from_table({"Cx": [1.1, 2.2], "Cma": {"alpha_deg": [0, 2, 4]},
                                 "Cmq": {"alpha_deg": 3}}, "f")
    assert TableSpec.from_table(spec.to_table(), "f") == spec
    states = np.zeros((50, 9))
    states[:, 0] = 600.0
    states[:, 2] = 600.0 * np.tan(np.radians(np.linspace(0.53, 3.96, 50)))
    tables = spec.resolve(5000.0, states)
    np.testing.assert_allclose(np.degrees(tables.knots_of("Cma")), (0, 2, 4), atol=1e-12)
    # counted knots span the data's total angle rounded outward to 0.1 deg
    np.testing.assert_allclose(np.degrees(tables.knots_of("Cmq")), (0.5, 2.25, 4.0),
                               atol=1e-12)
    assert tables.angle_names == ("Cma", "Cmq") and tables.names == ("Cx",)
    for bad, what in (({"Cma": {"alpha_deg": [-1.0, 2.0]}}, r"\[0, 90\] deg"),
                      ({"Cma": {"alpha_deg": [0.0, 95.0]}}, r"\[0, 90\] deg"),
                      ({"Cma": {"alpha_deg": [2.0, 1.0]}}, "increase"),
                      ({"Cma": {"alpha_rad": [0.0, 0.1]}}, "alpha_deg"),
                      ({"Cma": {"alpha_deg": 0}}, ">= 1"),
                      ({"Cma": {"alpha_deg": "2"}}, "list of angles")):
        with pytest.raises(AirframeError, match=what):
            TableSpec.from_table(bad, "f: [tables]")
    with pytest.raises(AirframeError, match="2-D"):
        MachTables((("Cma", (1.1, 2.2)),), 300.0, (("Cma", (0.0, 0.1)),))


def test_scenario_gives_a_true_angle_table():
    scenario = aeroid.flights.load_scenario("studies/scenarios/alpha_table.toml")
    assert scenario.tables.angle_names == ("Cma",)
    names = scenario.tables.parameter_names()
    truth = dict(zip(names, scenario.coefficient_vector, strict=True))
    assert truth["Cma@A1.2deg"] == -33.8 and truth["Cma@A2.2deg"] == -37.18
    fits = scenario.airframe.mach_tables()
    assert fits.parameter_names() == names


def test_a_study_scores_angle_points_against_the_true_table():
    from aeroid.study import _tables as study_tables

    scenario = aeroid.flights.load_scenario("studies/scenarios/alpha_table.toml")
    names = ("Cx", "Cma@A0.2deg", "Cma@A0.7deg", "Cma@A2.2deg", "Cma@A3deg", "Cmq")
    got = study_tables.parameter_truth(scenario, names)
    # the truth's rows, linear between them and held beyond (numpy.interp, independently)
    cma = np.interp([0.2, 0.7, 2.2, 3.0], [0.2, 1.2, 2.2], [-30.42, -33.8, -37.18])
    np.testing.assert_allclose(got, [-0.98, *cma, -2227.0], rtol=1e-12)
