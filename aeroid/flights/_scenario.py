"""Scenarios: an airframe, its true coefficients, a manoeuvre and a noise model.

The scenario file format is ``aeroid/data/reference-scenario.toml`` (the embedded
default, copied from the project's reference): the airframe file's tables
``[airframe]``, ``[atmosphere]`` (required) and ``[prior]`` (optional), then
``[initial_state]`` and ``[coefficients]`` (required), ``[actuator]`` and ``[recording]``
(keys left out take the paper's values, :class:`Manoeuvre`) and ``[noise.paper]``,
``[noise.gaussian]``, ``[noise.none]`` (options of each noise model; optional). Unknown
tables and keys and values of the wrong type are one-line errors naming the file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aeroid.errors import AirframeError
from aeroid.flights._noise import NOISE_MODELS, NoiseModel, make_noise
from aeroid.model._airframe import (
    SCENARIO_TABLES,
    Airframe,
    read_toml,
    reference_scenario_data,
)
from aeroid.model._coefficients import NAMES
from aeroid.model._dynamics import STATE_NAMES
from aeroid.model._fileform import check_keys, check_table, integer, number, numbers

#: Most RK4 steps one simulated truth may take (window end x rate x substeps): 1e8 steps
#: are minutes of integration and, at 500 Hz and 8 substeps, 7 hours of flight whose
#: (n, 9) sampled states alone take 900 MB: a window beyond it is a typo, refused before
#: anything is allocated.
MAX_TRUTH_STEPS = 1e8

_STATE_KEYS = ("u_mps", "v_mps", "w_mps", "p_radps", "q_radps", "r_radps",
               "phi_deg", "theta_deg", "psi_deg")


@dataclass(frozen=True, kw_only=True)
class Manoeuvre:
    """The flight to simulate: relay law, initial state and recording window.

    Attributes
    ----------
    command_amplitude : float
        ``A`` of the relay law (:mod:`aeroid.model`).
    command_phase_deg : float
        ``phi0`` [deg].
    initial_state : tuple of 9 float
        State at t = 0 [m/s, rad/s, rad] in :data:`aeroid.model.STATE_NAMES` order.
    sample_rate_hz : float
        Recording (and relay) rate [Hz].
    window_s : tuple of 2 float
        Recorded window [s], both ends included.
    truth_substeps : int
        RK4 steps per sample interval for the truth.
    """

    command_amplitude: float = 0.5
    command_phase_deg: float = 60.0
    initial_state: tuple[float, ...] = (501.7, 0, 0, 0, 0, 0, 0, math.radians(5.0), 0)
    sample_rate_hz: float = 500.0
    window_s: tuple[float, float] = (5.0, 6.0)
    truth_substeps: int = 8

    def __post_init__(self) -> None:
        state = numbers(self.initial_state, 9, "manoeuvre: initial_state")
        object.__setattr__(self, "initial_state", state)
        t0, t1 = numbers(self.window_s, 2, "manoeuvre: window_s")
        if not (0.0 <= t0 < t1):
            raise AirframeError(
                f"manoeuvre: window_s must satisfy 0 <= start < end, got {t0, t1}")
        object.__setattr__(self, "window_s", (t0, t1))
        rate = number(self.sample_rate_hz, "manoeuvre: sample_rate_hz")
        if not rate > 0:
            raise AirframeError("manoeuvre: sample_rate_hz must be positive")
        object.__setattr__(self, "sample_rate_hz", rate)
        substeps = integer(self.truth_substeps, "manoeuvre: truth_substeps")
        if substeps < 1:
            raise AirframeError("manoeuvre: truth_substeps must be >= 1")
        steps = t1 * rate * substeps
        if steps > MAX_TRUTH_STEPS:
            raise AirframeError(
                f"manoeuvre: {t1:g} s at {rate:g} Hz x {substeps} substeps is {steps:.3g} "
                f"RK4 steps (limit {MAX_TRUTH_STEPS:.0e}); shorten window_s")

    @property
    def dt(self) -> float:
        """Sample interval [s]."""
        return 1.0 / self.sample_rate_hz


@dataclass(frozen=True, kw_only=True)
class Scenario:
    """Everything :func:`aeroid.flights.simulate` needs, with its default noise model."""

    airframe: Airframe
    coefficients: tuple[float, ...]
    manoeuvre: Manoeuvre
    noise: NoiseModel
    name: str = "reference"

    @property
    def coefficient_vector(self) -> np.ndarray:
        """The true coefficients, shape (9,)."""
        return np.array(self.coefficients)


#: Keys of the scenario tables (the airframe's own tables are checked by ``Airframe``).
ACTUATOR_KEYS = ("command_amplitude", "command_phase_deg")
RECORDING_KEYS = ("sample_rate_Hz", "window_s", "truth_rk4_substeps")


def scenario_from_dict(data: dict[str, Any], *, source: str = "scenario") -> Scenario:
    """Build a scenario from the parsed file form (see the module docstring).

    Every table and key is checked: unknown tables and keys, missing initial-state keys
    or coefficients, and values of the wrong type are errors. ``[actuator]`` and
    ``[recording]`` keys left out take the :class:`Manoeuvre` defaults (the paper's).

    Raises
    ------
    AirframeError
        One line naming ``source`` and the table or key that is wrong.
    """
    airframe = Airframe.from_dict(data, source=source, other_tables=SCENARIO_TABLES)
    act = check_table(data.get("actuator", {}), f"{source}: [actuator]")
    check_keys(act, ACTUATOR_KEYS, f"{source}: [actuator]")
    init = check_table(data.get("initial_state", {}), f"{source}: [initial_state]")
    check_keys(init, _STATE_KEYS, f"{source}: [initial_state]", required=_STATE_KEYS)
    state = [number(init[k], f"{source}: [initial_state] {k}") for k in _STATE_KEYS]
    state[6:9] = [math.radians(x) for x in state[6:9]]
    rec = check_table(data.get("recording", {}), f"{source}: [recording]")
    check_keys(rec, RECORDING_KEYS, f"{source}: [recording]")
    options: dict[str, Any] = {}
    for key in ACTUATOR_KEYS:
        if key in act:
            options[key] = number(act[key], f"{source}: [actuator] {key}")
    if "sample_rate_Hz" in rec:
        options["sample_rate_hz"] = number(rec["sample_rate_Hz"],
                                           f"{source}: [recording] sample_rate_Hz")
    if "window_s" in rec:
        options["window_s"] = numbers(rec["window_s"], 2, f"{source}: [recording] window_s")
    if "truth_rk4_substeps" in rec:
        options["truth_substeps"] = integer(rec["truth_rk4_substeps"],
                                            f"{source}: [recording] truth_rk4_substeps")
    if "coefficients" not in data:
        raise AirframeError(f"{source}: no [coefficients] table (the true coefficients)")
    table = check_table(data["coefficients"], f"{source}: [coefficients]")
    check_keys(table, NAMES, f"{source}: [coefficients]", required=NAMES)
    coefficients = tuple(number(table[n], f"{source}: [coefficients] {n}") for n in NAMES)
    noise_tables = check_table(data.get("noise", {}), f"{source}: [noise]")
    check_keys(noise_tables, NOISE_MODELS, f"{source}: [noise]")
    noise_options = {name: check_table(table, f"{source}: [noise.{name}]")
                     for name, table in noise_tables.items()}
    try:
        manoeuvre = Manoeuvre(initial_state=tuple(state), **options)
        models = {name: make_noise(name, **opts) for name, opts in noise_options.items()}
    except ValueError as exc:
        raise AirframeError(f"{source}: {exc}") from None
    noise = models.get("paper") or make_noise("paper")
    return Scenario(airframe=airframe, coefficients=coefficients, manoeuvre=manoeuvre,
                    noise=noise, name=Path(source).stem)


def noise_for(scenario_data: dict[str, Any], name: str) -> NoiseModel:
    """Return the noise model ``name`` with the settings of the scenario's ``[noise.NAME]``."""
    return make_noise(name, **scenario_data.get("noise", {}).get(name, {}))


def load_scenario(path: str | Path | None = None) -> Scenario:
    """Load a scenario file; ``None`` gives the embedded reference scenario."""
    if path is None:
        return scenario_from_dict(reference_scenario_data(), source="reference")
    return scenario_from_dict(read_toml(path), source=str(path))


def reference_scenario() -> Scenario:
    """Return the embedded reference scenario (``reference-scenario.toml``)."""
    return load_scenario(None)


__all__ = ["Manoeuvre", "Scenario", "load_scenario", "reference_scenario", "STATE_NAMES"]
