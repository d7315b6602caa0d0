"""Mach from a per-sample air temperature (issue 23): the speed of sound, the three model
paths on a record whose temperature varies, the channel and its refusals, the scenario's
``[air]``."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

import aeroid
from aeroid.errors import AirframeError, FlightError
from aeroid.flights import make_flight, read_flight, scenario_from_dict, write_flight
from aeroid.flights._air import air_from_table
from aeroid.model import (
    EXOGENOUS,
    HAVE_NUMBA,
    MachTables,
    Record,
    Schedule,
    TableSpec,
    constants,
    exogenous_table,
    propagate,
    speed_of_sound_at,
    symbolic_record,
)

#: numpy, numba and CasADi evaluate one definition; they differ in the last bits of a
#: division or a folded constant, far below this (relative to each output's range).
SAME_RTOL = 1e-12
#: A closed form evaluated in another order (sqrt of a product): rounding only.
CLOSED_RTOL = 1e-14
DT = 0.004
KNOTS = (1.5, 1.9, 2.3)


def _closed_form(t_k: np.ndarray) -> np.ndarray:
    return np.sqrt(1.4 * 287.05287 * np.asarray(t_k))  # gamma R T, R of dry air [J/(kg K)]


def test_speed_of_sound_is_the_closed_form_everywhere() -> None:
    t_k = np.array([216.65, 255.65, 275.65, 288.15, 310.0])
    np.testing.assert_allclose(speed_of_sound_at(t_k), _closed_form(t_k), rtol=CLOSED_RTOL)
    # the ISA's, the tables' given temperature and a CasADi symbol go through the same one
    assert aeroid.model.tables.TableSpec.from_table(  # ISA at 5 km: 255.65 K, 320.53 m/s
        {"Cx": [1.5], "temperature_K": 255.65}, "t").speed_of_sound(None) == pytest.approx(
        float(_closed_form(255.65)), rel=CLOSED_RTOL)
    assert float(aeroid.model.tables.TableSpec((("Cx", (1.5,)),)).speed_of_sound(5000.0)) \
        == pytest.approx(320.5293, abs=5e-4)  # the ISA table's 320.53 m/s at 5 km
    x = ca.SX.sym("T")
    fun = ca.Function("a", [x], [speed_of_sound_at(x)])
    np.testing.assert_allclose(float(fun(275.65)), float(_closed_form(275.65)),
                               rtol=CLOSED_RTOL)


def test_per_sample_mach_needs_the_temperature_and_uses_it() -> None:
    flat = MachTables.from_knots({"Cx": KNOTS}, temperature_k=260.0)
    tables = MachTables(flat.knots, 300.0, (), True)
    states = np.zeros((3, aeroid.model.N_STATE))
    states[:, 0] = [500.0, 600.0, 700.0]
    with pytest.raises(AirframeError, match="needs the temperature"):
        tables.mach(states)
    temperature = np.array([250.0, 260.0, 270.0])
    np.testing.assert_allclose(tables.mach(states, temperature),
                               states[:, 0] / _closed_form(temperature), rtol=CLOSED_RTOL)
    # a constant logged temperature is the flight's one speed of sound of that temperature
    np.testing.assert_allclose(tables.mach(states, np.full(3, 260.0)), flat.mach(states),
                               rtol=CLOSED_RTOL)
    spec = TableSpec.from_table({"Cx": list(KNOTS), "temperature_K": 260.0}, "t")
    with pytest.raises(AirframeError, match="give one speed of sound"):
        spec.resolve(None, states, temperature)
    with pytest.raises(ValueError, match="varying=True"):
        symbolic_record(aeroid.model.constants(aeroid.model.reference_airframe()), DT, 1, 3,
                        tables=tables)


def _varying_record(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Sample times and an air temperature that changes by 30 K over the record."""
    t = np.arange(n) * DT
    return t, 255.0 + 30.0 * np.sin(2.0 * math.pi * t / (n * DT))


@pytest.fixture
def coast():
    scenario = aeroid.flights.load_scenario("studies/scenarios/mach_sweep.toml")
    const = constants(scenario.airframe)
    x0 = np.array(scenario.manoeuvre.initial_state)
    x0[3:6] = [40.0, 0.5, -0.3]  # rolling, pitching, yawing: every table term moves
    return scenario, const, x0


@pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")
def test_numba_and_numpy_carry_the_temperature_column(coast) -> None:
    # constant coefficients: the column is carried (in its place) and changes nothing
    scenario, const, x0 = coast
    n = 41
    t, temperature = _varying_record(n)
    delta = np.where(np.arange(n) % 7 < 3, 0.1, -0.1)
    table = exogenous_table(const, n, {"temperature": temperature,
                                       "rho": np.linspace(0.74, 0.72, n)})
    assert np.array_equal(table[:, EXOGENOUS.index("temperature")], temperature)
    theta = aeroid.model.nominal()
    a = propagate(x0, theta, delta[:-1], DT, const, substeps=2, backend="numba",
                  exogenous=table)[0]
    b = propagate(x0, theta, delta[:-1], DT, const, substeps=2, backend="numpy",
                  exogenous=table)[0]
    table[:, EXOGENOUS.index("temperature")] = 0.0  # not given: the default
    c = propagate(x0, theta, delta[:-1], DT, const, substeps=2, backend="numba",
                  exogenous=table)[0]
    scale = np.ptp(b, axis=0) + 1e-9
    assert np.max(np.abs(a - b) / scale) < SAME_RTOL
    assert np.max(np.abs(c - a) / scale) == 0.0


def _numpy_outputs(tables, parameters, x0, t, delta, temperature, const, positions, substeps):
    """The simulator's path: numpy RK4, the tables at each stage's Mach from the
    temperature linear in time within each interval (as the exogenous inputs are)."""
    def rhs(time, y, d):
        temp = np.interp(time, t, temperature)
        return aeroid.model.state_derivative(y, d, tables.coefficient_array(parameters, y,
                                                                            temp), const)
    states = [x0]
    h = DT / substeps
    for k in range(t.size - 1):
        x = states[-1]
        for sub in range(substeps):
            x = aeroid.model.rk4_step(rhs, t[k] + sub * h, x, h, delta[k])
        states.append(x)
    states = np.array(states)
    c = tables.coefficient_array(parameters, states, temperature)
    accel = aeroid.model.accelerometers(states, delta, c, const, positions).reshape(-1, 6)
    return np.column_stack([accel, states[:, 3:6]])


def test_numpy_and_casadi_tables_agree_with_a_varying_temperature(coast) -> None:
    scenario, const, x0 = coast
    n = 31
    t, temperature = _varying_record(n)
    delta = np.where(np.arange(n) % 5 < 2, 0.12, -0.12)
    tables = MachTables(MachTables.from_knots({"Cx": KNOTS, "Cmq": KNOTS},
                                              temperature_k=255.0).knots, 320.0, (), True)
    rng = np.random.default_rng(4)
    parameters = tables.expand(scenario.airframe.prior_vector())
    parameters *= 1.0 + 0.1 * rng.uniform(-1.0, 1.0, parameters.size)  # points differ
    positions = scenario.airframe.accel_positions
    expected = _numpy_outputs(tables, parameters, x0, t, delta, temperature, const,
                              positions, 2)
    record = Record.scheduled(Schedule.hold(t, delta), t,
                              exogenous_table(const, n, {"temperature": temperature}))
    simulate, _, _ = symbolic_record(const, DT, 2, n, (), (), False, record.n_pieces, True,
                                     tables)
    got = np.asarray(simulate(np.ones(parameters.size), parameters, x0,
                              *record.symbolic_inputs(), positions.ravel()))
    scale = np.ptp(expected, axis=0)
    assert np.max(np.abs(got - expected) / scale) < SAME_RTOL
    # the temperature matters: the flight's one speed of sound gives other outputs
    flat = MachTables(tables.knots, float(speed_of_sound_at(temperature.mean())))
    other = _numpy_outputs(flat, parameters, x0, t, delta, temperature, const, positions, 2)
    assert np.max(np.abs(other - expected) / scale) > 1e3 * SAME_RTOL


def _flight_with(temperature: np.ndarray):
    scenario = aeroid.flights.reference_scenario()
    flight = aeroid.flights.simulate_scenario(scenario, aeroid.flights.NoNoise(), rng=0)
    data = {c: flight[c] for c in flight.channels}
    data["air_temperature"] = temperature
    return make_flight(data, flight.airframe, dict(flight.metadata))


@pytest.mark.parametrize(("bad", "words"), [
    (np.nan, "NaN"), (-5.0, "must be an air temperature in 150..350 K"),
    (0.0, "must be an air temperature"), (21.0, "kelvin, not deg C")])
def test_a_bad_temperature_column_is_refused_in_one_line(bad, words) -> None:
    n = aeroid.flights.reference_scenario().manoeuvre.window_s
    flight = _flight_with(np.full(1 + round((n[1] - n[0]) * 500.0), 260.0))
    values = flight["air_temperature"].copy()
    values[7] = bad
    broken = _flight_with(values)
    with pytest.raises(FlightError) as err:
        broken.validate()
    assert words in str(err.value)
    assert "air_temperature" in str(err.value)
    with pytest.raises(FlightError, match="at sample 7") if not np.isnan(bad) else \
            pytest.raises(FlightError, match="first at row 7"):
        broken.validate()


def test_a_column_in_degc_is_converted_to_kelvin(tmp_path) -> None:
    flight = _flight_with(np.full(501, 260.0))
    path = tmp_path / "f.csv"
    write_flight(flight, path)
    frame = __import__("pandas").read_csv(path)
    frame = frame.rename(columns={"air_temperature": "oat"})
    frame["oat"] = frame["oat"] - 273.15
    frame.to_csv(path, index=False)
    mapping = tmp_path / "map.toml"
    mapping.write_text('oat = {channel = "air_temperature", unit = "degC"}\n')
    got = read_flight(path, columns=mapping)
    np.testing.assert_allclose(got["air_temperature"], 260.0, rtol=1e-12)


@pytest.mark.parametrize(("table", "words"), [
    ({"delta_T_K": 20.0, "temperature_K": [[0.0, 260.0]]}, "exactly one of"),
    ({}, "exactly one of"),
    ({"temperature_K": [[0.0, 260.0], [0.0, 250.0]]}, "times must increase"),
    ({"temperature_K": [[0.0, 26.0]]}, "kelvin, not deg C"),
    ({"delta_T_K": 5.0, "log_temperature": 1}, "true or false"),
    ({"delta_T_K": 5.0, "sd": 1.0}, "sd")])
def test_the_scenario_air_table_refuses_in_one_line(table, words) -> None:
    with pytest.raises(AirframeError, match=words) as err:
        air_from_table(table, "s.toml: [air]")
    assert "\n" not in str(err.value) and "[air]" in str(err.value)


def test_the_scenario_air_offset_and_profile() -> None:
    offset = air_from_table({"delta_T_K": 20.0}, "[air]")
    np.testing.assert_allclose(offset.temperature(np.arange(3.0), 5000.0), 255.65 + 20.0,
                               rtol=1e-12)
    with pytest.raises(AirframeError, match="altitude_m"):
        offset.temperature(np.arange(3.0), None)
    profile = air_from_table({"temperature_K": [[0.0, 268.0], [20.0, 258.0]]}, "[air]")
    np.testing.assert_allclose(profile.temperature(np.array([-1.0, 10.0, 30.0]), None),
                               [268.0, 263.0, 258.0])
    data = aeroid.model.read_toml("studies/scenarios/mach_sweep.toml")
    data["air"] = {"delta_T_K": 20.0, "log_temperature": True}
    scenario = scenario_from_dict(data, source="sweep")
    assert scenario.manoeuvre.air == air_from_table(data["air"], "x")
    assert "air" in scenario.manoeuvre.describe()
    del data["air"]
    assert "air" not in scenario_from_dict(data, source="s").manoeuvre.describe()
