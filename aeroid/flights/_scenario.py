"""Scenarios: an airframe, its true coefficients, a manoeuvre and a noise model.

The scenario file format is ``aeroid/data/reference-scenario.toml`` (the embedded
default, copied from the project's reference): tables ``[airframe]``, ``[atmosphere]``,
``[actuator]``, ``[initial_state]``, ``[recording]``, ``[coefficients]``, ``[noise.paper]``
and optionally ``[prior]`` and ``[noise.gaussian]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aeroid.errors import AirframeError
from aeroid.flights._noise import NoiseModel, make_noise
from aeroid.model._airframe import Airframe, read_toml, reference_scenario_data
from aeroid.model._coefficients import as_vector
from aeroid.model._dynamics import STATE_NAMES

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
        state = tuple(float(x) for x in self.initial_state)
        if len(state) != 9 or not all(math.isfinite(x) for x in state):
            raise ValueError("manoeuvre: initial_state must be 9 finite numbers")
        object.__setattr__(self, "initial_state", state)
        t0, t1 = (float(x) for x in self.window_s)
        if not (0.0 <= t0 < t1):
            raise ValueError(f"manoeuvre: window_s must satisfy 0 <= start < end, got {t0, t1}")
        object.__setattr__(self, "window_s", (t0, t1))
        if not self.sample_rate_hz > 0:
            raise ValueError("manoeuvre: sample_rate_hz must be positive")
        if int(self.truth_substeps) < 1:
            raise ValueError("manoeuvre: truth_substeps must be >= 1")

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


def scenario_from_dict(data: dict[str, Any], *, source: str = "scenario") -> Scenario:
    """Build a scenario from the parsed file form (see the module docstring).

    Raises
    ------
    AirframeError
        One line naming ``source`` and the table or key that is wrong.
    """
    try:
        airframe = Airframe.from_dict(data, source=source)
        act = data.get("actuator", {})
        init = data.get("initial_state", {})
        missing = [k for k in _STATE_KEYS if k not in init]
        if missing:
            raise AirframeError(f"{source}: [initial_state] is missing {', '.join(missing)}")
        state = [float(init[k]) for k in _STATE_KEYS]
        state[6:9] = [math.radians(x) for x in state[6:9]]
        rec = data.get("recording", {})
        manoeuvre = Manoeuvre(
            command_amplitude=float(act.get("command_amplitude", 0.5)),
            command_phase_deg=float(act.get("command_phase_deg", 60.0)),
            initial_state=tuple(state),
            sample_rate_hz=float(rec.get("sample_rate_Hz", 500.0)),
            window_s=tuple(rec.get("window_s", (5.0, 6.0))),  # type: ignore[arg-type]
            truth_substeps=int(rec.get("truth_rk4_substeps", 8)),
        )
        if "coefficients" not in data:
            raise AirframeError(f"{source}: no [coefficients] table (the true coefficients)")
        coefficients = tuple(float(x) for x in as_vector(data["coefficients"]))
        noise_tables = data.get("noise", {})
        noise = make_noise("paper", **noise_tables.get("paper", {}))
    except (ValueError, TypeError) as exc:
        if isinstance(exc, AirframeError) and str(exc).startswith(source):
            raise
        raise AirframeError(f"{source}: {exc}") from None
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
