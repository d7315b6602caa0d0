"""A sensor suite's air-data probe: simulated in the flight's air, read, its airspeed.

**Simulated** (:class:`AirProbe`, ``SensorSuite(air_probe=AirProbe(...))``): the probe
samples the truth every ``imu_rate / rate_hz``-th IMU instant and reads the air-relative
velocity at its position ``r`` (body axes from the c.g.),
``v_air + omega x r`` with ``v_air`` the model's :func:`aeroid.model.equations.air_velocity`
(the body velocity less the wind the truth flew in: steady, plus the Dryden gusts per
sample). Its readings are the single-file simulator's, written by the same noise model
(:meth:`aeroid.flights.GaussianNoise.corrupt_air` and ``corrupt_pitot``, the same options,
the same draws in the same order): ``alpha`` and ``beta`` always, ``airspeed`` with
``airspeed_sd_mps > 0``, the pitot-static ``total_pressure`` and ``static_pressure`` with
either pressure sd positive (static ``p = rho R T`` of the model's air, total ``p r(M)``:
:func:`aeroid.flights.probe_pressures`). Drawn after every other group, so the other
groups of a seed are unchanged by the probe.

**Read** (a suite log's ``[groups.air]``): the channels of ``GROUPS["air"]`` with units,
and ``probe_position_m = [x, y, z]`` (body axes from the c.g. [m]; the single-file
flight's ``metadata["air_data_probe"]["position_m"]``). The pressures are checked as a
single-file log's (:func:`aeroid.flights._pitot.pitot_findings`: both airspeeds, a total
without a static pressure, NaN, the static range, total above static), and a static
pressure alone is refused here (in a suite log a barometer's goes in the ``baro`` group).

**The airspeed of the pressures** (:func:`air_group_airspeed`, the reconstruction's
steady wind): :func:`aeroid.flights.pitot_airspeed` of the group's pressures, Mach from
``p0 / p`` times the speed of sound of the airframe's ``[tables] temperature_K``, else the
ISA at its ``[atmosphere] altitude_m`` (the simulator's air; a suite log has no air
temperature channel), its sd the pressures' propagated by the derivative; the note says
which.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from aeroid.errors import AirframeError, FlightError
from aeroid.flights._flight import Flight
from aeroid.flights._noise import GaussianNoise
from aeroid.flights._pitot import (
    PITOT_CHANNELS,
    STATIC_PRESSURE,
    TOTAL_PRESSURE,
    probe_pressures,
    true_air_temperature,
)
from aeroid.flights._pitot_airspeed import pitot_airspeed
from aeroid.flights._suite_air_read import probe_position
from aeroid.flights._suite_log import SensorGroup
from aeroid.model import (
    R_AIR,
    Airframe,
    as_state,
    constants,
    equations,
)

__all__ = ["AirProbe", "air_group_airspeed", "check_probe_rate", "probe_group", "probe_velocity",
           "suite_probe"]

#: The probe's noise options (:class:`aeroid.flights.GaussianNoise`'s names).
_NOISE = ("alpha_sd_rad", "beta_sd_rad", "airspeed_sd_mps", "total_pressure_sd_pa",
          "static_pressure_sd_pa")


@dataclass(frozen=True, kw_only=True)
class AirProbe:
    """A suite's air-data probe (module docstring): rate [Hz], noise sd (SI), position [m].

    The defaults: 100 Hz, 0.1 deg vanes, a 0.5 m/s airspeed, no pressures, at the c.g.
    """

    rate_hz: float = 100.0
    alpha_sd_rad: float = float(np.radians(0.1))
    beta_sd_rad: float = float(np.radians(0.1))
    airspeed_sd_mps: float = 0.5
    total_pressure_sd_pa: float = 0.0
    static_pressure_sd_pa: float = 0.0
    position_m: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if not (isinstance(self.rate_hz, int | float) and math.isfinite(self.rate_hz)
                and self.rate_hz > 0):
            raise AirframeError(f"sensor suite: air probe rate_hz must be positive, got "
                                f"{self.rate_hz!r}")
        object.__setattr__(self, "position_m", probe_position(self.position_m,
                                                          "sensor suite: air probe position_m",
                                                          AirframeError))
        self.noise()  # refuses bad sd and two airspeeds

    def noise(self) -> GaussianNoise:
        """The single-file noise model of the probe's readings (no IMU noise)."""
        try:
            return GaussianNoise(accel_sd_mps2=0.0, rate_sd_radps=0.0,
                                 **{k: getattr(self, k) for k in _NOISE})
        except AirframeError as exc:
            raise AirframeError(f"sensor suite: air probe: {exc}") from None


def check_probe_rate(probe: AirProbe | None, imu_rate_hz: float) -> None:
    """Refuse, in one line, a probe whose rate does not divide the IMU's (it samples the
    truth at every ``imu_rate / rate_hz``-th IMU instant)."""
    if probe is None:
        return
    stride = imu_rate_hz / probe.rate_hz
    if stride < 1.0 - 1e-9 or abs(stride - round(stride)) > 1e-9:
        raise AirframeError(f"sensor suite: air probe rate_hz = {probe.rate_hz:g} must divide "
                            f"imu_rate_hz = {imu_rate_hz:g}")


def probe_velocity(states: np.ndarray, const: Any, position_m: Any
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The air-relative velocity at the probe, body axes [m/s], each (n,):
    ``air_velocity(states, const) + omega x r`` (``const``: the model constants with the
    wind, per sample or constant; ``states`` (n, N_STATES))."""
    x = as_state(states)
    u, v, w = equations.air_velocity(x, const)
    rx, ry, rz = (float(c) for c in position_m)
    if rx == ry == rz == 0.0:  # at the c.g.: the single-file simulator's, to the bit
        return (np.asarray(u, dtype=float), np.asarray(v, dtype=float),
                np.asarray(w, dtype=float))
    return u + x.q * rz - x.r * ry, v + x.r * rx - x.p * rz, w + x.p * ry - x.q * rx


def probe_group(t: np.ndarray, velocity: tuple[np.ndarray, ...], density_kgm3: Any,
                temperature_k: np.ndarray, probe: AirProbe, rng: np.random.Generator, *,
                offset_s: float = 0.0) -> tuple[SensorGroup, dict[str, np.ndarray]]:
    """The probe's logged group at ``t`` and its true readings (module docstring).

    ``velocity``: the air-relative velocity at the probe at ``t`` (:func:`probe_velocity`),
    ``density_kgm3`` and ``temperature_k`` the air's there (the pressures). Draws from
    ``rng`` as :meth:`GaussianNoise.corrupt_air` then ``corrupt_pitot``.
    """
    noise = probe.noise()
    speed, alpha, beta = equations.air_data(*velocity)
    true = {"alpha": alpha, "beta": beta, "airspeed": speed}
    channels = noise.corrupt_air({"alpha": alpha, "beta": beta}, velocity, rng)
    if noise.logs_pitot:
        total, static = probe_pressures(velocity, density_kgm3, temperature_k)
        true.update(total_pressure=total, static_pressure=static)
        channels = noise.corrupt_pitot(channels, (total, static), rng)
    sd = {"alpha": noise.alpha_sd_rad, "beta": noise.beta_sd_rad,
          "airspeed": noise.airspeed_sd_mps, TOTAL_PRESSURE: noise.total_pressure_sd_pa,
          STATIC_PRESSURE: noise.static_pressure_sd_pa}
    group = SensorGroup("air", np.asarray(t, dtype=float).copy(), channels,
                        {c: s for c, s in sd.items() if s > 0 and c in channels},
                        float(offset_s), "simulated air", probe_position_m=probe.position_m)
    return group, true


def air_group_airspeed(group: SensorGroup, airframe: Airframe | None
                       ) -> tuple[np.ndarray, np.ndarray | None, str]:
    """The airspeed [m/s] of an air group's pressures, its sd per sample (None without both
    pressures' sd) and a note saying how: :func:`aeroid.flights.pitot_airspeed` of the
    group's pressures (module docstring; a per-sample atmosphere's altitude is not the
    group's, so its temperature is the ISA at ``altitude_m``, as the note says).

    Raises
    ------
    FlightError
        :func:`aeroid.flights.pitot_airspeed`'s: the pressures' checks, no temperature.
    """
    if airframe is None:
        raise FlightError(f"{group.source}: the probe's pressures give Mach; its airspeed "
                          "needs the airframe's temperature (no airframe)")
    sd = [group.noise_sd.get(c) for c in PITOT_CHANNELS]
    given = {} if None in sd else {"total_sd_pa": sd[0], "static_sd_pa": sd[1]}
    found = pitot_airspeed(Flight(pd.DataFrame({c: group.channels[c] for c in PITOT_CHANNELS}),
                                  airframe.replace(atmosphere_channel=None),
                                  {"source": group.source}), **given)
    return found.airspeed, found.sd, found.note


def suite_probe(t: np.ndarray, states: np.ndarray, airframe: Airframe, suite: Any,
                rng: np.random.Generator, wind: np.ndarray | None,
                atmosphere: dict[str, np.ndarray] | None,
                air_temperature: np.ndarray | None
                ) -> tuple[SensorGroup, dict[str, np.ndarray]]:
    """The air group of :func:`aeroid.flights.log_trajectory` and its truth at every IMU
    instant (``wind_n wind_e wind_d`` [m/s] with a wind; the probe's clean ``air_alpha``,
    ``air_beta``, ``airspeed`` and, with pressures, ``total_pressure``, ``static_pressure``).

    ``suite``: the :class:`~aeroid.flights.SensorSuite` (its ``air_probe``, rates and
    offsets); the air: ``atmosphere``'s pressure and temperature, else the airframe's
    density and ``air_temperature`` (default the ISA at ``altitude_m``).
    """
    probe = suite.air_probe
    const = constants(airframe)
    if wind is not None:
        const = const._replace(wind_n=wind[:, 0], wind_e=wind[:, 1], wind_d=wind[:, 2])
    if atmosphere is not None:
        temperature = atmosphere["temperature"]
        density: Any = atmosphere["pressure"] / (R_AIR * temperature)
    else:
        temperature = (air_temperature if air_temperature is not None else
                       true_air_temperature(airframe, None, None, t))
        density = const.rho
    velocity = probe_velocity(states, const, probe.position_m)
    every = int(round(suite.imu_rate_hz / probe.rate_hz))
    at = (np.broadcast_to(density, t.shape)[::every], np.asarray(temperature)[::every])
    group, true = probe_group(t[::every], tuple(v[::every] for v in velocity), *at, probe, rng,
                              offset_s=float(dict(suite.offsets_s).get("air", 0.0)))
    speed, alpha, beta = equations.air_data(*velocity)
    truth = {"air_alpha": alpha, "air_beta": beta, "airspeed": speed}
    if "total_pressure" in true:
        truth.update(zip(PITOT_CHANNELS, probe_pressures(velocity, density, temperature),
                         strict=True))
    if wind is not None:
        truth.update(wind_n=wind[:, 0], wind_e=wind[:, 1], wind_d=wind[:, 2])
    return group, truth
