"""Tabled truths that several test modules fly, integrated once per test run (shared helper).

A truth with coefficient tables is integrated by numpy with Mach (and the angle) looked
up at every RK4 stage: 5 s of CPU for the first 6 s of the Mach sweep, 8 s for
``studies/scenarios/alpha_table.toml``. Five modules flew the same sweep truth and three
the same angle-table truth, each its own. The integration draws nothing, so one result
serves them all (same inputs, same numbers). Its arrays are made read-only: a test that
wrote into one raises instead of changing another module's flight.
"""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path
from typing import Any

import numpy as np

from aeroid.flights import Manoeuvre, Scenario, Truth, load_scenario, simulate_truth

SCENARIOS = Path(__file__).parents[1] / "studies" / "scenarios"
#: The Mach sweep (20 s coast) and the 1 s angle-table flight at Mach 1.7.
MACH_SWEEP = SCENARIOS / "mach_sweep.toml"
ALPHA_TABLE = SCENARIOS / "alpha_table.toml"
#: The sweep's first 6 s (Mach 2.19 -> 1.68), the window the table tests fit.
SWEEP_WINDOW_S = (0.5, 6.5)


def table_truth(scenario_file: Path, window_s: tuple[float, float] | None = None,
                changes: dict[str, float] | None = None
                ) -> tuple[Scenario, Manoeuvre, np.ndarray, Truth]:
    """The scenario file's tabled truth over ``window_s`` (None: the file's window).

    ``changes``: table parameters (by name) set to other values than the file's.
    Returns ``(scenario, manoeuvre, parameters, truth)``: the loaded scenario, its
    manoeuvre over the window, the parameters flown (read-only) and the truth
    (read-only arrays), the same objects on every call with the same arguments.
    """
    key = tuple(sorted((changes or {}).items()))
    return _table_truth(str(scenario_file), None if window_s is None else tuple(window_s), key)


@functools.cache
def _table_truth(scenario_file: str, window_s: tuple[float, float] | None,
                 changes: tuple[tuple[str, float], ...]
                 ) -> tuple[Scenario, Manoeuvre, np.ndarray, Truth]:
    scenario = load_scenario(Path(scenario_file))
    manoeuvre = scenario.manoeuvre
    if window_s is not None:
        manoeuvre = dataclasses.replace(manoeuvre, window_s=window_s)
    parameters = np.array(scenario.coefficients, dtype=float)
    names = scenario.tables.parameter_names()
    for name, value in changes:
        parameters[names.index(name)] = value
    truth = simulate_truth(scenario.airframe, parameters, manoeuvre, tables=scenario.tables)
    for value in (parameters, *truth, *vars(truth.schedule).values()):
        _freeze(value)
    return scenario, manoeuvre, parameters, truth


def _freeze(value: Any) -> None:
    if isinstance(value, np.ndarray):
        value.flags.writeable = False
