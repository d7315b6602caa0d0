"""Sensors: lever-arm accelerometers (eq. 28) and measurement-noise models (eq. 43).

Accelerometers measure specific force (no gravity): at position ``R`` from the c.g.,
``a_R = (F_A + F_T) / m + wdot x R + w x (w x R)`` (eq. 28, notes), with ``wdot`` from
eqs. 5-7.

Noise models
------------
* :class:`PaperNoise` (eq. 43): multiplicative uniform, ``s_m = s (1 + xi (2U - 1))``,
  ``xi`` per channel group (accelerations; rates), other channels clean; and the
  estimator's copy of each accelerometer-position component perturbed once per flight
  with ``xi_pos`` (a position error; the simulator itself uses the true positions).
* :class:`GaussianNoise`: additive zero-mean Gaussian, one standard deviation per
  channel (a realistic IMU); optional Gaussian position error [m]; optional air data
  (an air-data probe: the vane angles ``alpha``, ``beta`` and an ``airspeed`` channel,
  each with its own sd; :meth:`GaussianNoise.corrupt_air`).
* :class:`NoNoise`.

Air data (``alpha_sd_rad``, ``beta_sd_rad``, ``airspeed_sd_mps`` of
:class:`GaussianNoise`; all 0 by default, the flights as before to the bit): the
simulator records the air-relative angles and speed of the truth (in moving air the
wind's; in still air the inertial ones) and :meth:`GaussianNoise.corrupt_air` adds
white Gaussian noise to them, drawn after everything else (the IMU noise and the
position error draw the same numbers with or without it). A positive
``airspeed_sd_mps`` is what makes the flight log an ``airspeed`` channel (a probe that
measures one); with 0 it logs none. The paper's noise (eq. 43) has no air data.

A pitot-static probe (``total_pressure_sd_pa``, ``static_pressure_sd_pa``; 0 by default):
either positive logs both ``total_pressure`` and ``static_pressure`` [Pa], the true ones
of :func:`aeroid.flights.probe_pressures` plus white Gaussian noise of these sd
(:meth:`GaussianNoise.corrupt_pitot`, one (n, 2) draw after everything else, the probe's
angles and airspeed included). With an ``airspeed_sd_mps`` too it is refused: a log with
both airspeeds is (:mod:`aeroid.flights._pitot`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any, Protocol

import numpy as np

from aeroid.errors import AirframeError
from aeroid.model import ACCEL_CHANNELS, OUTPUT_CHANNELS, RATE_CHANNELS, equations, fileform

#: :class:`GaussianNoise`'s air-data options (module docstring).
AIR_NOISE_OPTIONS: tuple[str, ...] = ("alpha_sd_rad", "beta_sd_rad", "airspeed_sd_mps",
                                      "total_pressure_sd_pa", "static_pressure_sd_pa")


def _check_options(model: Any) -> None:
    """Refuse options that are not finite non-negative numbers (a boolean is not one).

    Run at construction, so a study or scenario with ``rates_xi = "x"`` stops with one
    line before its first flight instead of in the middle of a study.
    """
    for f in fields(model):
        if f.name == "name":
            continue
        value = getattr(model, f.name)
        if not (fileform.is_number(value) and math.isfinite(value) and value >= 0):
            raise AirframeError(f"noise model {model.name!r}: {f.name} must be a finite "
                                f"number >= 0, got {value!r}")
        object.__setattr__(model, f.name, float(value))


class NoiseModel(Protocol):
    """What the simulator needs from a noise model."""

    name: str

    def corrupt(self, channels: dict[str, np.ndarray], rng: np.random.Generator
                ) -> dict[str, np.ndarray]:
        """Return noisy copies of the measured channels (others unchanged)."""
        ...

    def perturb_positions(self, positions: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Return the estimator's copy of the triad positions, shape (2, 3)."""
        ...

    def position_sd(self, positions: np.ndarray) -> np.ndarray:
        """Return the sd of the position error of each component given ``positions`` (2, 3)."""
        ...

    def output_sd(self, outputs: np.ndarray, *, form: str = "heteroscedastic") -> np.ndarray:
        """Return the measurement-error sd of every output, shape of ``outputs`` (n, m)."""
        ...

    def to_dict(self) -> dict[str, Any]:
        """Return the model's settings (for flight metadata and reports)."""
        ...


#: How a multiplicative noise's sd is taken: per sample from ``|s_k|`` (what eq. 43 says),
#: or per channel from the channel's RMS.
NOISE_FORMS: tuple[str, ...] = ("heteroscedastic", "homoscedastic")


def _per_output(outputs: np.ndarray, accel: float, rate: float) -> tuple[np.ndarray, np.ndarray]:
    """Return ``outputs`` as floats (n, m) and one value per column: ``accel`` on the
    accelerometer channels, ``rate`` on the gyros (:data:`OUTPUT_CHANNELS` columns)."""
    outputs = np.asarray(outputs, dtype=float)
    if outputs.ndim != 2 or outputs.shape[1] != len(OUTPUT_CHANNELS):
        raise ValueError(f"noise sd: outputs must have shape (n, {len(OUTPUT_CHANNELS)}) "
                         f"({', '.join(OUTPUT_CHANNELS)}), got {outputs.shape}")
    return outputs, np.array([accel if c in ACCEL_CHANNELS else rate for c in OUTPUT_CHANNELS])


@dataclass(frozen=True, kw_only=True)
class PaperNoise:
    """Eq. 43: ``s_m = s (1 + xi (2U - 1))``, U ~ U[0, 1] per sample and channel.

    Draw order (fixed, so a seed gives the same flight everywhere): the six
    accelerations (one (n, 6) block), then p, q, r ((n, 3)), then the position error.
    """

    accelerations_xi: float = 0.05
    rates_xi: float = 0.05
    accel_position_xi: float = 0.1
    name: str = field(default="paper", init=False)

    def __post_init__(self) -> None:
        _check_options(self)

    def corrupt(self, channels: dict[str, np.ndarray], rng: np.random.Generator
                ) -> dict[str, np.ndarray]:
        """Apply multiplicative uniform noise to the accelerations and rates."""
        out = dict(channels)
        for names, xi in ((ACCEL_CHANNELS, self.accelerations_xi),
                          (RATE_CHANNELS, self.rates_xi)):
            n = len(channels[names[0]])
            u = rng.random((n, len(names)))
            for j, name in enumerate(names):
                out[name] = channels[name] * (1.0 + xi * (2.0 * u[:, j] - 1.0))
        return out

    def perturb_positions(self, positions: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Perturb each position component multiplicatively with ``accel_position_xi``."""
        positions = np.asarray(positions, dtype=float)
        u = rng.random(positions.shape)
        return positions * (1.0 + self.accel_position_xi * (2.0 * u - 1.0))

    def position_sd(self, positions: np.ndarray) -> np.ndarray:
        """``xi |R| / sqrt(3)``: the sd of the uniform +-xi relative error, per component."""
        return self.accel_position_xi * np.abs(np.asarray(positions, dtype=float)) / math.sqrt(3)

    def output_sd(self, outputs: np.ndarray, *, form: str = "heteroscedastic") -> np.ndarray:
        """Return the sd of eq. 43's error on the noise-free ``outputs`` (n, m), same shape.

        U[-xi, xi] has sd ``xi / sqrt(3)``: ``|s_k| xi / sqrt(3)`` per sample
        (``form="heteroscedastic"``, what eq. 43 says) or ``xi RMS(s) / sqrt(3)`` per
        channel (``"homoscedastic"``); columns :data:`aeroid.model.OUTPUT_CHANNELS`.
        """
        outputs, xi = _per_output(outputs, self.accelerations_xi, self.rates_xi)
        if form == "heteroscedastic":
            return np.abs(outputs) * xi / math.sqrt(3.0)
        if form == "homoscedastic":
            rms = np.sqrt(np.mean(outputs**2, axis=0))
            return np.broadcast_to(rms * xi / math.sqrt(3.0), outputs.shape).copy()
        raise ValueError(f"noise sd: unknown form {form!r} (expected {' or '.join(NOISE_FORMS)})")

    def to_dict(self) -> dict[str, Any]:
        """Return the settings."""
        return {"model": self.name, "accelerations_xi": self.accelerations_xi,
                "rates_xi": self.rates_xi, "accel_position_xi": self.accel_position_xi}


@dataclass(frozen=True, kw_only=True)
class GaussianNoise:
    """Additive zero-mean Gaussian noise with one standard deviation per channel group.

    Defaults describe a tactical-grade IMU sampled at 500 Hz: 0.05 m/s^2 on each
    acceleration, 0.005 rad/s on each rate; positions known exactly
    (``position_sd_m = 0``).

    Decision: unlike eq. 43's multiplicative error, which leaves the zero y, z
    components of triad 1 at zero, an additive position error moves every component.
    At the reference roll rate (p ~ 50 rad/s) a radial offset of 1 mm adds a
    centripetal p^2 * 1 mm ~ 2.5 m/s^2 to the lateral channels, fifty times the
    accelerometer noise, and it ruins every estimator that trusts the positions
    (measured: EKF Czq errors of thousands of percent). So the default is zero, and a
    position error is an explicit choice of the study (``studies/realistic_imu.toml``
    shows its effect).
    """

    accel_sd_mps2: float = 0.05
    rate_sd_radps: float = 0.005
    position_sd_m: float = 0.0
    #: vane noise on the logged angle of attack and of sideslip [rad] (0: the true ones)
    alpha_sd_rad: float = 0.0
    beta_sd_rad: float = 0.0
    #: noise of a logged ``airspeed`` channel [m/s]; 0: no airspeed channel (module docstring)
    airspeed_sd_mps: float = 0.0
    #: noise of a pitot-static probe's total and static pressures [Pa]; both 0: no probe
    total_pressure_sd_pa: float = 0.0
    static_pressure_sd_pa: float = 0.0
    name: str = field(default="gaussian", init=False)

    def __post_init__(self) -> None:
        _check_options(self)
        if self.logs_pitot and self.airspeed_sd_mps > 0:
            raise AirframeError("noise model 'gaussian': airspeed_sd_mps and a probe's "
                                "pressures (total_pressure_sd_pa, static_pressure_sd_pa) log "
                                "two airspeeds, which the fits refuse; give one of them")

    def corrupt(self, channels: dict[str, np.ndarray], rng: np.random.Generator
                ) -> dict[str, np.ndarray]:
        """Add Gaussian noise to the accelerations and rates."""
        out = dict(channels)
        for names, sd in ((ACCEL_CHANNELS, self.accel_sd_mps2),
                          (RATE_CHANNELS, self.rate_sd_radps)):
            n = len(channels[names[0]])
            e = rng.standard_normal((n, len(names)))
            for j, name in enumerate(names):
                out[name] = channels[name] + sd * e[:, j]
        return out

    def perturb_positions(self, positions: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Add Gaussian position error with ``position_sd_m``."""
        positions = np.asarray(positions, dtype=float)
        return positions + self.position_sd_m * rng.standard_normal(positions.shape)

    def position_sd(self, positions: np.ndarray) -> np.ndarray:
        """``position_sd_m`` for every component."""
        return np.full(np.shape(positions), float(self.position_sd_m))

    @property
    def logs_air_data(self) -> bool:
        """True when the flights carry air data with noise (:meth:`corrupt_air`)."""
        return max(self.alpha_sd_rad, self.beta_sd_rad, self.airspeed_sd_mps) > 0

    @property
    def logs_pitot(self) -> bool:
        """True when the flights carry a pitot-static probe's pressures (:meth:`corrupt_pitot`)."""
        return max(self.total_pressure_sd_pa, self.static_pressure_sd_pa) > 0

    def corrupt_pitot(self, channels: dict[str, np.ndarray],
                      pressures: tuple[np.ndarray, np.ndarray], rng: np.random.Generator
                      ) -> dict[str, np.ndarray]:
        """Return ``channels`` with ``total_pressure`` and ``static_pressure`` [Pa]: the true
        ``pressures`` ``(total, static)``, each (n,), plus noise of their sd (one (n, 2)
        draw)."""
        out = dict(channels)
        total, static = (np.asarray(p, dtype=float) for p in pressures)
        e = rng.standard_normal((total.size, 2))
        out["total_pressure"] = total + self.total_pressure_sd_pa * e[:, 0]
        out["static_pressure"] = static + self.static_pressure_sd_pa * e[:, 1]
        return out

    def corrupt_air(self, channels: dict[str, np.ndarray], air_velocity: tuple[np.ndarray, ...],
                    rng: np.random.Generator) -> dict[str, np.ndarray]:
        """Return ``channels`` with the probe's readings of the air-relative velocity.

        ``air_velocity`` is the true ``(u, v, w)`` relative to the air, body axes [m/s],
        each shape (n,). ``alpha`` and ``beta`` [rad] (eqs. 14-16 of it) get white
        Gaussian noise of ``alpha_sd_rad``, ``beta_sd_rad`` (one (n, 2) draw, when either
        is positive); with ``airspeed_sd_mps > 0`` an ``airspeed`` channel [m/s], its
        magnitude plus noise of that sd (one (n,) draw, after the angles').
        """
        out = dict(channels)
        speed, alpha, beta = equations.air_data(*(np.asarray(c, dtype=float)
                                                  for c in air_velocity))
        if self.alpha_sd_rad > 0 or self.beta_sd_rad > 0:
            e = rng.standard_normal((len(speed), 2))
            out["alpha"] = alpha + self.alpha_sd_rad * e[:, 0]
            out["beta"] = beta + self.beta_sd_rad * e[:, 1]
        if self.airspeed_sd_mps > 0:
            out["airspeed"] = speed + self.airspeed_sd_mps * rng.standard_normal(len(speed))
        return out

    def output_sd(self, outputs: np.ndarray, *, form: str = "heteroscedastic") -> np.ndarray:
        """Return ``accel_sd_mps2`` / ``rate_sd_radps`` for every output, shape of ``outputs``
        (additive noise: both forms are the same)."""
        outputs, sd = _per_output(outputs, self.accel_sd_mps2, self.rate_sd_radps)
        if form not in NOISE_FORMS:
            raise ValueError(f"noise sd: unknown form {form!r} "
                             f"(expected {' or '.join(NOISE_FORMS)})")
        return np.broadcast_to(sd, outputs.shape).copy()

    def to_dict(self) -> dict[str, Any]:
        """Return the settings."""
        air = {k: getattr(self, k) for k in AIR_NOISE_OPTIONS if getattr(self, k) > 0}
        return {"model": self.name, "accel_sd_mps2": self.accel_sd_mps2,
                "rate_sd_radps": self.rate_sd_radps, "position_sd_m": self.position_sd_m,
                **air}  # the air data only when given: older sidecars unchanged


@dataclass(frozen=True, kw_only=True)
class NoNoise:
    """Perfect sensors and perfectly known positions."""

    name: str = field(default="none", init=False)

    def corrupt(self, channels: dict[str, np.ndarray], rng: np.random.Generator
                ) -> dict[str, np.ndarray]:
        """Return the channels unchanged."""
        return dict(channels)

    def perturb_positions(self, positions: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Return the positions unchanged."""
        return np.asarray(positions, dtype=float).copy()

    def position_sd(self, positions: np.ndarray) -> np.ndarray:
        """Zero: the positions are known."""
        return np.zeros(np.shape(positions))

    def output_sd(self, outputs: np.ndarray, *, form: str = "heteroscedastic") -> np.ndarray:
        """Zero for every output: no measurement error."""
        outputs, _ = _per_output(outputs, 0.0, 0.0)
        if form not in NOISE_FORMS:
            raise ValueError(f"noise sd: unknown form {form!r} "
                             f"(expected {' or '.join(NOISE_FORMS)})")
        return np.zeros(outputs.shape)

    def to_dict(self) -> dict[str, Any]:
        """Return the settings."""
        return {"model": self.name}


NOISE_MODELS = {"paper": PaperNoise, "gaussian": GaussianNoise, "none": NoNoise}


def make_noise(name: str, **options: Any) -> NoiseModel:
    """Return a noise model by name (``paper``, ``gaussian`` or ``none``) and options.

    Raises
    ------
    AirframeError
        One line naming the unknown model, an unknown option or an option of the wrong
        type (a ``ValueError``).
    """
    try:
        cls = NOISE_MODELS[name]
    except (KeyError, TypeError):
        raise AirframeError(
            f"unknown noise model {name!r} (expected one of {', '.join(NOISE_MODELS)})"
        ) from None
    try:
        return cls(**options)  # type: ignore[no-any-return]
    except TypeError:
        allowed = [f.name for f in fields(cls) if f.name != "name"]
        unknown = sorted(str(k) for k in options if k not in allowed)
        raise AirframeError(
            f"noise model {name!r}: unknown option(s) {unknown}; allowed {allowed}"
        ) from None


def noise_from_dict(data: dict[str, Any]) -> NoiseModel:
    """Rebuild a noise model from :meth:`to_dict` output (``{"model": NAME, **options}``)."""
    data = dict(data)
    if "model" not in data:
        raise AirframeError(f"noise settings {data!r} name no model")
    return make_noise(data.pop("model"), **data)
