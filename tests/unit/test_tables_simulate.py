"""The simulator with coefficient tables in Mach (aeroid.flights.simulate(tables=...))."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import aeroid
from aeroid.errors import AirframeError
from aeroid.flights import Manoeuvre, load_scenario, simulate
from aeroid.model import MachTables

MACH_SWEEP = Path(__file__).parents[2] / "studies" / "scenarios" / "mach_sweep.toml"
#: The table path (numpy RK4) and the constant-coefficient path (numba or numpy kernel)
#: take the same RK4 steps; they differ by rounding, tested to 1e-12 of each channel's
#: range elsewhere (numpy against numba), and here over 0.2 s of flight.
SAME_MODEL_TOL = 1e-9


def _short() -> Manoeuvre:
    return Manoeuvre(window_s=(0.0, 0.2), sample_rate_hz=500.0, truth_substeps=2)


def test_flat_tables_fly_the_constant_coefficients():
    airframe = aeroid.model.reference_airframe()
    c = aeroid.model.nominal()
    tables = MachTables.from_knots({"Cx": (1.5, 1.7, 1.9), "Cmq": (1.6, 1.8)},
                                   altitude_m=airframe.altitude_m)
    plain = simulate(airframe, c, _short())
    tabled = simulate(airframe, tables.expand(c), _short(), tables=tables)
    for name in aeroid.model.OUTPUT_CHANNELS:
        span = np.ptp(plain[name]) + 1e-300
        assert np.max(np.abs(tabled[name] - plain[name])) / span < SAME_MODEL_TOL, name
    assert tabled.true_coefficients is None
    assert tabled.metadata["true_parameters"]["Cx@M1.7"] == pytest.approx(c[0])
    assert tabled.metadata["true_tables"]["Cx"] == [1.5, 1.7, 1.9]


def test_tables_change_the_flight_as_the_table_says():
    """A table in Cx makes the axial accelerations those of Cx(M) at each sample."""
    airframe = aeroid.model.reference_airframe()
    tables = MachTables.from_knots({"Cx": (1.6, 1.75)}, altitude_m=airframe.altitude_m)
    p = tables.expand(aeroid.model.nominal())
    p[:2] = (-1.2, -0.8)
    flight = simulate(airframe, p, _short(), tables=tables)
    states = flight.states()
    mach = tables.mach(states)
    cx = -1.2 + (mach - 1.6) / 0.15 * 0.4  # the table, by hand (1.6 < M < 1.75 here)
    assert np.all((mach > 1.6) & (mach < 1.75))
    const = aeroid.model.constants(airframe)
    qs = 0.5 * const.rho * const.area * np.sum(states[:, :3] ** 2, axis=1)
    fax = flight["ax1"] * const.mass  # minus thrust and the lever-arm terms, below
    c = np.tile(aeroid.model.nominal(), (len(mach), 1))
    c[:, 0] = 0.0
    lever = aeroid.model.accelerometers(states, flight["delta"], c, const,
                                        airframe.accel_positions)[:, 0, 0] * const.mass
    np.testing.assert_allclose((fax - lever) / qs, cx, rtol=1e-10)


def test_tables_refuse_what_they_do_not_simulate():
    airframe = aeroid.model.reference_airframe()
    tables = MachTables.from_knots({"Cx": (1.5, 1.9)}, altitude_m=airframe.altitude_m)
    with pytest.raises(AirframeError, match="latched"):
        simulate(airframe, tables.expand(aeroid.model.nominal()),
                 dataclasses.replace(_short(), evaluation="continuous"), tables=tables)
    with pytest.raises(AirframeError, match="9 coefficient values for tables of 10"):
        simulate(airframe, aeroid.model.nominal(), _short(), tables=tables)


def test_mach_sweep_scenario_reads_its_tables():
    scenario = load_scenario(MACH_SWEEP)
    assert scenario.tables.names == ("Cx", "Cmq")
    assert len(scenario.coefficients) == scenario.tables.n_parameters
    assert scenario.airframe.mach_tables().parameter_names() == scenario.tables.parameter_names()
    cx = np.array(scenario.coefficients[:5])
    assert np.all(np.abs(cx / -0.98 - 1.0) <= 0.15 + 1e-9)  # +-15 % of the reference's
    data = aeroid.model.read_toml(MACH_SWEEP)
    data["coefficients"]["Cx"] = [[2.2, -0.8], [1.1, -1.1]]
    with pytest.raises(AirframeError, match=r"\[coefficients\].*increase"):
        aeroid.flights.scenario_from_dict(data, source="s.toml")
    data["coefficients"]["Cx"] = [[2.2]]
    with pytest.raises(AirframeError, match=r"\[coefficients\] Cx"):
        aeroid.flights.scenario_from_dict(data, source="s.toml")


def test_a_table_flight_reads_back_with_its_tables(tmp_path):
    scenario = load_scenario(MACH_SWEEP)
    manoeuvre = dataclasses.replace(scenario.manoeuvre, window_s=(0.0, 0.2))
    flight = simulate(scenario.airframe, scenario.coefficient_vector, manoeuvre,
                      tables=scenario.tables, rng=0)
    flight.write(tmp_path / "f.csv")
    again = aeroid.flights.read_flight(tmp_path / "f.csv")
    assert again.airframe.tables == scenario.airframe.tables
    assert again.metadata["true_parameters"] == flight.metadata["true_parameters"]
    assert again.metadata["true_tables"]["Cmq"] == list(scenario.tables.knots_of("Cmq"))


def test_tables_without_a_speed_of_sound_are_refused_on_load():
    data = aeroid.model.read_toml(MACH_SWEEP)
    data["atmosphere"] = {"density_kgm3": 0.7}
    with pytest.raises(AirframeError, match=r"s.toml: .*\[tables\] needs the speed of sound"):
        aeroid.flights.scenario_from_dict(data, source="s.toml")
    data["tables"]["temperature_K"] = 255.7
    scenario = aeroid.flights.scenario_from_dict(data, source="s.toml")
    assert scenario.tables.speed_of_sound_mps == pytest.approx((1.4 * 287.05287 * 255.7) ** 0.5)


def test_a_study_of_tables_refuses_estimators_without_tables_in_one_line(tmp_path):
    """A study of tables scores table fits (tests/integration/test_study_tables.py); a
    method that fits constants only is refused on load, not per fit."""
    study = tmp_path / "s.toml"
    study.write_text(f'[study]\nruns = 1\nseed = 1\nscenario = "{MACH_SWEEP}"\n'
                     '[[estimators]]\nlabel = "E"\nmethod = "sebm-pso"\n')
    with pytest.raises(aeroid.errors.StudyError, match=r"\[tables\]: E cannot fit tables"):
        aeroid.study.load_study(study)
