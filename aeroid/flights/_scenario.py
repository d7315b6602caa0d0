"""Scenarios: an airframe, its true coefficients, a manoeuvre and a noise model.

The scenario file format is ``aeroid/data/reference-scenario.toml`` (the embedded
default, copied from the project's reference): the airframe file's tables
``[airframe]``, ``[atmosphere]`` (required) and ``[prior]`` (optional), then
``[initial_state]`` and ``[coefficients]`` (required), ``[actuator]`` and ``[recording]``
(keys left out take the paper's values, :class:`Manoeuvre`) and ``[noise.paper]``,
``[noise.gaussian]``, ``[noise.none]`` (options of each noise model; optional). Unknown
tables and keys and values of the wrong type are one-line errors naming the file.

``[actuator]`` is the TRUE fin law the simulator flies: the keys of the airframe file's
``[fin_law]`` (:mod:`aeroid.model._actuator`; here all optional, the paper's ``A = 0.5``,
``phi0 = 60 deg``, no delay, no rate limit by default) and how the law is evaluated::

    [actuator]
    command_amplitude = 0.5          # or [[t_s, A], ...]
    command_phase_deg = 60.0         # or [[t_s, deg], ...]
    delay_s = 0.0
    rate_limit_dps = 8000.0          # left out: none
    evaluation = "latched"           # "latched" (default: at each sample instant, held),
                                     # "continuous" (switch instants located in the truth)
    # control_rate_Hz = 2000.0       # a digital relay latched at its own clock instead

``[wind]`` (optional; :mod:`aeroid.flights._turbulence`) is the air the flight crosses: a
steady wind over the ground and Dryden turbulence (MIL-F-8785C); left out, still air::

    [wind]
    north_mps = 3.5                  # steady wind, NED [m/s] (each key optional, 0)
    east_mps = 3.5
    down_mps = 0.0
    turbulence_sd_mps = 3.0          # Dryden intensity per component (0: none)
    scale_length_m = 533.4           # Dryden scale length (MIL-F-8785C, above 2000 ft)

``[air]`` (optional; :mod:`aeroid.flights._air`): the true air temperature, when not
the ISA's (an offset or a profile in time), and whether the flights log it.

A scenario may also carry the airframe file's ``[fin_law]``: what the simulated flights'
airframe tells the estimators (their ``law`` input). It is independent of ``[actuator]``,
so a study can give the estimators a law that differs from the truth (a wrong delay);
left out, the flights' airframe has no fin law.

A true coefficient may be a table in Mach (:class:`aeroid.model.MachTables`): in
``[coefficients]``, ``Cx = [[1.1, -1.13], [1.6, -0.98], [2.2, -0.83]]`` gives its value
at each Mach number (increasing), linear between and held beyond the ends; the speed of
sound is that of the airframe's ``[tables] temperature_K`` or ISA at ``[atmosphere]
altitude_m``. The scenario's ``coefficients`` are then the tables' parameters
(:meth:`~aeroid.model.MachTables.parameter_names`) and ``tables`` the tables. The
airframe's own ``[tables]`` is what the flights tell the fits (like ``[fin_law]``).

``[initial_state] mass_scale`` (optional, default 1) flies the truth with the airframe's
``mass_kg`` times this factor while the flights' airframe keeps ``mass_kg``: a coast
mass with residual propellant the airframe file does not know of (say it with the
file's ``mass_sd_kg``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aeroid.errors import AirframeError
from aeroid.flights._air import Air, air_from_table
from aeroid.flights._noise import NOISE_MODELS, NoiseModel, make_noise
from aeroid.flights._scenario_rows import angle_rows
from aeroid.flights._turbulence import Wind, wind_from_table
from aeroid.model import (
    FIN_LAW_KEYS,
    NAMES,
    SCENARIO_TABLES,
    STATE_NAMES,
    Airframe,
    FinLaw,
    MachTables,
    Profile,
    fileform,
    profile,
    read_toml,
    reference_scenario_data,
)

#: Most RK4 steps one simulated truth may take (window end x rate x substeps): 1e8 steps
#: are minutes of integration and, at 500 Hz and 8 substeps, 7 hours of flight whose
#: (n, 9) sampled states alone take 900 MB: a window beyond it is a typo, refused before
#: anything is allocated.
MAX_TRUTH_STEPS = 1e8

#: How the simulator evaluates the fin law (:class:`Manoeuvre`).
EVALUATIONS = ("latched", "continuous", "control_rate")
#: Manoeuvre fields added for the fin law, with their defaults: left out of
#: :meth:`Manoeuvre.describe` when at the default, so that a study's fingerprint of a
#: manoeuvre without them stays what it was.
FIN_LAW_DEFAULTS = {"delay_s": 0.0, "rate_limit_dps": None, "evaluation": "latched",
                    "control_rate_hz": None}

#: Plausible true mass / the airframe's mass_kg (``[initial_state] mass_scale``): a
#: residual propellant is a few percent; beyond a factor 2 the file's mass is a typo.
MASS_SCALE_RANGE = (0.5, 2.0)

_STATE_KEYS = ("u_mps", "v_mps", "w_mps", "p_radps", "q_radps", "r_radps",
               "phi_deg", "theta_deg", "psi_deg")


@dataclass(frozen=True, kw_only=True)
class Manoeuvre:
    """The flight to simulate: fin law and its evaluation, initial state, recording window.

    Attributes
    ----------
    command_amplitude : float or tuple of (time_s, value) pairs
        ``A`` of the relay law (:class:`aeroid.model.FinLaw`), constant or piecewise
        linear in time.
    command_phase_deg : float or tuple of (time_s, value) pairs
        ``phi0`` [deg], the same.
    initial_state : tuple of float, one per state
        State at t = 0 [m/s, rad/s, rad] in :data:`aeroid.model.STATE_NAMES` order.
    sample_rate_hz : float
        Recording (and relay) rate [Hz].
    window_s : tuple of 2 float
        Recorded window [s], both ends included.
    truth_substeps : int
        RK4 steps per sample interval for the truth.
    delay_s : float
        Actuator time delay [s], >= 0.
    rate_limit_dps : float or None
        Actuator rate limit [deg/s]; None: none (a switch is a jump).
    evaluation : {"latched", "continuous", "control_rate"}
        ``latched``: the law evaluated at each sample instant and held to the next (the
        paper's digital relay at the log clock); ``continuous``: switched where the
        switching function of the true roll angle crosses zero; ``control_rate``: a
        digital relay latched at its own clock, ``control_rate_hz``.
    control_rate_hz : float or None
        The relay's clock [Hz] (``control_rate`` only); its instants are ``m /
        control_rate_hz`` from t = 0.
    wind : Wind or None
        The air the flight crosses (steady wind, Dryden turbulence); None: still air.
    air : Air or None
        Its true temperature when not the ISA's (``[air]``, :mod:`aeroid.flights._air`).
    mass_scale : float
        The true mass over the airframe's ``mass_kg`` (default 1; in
        :data:`MASS_SCALE_RANGE`): the truth is flown with it, the flights' airframe
        keeps ``mass_kg`` (:meth:`flown`).
    """

    command_amplitude: Profile = 0.5
    command_phase_deg: Profile = 60.0
    initial_state: tuple[float, ...] = (501.7, 0, 0, 0, 0, 0, 0, math.radians(5.0), 0)
    sample_rate_hz: float = 500.0
    window_s: tuple[float, float] = (5.0, 6.0)
    truth_substeps: int = 8
    delay_s: float = 0.0
    rate_limit_dps: float | None = None
    evaluation: str = "latched"
    control_rate_hz: float | None = None
    wind: Wind | None = None
    mass_scale: float = 1.0
    air: Air | None = None

    def __post_init__(self) -> None:
        if self.wind is not None and not isinstance(self.wind, Wind):
            raise AirframeError(f"manoeuvre: wind must be a Wind or None, got {self.wind!r}")
        for name in ("command_amplitude", "command_phase_deg"):
            object.__setattr__(self, name, profile(getattr(self, name), f"manoeuvre: {name}"))
        try:
            law = self.fin_law(1.0)  # checks the delay and the rate limit
        except AirframeError as exc:
            raise AirframeError(str(exc).replace("fin law:", "manoeuvre:")) from None
        object.__setattr__(self, "delay_s", law.delay_s)
        object.__setattr__(self, "rate_limit_dps", law.rate_limit_dps)
        if self.evaluation not in EVALUATIONS:
            raise AirframeError(f"manoeuvre: evaluation must be one of "
                                f"{', '.join(map(repr, EVALUATIONS))}, got {self.evaluation!r}")
        if (self.evaluation == "control_rate") != (self.control_rate_hz is not None):
            raise AirframeError("manoeuvre: control_rate_Hz goes with evaluation = "
                                "\"control_rate\" and nothing else")
        if self.control_rate_hz is not None:
            rate = fileform.number(self.control_rate_hz, "manoeuvre: control_rate_Hz")
            if rate <= 0:
                raise AirframeError(f"manoeuvre: control_rate_Hz must be positive, got {rate:g}")
            object.__setattr__(self, "control_rate_hz", rate)
        state = fileform.numbers(self.initial_state, len(STATE_NAMES), "manoeuvre: initial_state")
        object.__setattr__(self, "initial_state", state)
        t0, t1 = fileform.numbers(self.window_s, 2, "manoeuvre: window_s")
        if not (0.0 <= t0 < t1):
            raise AirframeError(
                f"manoeuvre: window_s must satisfy 0 <= start < end, got {t0, t1}")
        object.__setattr__(self, "window_s", (t0, t1))
        rate = fileform.number(self.sample_rate_hz, "manoeuvre: sample_rate_hz")
        if not rate > 0:
            raise AirframeError("manoeuvre: sample_rate_hz must be positive")
        object.__setattr__(self, "sample_rate_hz", rate)
        scale = fileform.number(self.mass_scale, "manoeuvre: mass_scale")
        if not MASS_SCALE_RANGE[0] <= scale <= MASS_SCALE_RANGE[1]:
            raise AirframeError(f"manoeuvre: mass_scale must be in {MASS_SCALE_RANGE[0]:g}.."
                                f"{MASS_SCALE_RANGE[1]:g} (true mass / the airframe's "
                                f"mass_kg), got {scale:g}")
        object.__setattr__(self, "mass_scale", scale)
        substeps = fileform.integer(self.truth_substeps, "manoeuvre: truth_substeps")
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

    def flown(self, airframe: Airframe) -> Airframe:
        """Return the airframe the truth is flown with: ``mass_kg`` times :attr:`mass_scale`."""
        if self.mass_scale == 1.0:
            return airframe
        return airframe.replace(mass_kg=airframe.mass_kg * self.mass_scale)

    def fin_law(self, delta_max_rad: float) -> FinLaw:
        """Return the manoeuvre's fin law for a fin throw ``delta_max_rad`` [rad]."""
        return FinLaw(delta_max_rad=delta_max_rad, command_amplitude=self.command_amplitude,
                      command_phase_deg=self.command_phase_deg, delay_s=self.delay_s,
                      rate_limit_dps=self.rate_limit_dps)

    def describe(self) -> dict[str, Any]:
        """Return the fields as a dict, leaving out the fin-law fields at their defaults.

        A manoeuvre of the paper's latched relay describes as before the fin-law fields
        existed (:data:`FIN_LAW_DEFAULTS`): study fingerprints made from it stay valid.
        """
        fields = dataclasses.asdict(self)
        if fields["mass_scale"] == 1.0:  # as before the key existed (fingerprints)
            del fields["mass_scale"]
        return {k: v for k, v in fields.items()
                if (k not in FIN_LAW_DEFAULTS or v != FIN_LAW_DEFAULTS[k])
                and not (k in ("wind", "air") and v is None)}  # as before these existed


@dataclass(frozen=True, kw_only=True)
class Scenario:
    """Everything :func:`aeroid.flights.simulate` needs, with its default noise model."""

    airframe: Airframe
    coefficients: tuple[float, ...]
    manoeuvre: Manoeuvre
    noise: NoiseModel
    name: str = "reference"
    tables: MachTables | None = None

    @property
    def coefficient_vector(self) -> np.ndarray:
        """The true coefficients, shape (N_COEFFICIENTS,) (with :attr:`tables`: their
        parameters, shape (tables.n_parameters,))."""
        return np.array(self.coefficients)


#: Keys of the scenario tables (the airframe's own tables are checked by ``Airframe``).
ACTUATOR_KEYS = (*FIN_LAW_KEYS, "evaluation", "control_rate_Hz")
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
    act = fileform.check_table(data.get("actuator", {}), f"{source}: [actuator]")
    fileform.check_keys(act, ACTUATOR_KEYS, f"{source}: [actuator]")
    if act and airframe.fin == "passive":
        raise AirframeError(f'{source}: [actuator] with a passive fin (fin = "passive"): the '
                            "fins do not move and the simulator flies no fin law; drop it")
    init = fileform.check_table(data.get("initial_state", {}), f"{source}: [initial_state]")
    fileform.check_keys(init, (*_STATE_KEYS, "mass_scale"), f"{source}: [initial_state]",
                        required=_STATE_KEYS)
    state = [fileform.number(init[k], f"{source}: [initial_state] {k}") for k in _STATE_KEYS]
    state = [math.radians(x) if k.endswith("_deg") else x for k, x in zip(_STATE_KEYS, state,
                                                                           strict=True)]
    rec = fileform.check_table(data.get("recording", {}), f"{source}: [recording]")
    fileform.check_keys(rec, RECORDING_KEYS, f"{source}: [recording]")
    options = _actuator_options(act, f"{source}: [actuator]")
    if "mass_scale" in init:
        options["mass_scale"] = fileform.number(init["mass_scale"],
                                                f"{source}: [initial_state] mass_scale")
    if "sample_rate_Hz" in rec:
        options["sample_rate_hz"] = fileform.number(rec["sample_rate_Hz"],
                                           f"{source}: [recording] sample_rate_Hz")
    if "window_s" in rec:
        options["window_s"] = fileform.numbers(rec["window_s"], 2,
                                               f"{source}: [recording] window_s")
    if "truth_rk4_substeps" in rec:
        options["truth_substeps"] = fileform.integer(rec["truth_rk4_substeps"],
                                            f"{source}: [recording] truth_rk4_substeps")
    if "coefficients" not in data:
        raise AirframeError(f"{source}: no [coefficients] table (the true coefficients)")
    table = fileform.check_table(data["coefficients"], f"{source}: [coefficients]")
    fileform.check_keys(table, NAMES, f"{source}: [coefficients]", required=NAMES)
    coefficients, tables = _true_coefficients(table, airframe, f"{source}: [coefficients]")
    if "wind" in data:
        options["wind"] = wind_from_table(data["wind"], f"{source}: [wind]")
    if "air" in data:  # the true air temperature (non-ISA)
        options["air"] = air_from_table(data["air"], f"{source}: [air]")
    noise_tables = fileform.check_table(data.get("noise", {}), f"{source}: [noise]")
    fileform.check_keys(noise_tables, NOISE_MODELS, f"{source}: [noise]")
    noise_options = {name: fileform.check_table(table, f"{source}: [noise.{name}]")
                     for name, table in noise_tables.items()}
    try:
        manoeuvre = Manoeuvre(initial_state=tuple(state), **options)
        models = {name: make_noise(name, **opts) for name, opts in noise_options.items()}
    except ValueError as exc:
        raise AirframeError(f"{source}: {exc}") from None
    noise = models.get("paper") or make_noise("paper")
    return Scenario(airframe=airframe, coefficients=coefficients, manoeuvre=manoeuvre,
                    noise=noise, name=Path(source).stem, tables=tables)


def _true_coefficients(table: Any, airframe: Airframe, where: str
                       ) -> tuple[tuple[float, ...], MachTables | None]:
    """The ``[coefficients]`` values: numbers, or ``[[mach, value], ...]`` tables, or
    ``{alpha_deg = [[deg, value], ...]}`` tables in the total angle of attack."""
    if not any(isinstance(table[n], list | dict) for n in NAMES):
        return tuple(fileform.number(table[n], f"{where} {n}") for n in NAMES), None
    knots, values = {}, []
    angle_knots: dict[str, tuple[float, ...]] = {}
    for name in NAMES:
        value = table[name]
        if isinstance(value, dict):  # a table in the total angle of attack
            rows = angle_rows(value, f"{where} {name}")
            angle_knots[name] = tuple(math.radians(row[0]) for row in rows)
            values.extend(row[1] for row in rows)
            continue
        if not isinstance(value, list):
            values.append(fileform.number(value, f"{where} {name}"))
            continue
        rows = [fileform.numbers(row, 2, f"{where} {name} (rows [mach, value])")
                for row in value]
        if not rows:
            raise AirframeError(f"{where} {name}: an empty table (rows [mach, value])")
        knots[name] = tuple(row[0] for row in rows)
        values.extend(row[1] for row in rows)
    spec = airframe.tables
    try:
        sound = (spec.speed_of_sound(airframe.altitude_m) if spec is not None
                 else airframe.speed_of_sound_mps)
        tables = MachTables(tuple(knots.items()), sound, tuple(angle_knots.items()))
    except AirframeError as exc:
        raise AirframeError(f"{where}: {exc}") from None
    return tuple(values), tables


def _actuator_options(act: Any, where: str) -> dict[str, Any]:
    """Return the :class:`Manoeuvre` options of an ``[actuator]`` table."""
    options: dict[str, Any] = {}
    for key in ("command_amplitude", "command_phase_deg"):
        if key in act:
            options[key] = profile(act[key], f"{where} {key}")
    for key, field in (("delay_s", "delay_s"), ("rate_limit_dps", "rate_limit_dps"),
                       ("control_rate_Hz", "control_rate_hz")):
        if key in act:
            options[field] = fileform.number(act[key], f"{where} {key}")
    if "evaluation" in act:
        options["evaluation"] = fileform.text(act["evaluation"], f"{where} evaluation")
    elif "control_rate_Hz" in act:
        options["evaluation"] = "control_rate"
    return options


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


__all__ = ["EVALUATIONS", "FIN_LAW_DEFAULTS", "MASS_SCALE_RANGE", "Manoeuvre", "Scenario",
           "load_scenario", "reference_scenario", "STATE_NAMES"]
