"""Coefficient tables in Mach (aeroid.model.tables): identities and the CasADi evaluation."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import aeroid
from aeroid.errors import AirframeError
from aeroid.model import MachTables, TableSpec, symbolic
from aeroid.model import tables as T

#: numpy and CasADi evaluate the same element-wise definition; they may differ in the
#: last bits of a division (CasADi folds constants), far below this.
CASADI_TOL = 1e-12
KNOTS = (1.1, 1.35, 1.6, 1.9, 2.2)


def _tables() -> MachTables:
    return MachTables.from_knots({"Cx": KNOTS, "Cmq": (1.1, 1.65, 2.2)}, altitude_m=5000.0)


def _states(rng: np.random.Generator, n: int, sound: float) -> np.ndarray:
    states = rng.normal(0.0, 1.0, (n, aeroid.model.N_STATE))
    states[:, aeroid.model.U] = rng.uniform(0.8, 2.5, n) * sound  # beyond both end knots too
    states[:, aeroid.model.V:aeroid.model.W + 1] *= 10.0
    states[:, aeroid.model.P] *= 50.0
    return states


def test_basis_sums_to_one_and_reproduces_a_linear_function():
    mach = np.linspace(0.5, 3.0, 2001)  # inside and beyond the knots
    B = T.basis(KNOTS, mach)
    assert B.shape == (mach.size, len(KNOTS))
    np.testing.assert_allclose(B.sum(axis=1), 1.0, rtol=0, atol=1e-15)
    assert B.min() >= 0.0
    np.testing.assert_array_equal(T.basis(KNOTS, np.array(KNOTS)), np.eye(len(KNOTS)))
    inside = (mach >= KNOTS[0]) & (mach <= KNOTS[-1])
    line = -0.9 + 0.25 * mach
    values = -0.9 + 0.25 * np.array(KNOTS)
    np.testing.assert_allclose((B @ values)[inside], line[inside], rtol=0, atol=1e-14)
    # beyond the ends the end values hold
    np.testing.assert_allclose((B @ values)[mach < KNOTS[0]], values[0], rtol=0, atol=1e-15)
    np.testing.assert_allclose((B @ values)[mach > KNOTS[-1]], values[-1], rtol=0, atol=1e-15)


def test_one_knot_is_a_constant():
    np.testing.assert_array_equal(T.basis((1.5,), np.array([0.7, 1.5, 3.0])), np.ones((3, 1)))


def test_table_with_equal_points_is_the_constant_coefficient():
    rng = np.random.default_rng(1)
    tables = _tables()
    c = aeroid.model.nominal()
    states = _states(rng, 200, tables.speed_of_sound_mps)
    p = tables.expand(c)
    np.testing.assert_allclose(tables.coefficient_array(p, states), np.broadcast_to(c, (200, 9)),
                               rtol=1e-15, atol=0)
    const = aeroid.model.constants(aeroid.model.reference_airframe())
    delta = rng.uniform(-0.1, 0.1, 200)
    direct = aeroid.model.state_derivative(states, delta, c, const)
    tabled = aeroid.model.state_derivative(states, delta, tables.coefficient_array(p, states),
                                           const)
    np.testing.assert_allclose(tabled, direct, rtol=1e-14, atol=1e-12)


def test_parameter_names_and_sizes_come_from_the_knots():
    tables = _tables()
    names = tables.parameter_names()
    assert tables.n_parameters == len(names) == aeroid.model.N_COEFFICIENTS - 2 + 5 + 3
    assert names[:len(KNOTS)] == tuple(f"Cx@M{k:g}" for k in KNOTS)
    assert "Cmq@M1.65" in names and "Cx" not in names and "Cza" in names
    np.testing.assert_allclose(tables.mean_coefficients(tables.expand(aeroid.model.nominal())),
                               aeroid.model.nominal())


def test_casadi_table_equals_numpy_table():
    rng = np.random.default_rng(2)
    tables = _tables()
    p = tables.expand(aeroid.model.nominal()) * rng.uniform(0.8, 1.2, tables.n_parameters)
    states = _states(rng, 300, tables.speed_of_sound_mps)
    x = ca.SX.sym("x", aeroid.model.N_STATE)
    theta = ca.SX.sym("theta", tables.n_parameters)
    c = symbolic.coefficients_at(theta, symbolic._state(x), tables)
    fun = ca.Function("c", [x, theta], [ca.vertcat(*c)])
    symbolic_values = np.array(fun.map(len(states))(states.T, np.tile(p, (len(states), 1)).T)).T
    numpy_values = tables.coefficient_array(p, states)
    scale = np.abs(numpy_values).max(axis=0)
    assert np.max(np.abs(symbolic_values - numpy_values) / scale) < CASADI_TOL
    # and the whole right-hand side
    const = aeroid.model.constants(aeroid.model.reference_airframe())
    xdot, _ = symbolic.rhs(x, 0.02, theta, const, tables)
    f = ca.Function("f", [x, theta], [xdot])
    got = np.array(f.map(len(states))(states.T, np.tile(p, (len(states), 1)).T)).T
    want = aeroid.model.state_derivative(states, 0.02, numpy_values, const)
    assert np.max(np.abs(got - want) / (np.abs(want).max(axis=0) + 1e-300)) < CASADI_TOL


def test_table_spec_reads_checks_and_resolves():
    spec = TableSpec.from_table({"Cx": [1.1, 2.2], "Cmq": 3, "temperature_K": 255.7}, "f")
    assert TableSpec.from_table(spec.to_table(), "f") == spec
    states = np.zeros((50, 9))
    states[:, 0] = np.linspace(1.12, 2.18, 50) * np.sqrt(1.4 * aeroid.model.R_AIR * 255.7)
    tables = spec.resolve(None, states)
    assert tables.knots_of("Cmq") == (1.12, 1.65, 2.18)
    for bad, what in (({"Cq": [1.0]}, "unknown"), ({"Cx": [2.0, 1.0]}, "increase"),
                      ({"Cx": [1.0, "a"]}, "numbers"), ({"Cx": 0}, ">= 1"),
                      ({"Cx": [1.0], "temperature_K": 20.0}, "kelvin"), ({}, "no coefficient"),
                      ({"Cx": [350.0]}, "Mach numbers")):
        with pytest.raises(AirframeError, match=what):
            TableSpec.from_table(bad, "f: [tables]")
    with pytest.raises(AirframeError, match="temperature_K"):
        TableSpec.from_table({"Cx": [1.0]}, "f").resolve(None)
    with pytest.raises(AirframeError, match="no flight"):
        spec.resolve(1000.0)


def test_airframe_file_carries_tables(tmp_path):
    data = aeroid.model.reference_scenario_data()
    data = {k: data[k] for k in ("airframe", "atmosphere")}
    data["tables"] = {"Cx": [1.1, 1.6, 2.2], "Cmq": [1.2, 2.0]}
    airframe = aeroid.model.Airframe.from_dict(data, source="a.toml")
    path = tmp_path / "a.toml"
    aeroid.model.save_airframe(airframe, path)
    again = aeroid.model.load_airframe(path)
    assert again == airframe
    tables = again.mach_tables()
    assert tables.names == ("Cx", "Cmq")
    np.testing.assert_allclose(tables.speed_of_sound_mps, airframe.speed_of_sound_mps)
    data["tables"] = {"Cx": "1.1"}
    with pytest.raises(AirframeError, match=r"a.toml: \[tables\] Cx"):
        aeroid.model.Airframe.from_dict(data, source="a.toml")
