"""Flights of a rolling airframe made by JSBSim, an independent flight-dynamics engine.

:func:`make_flight` writes the aircraft definition of a :class:`FlightConfig`
(:mod:`._aircraft`), flies it in JSBSim from the initial condition at t = 0
(:mod:`._engine`) and logs the window at the sample rate: the channels aeroid reads (SI,
radians) as an aeroid :class:`~aeroid.flights.Flight`, and everything else the engine
knows (density, gravity, altitude, forces, planet-relative rates, the switch instants) as
a :class:`Truth`.

* The accelerometers are eq. 28 at the true positions from the engine's
  non-gravitational forces and its inertial angular acceleration and rates:
  ``a_R = (F_aero + F_thrust) / m + wdot x R + w x (w x R)``.
* The deflection: JSBSim evaluates the fin law once per frame. With the Adams-Bashforth
  integrators a frame's state derivative enters the integrated state as if it acted on
  ``[t_n - dt/2, t_n + dt/2]`` (the weights of the history sum to 1 with first moment
  1/2; with the Euler integrator ``[t_n, t_n + dt]``). :func:`switch_events` turns the
  frames' deflections into the equivalent continuous relay's switch instants
  (:attr:`Truth.switch_times`), and the logged ``delta`` is that relay's value at the
  log instant (:func:`relay_at_samples`).
* The airframe's ``[atmosphere]`` is the ISA altitude of the window's mean density.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import brentq

from aeroid.flights import ACCEL_CHANNELS, Flight, NoiseModel, NoNoise
from aeroid.flights import make_flight as aeroid_make_flight
from aeroid.model import Airframe, as_dict, save_airframe
from aeroid.model import density as isa_density

from ._aircraft import FlightConfig
from ._engine import run_jsbsim


@dataclass(frozen=True, eq=False)
class Truth:
    """What the engine knows about a flight beyond aeroid's channels.

    Attributes
    ----------
    config : FlightConfig
    airframe : Airframe
        The true airframe (true positions; ``altitude_m`` gives the window's mean density).
    coefficients : ndarray, shape (9,)
    data : pandas.DataFrame
        Per log sample: aeroid's channels (noise-free) plus ``rho`` [kg/m^3], ``gravity``
        [m/s^2], ``altitude`` [m], planet-relative rates ``p_ecef..`` [rad/s], forces
        ``FAX..FTZ`` [N], moments [N m], ``pdot..rdot`` [rad/s^2], ``udot..wdot``
        [m/s^2], JSBSim's ``alpha_jsbsim``, ``beta_jsbsim``, ``qbar`` [Pa] and its one-frame
        late ``a_pilot_*`` [m/s^2], the total wind ``wind_n, wind_e, wind_d`` (steady plus
        turbulence, NED) [m/s], the rotational gusts ``p_turb..`` [rad/s] and the
        ``airspeed`` [m/s].
    frame_dt : float
        JSBSim frame [s].
    switch_times, switch_values : ndarray, shape (m,)
        The continuous relay's switch instants equivalent to the engine's frames
        (:func:`switch_events`) from t = 0 to the window's end [s], and the deflection
        after each [rad].
    initial_delta : float
        Deflection at t = 0 [rad].
    """

    config: FlightConfig
    airframe: Airframe
    coefficients: np.ndarray
    data: pd.DataFrame
    frame_dt: float
    switch_times: np.ndarray
    switch_values: np.ndarray
    initial_delta: float

    def delta_at(self, t: np.ndarray) -> np.ndarray:
        """Return the effective deflection at times ``t`` [rad] (switch at ``t``: new value)."""
        idx = np.searchsorted(self.switch_times, np.asarray(t, dtype=float), side="right")
        values = np.concatenate([[self.initial_delta], self.switch_values])
        return values[idx]


def switch_events(frame_t: np.ndarray, frame_delta: np.ndarray, delta_max: float,
                  shift: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Return the continuous relay's switch instants equivalent to the frames' deflections.

    Frame ``n`` acts on the integrated state as the interval ``[t_n - shift, t_n - shift +
    dt]``. A switch from ``a`` to ``b`` whose frames ``n0..n1-1`` hold intermediate
    (sub-frame) values is placed where a single step from ``a`` to ``b`` has the same
    integral over those intervals; with no intermediate frame that is ``t_n1 - shift``.
    Intermediate frames that return to the old value are a pulse of the same integral,
    centred on them.

    Returns
    -------
    times, values : ndarray
        Switch instants [s] and the deflection after each [rad].
    initial : float
        The deflection at t = 0 [rad].
    """
    dt = float(frame_t[1] - frame_t[0])
    start = frame_t - shift
    full = np.abs(np.abs(frame_delta) - delta_max) <= 1e-12 * delta_max
    cur = float(np.copysign(delta_max, frame_delta[0]))
    initial, times, values = cur, [], []
    n, count = 1, len(frame_delta)
    while n < count:
        if frame_delta[n] == cur:
            n += 1
            continue
        n0 = n
        while n < count and not full[n]:
            n += 1
        if n == count:
            break
        new = float(frame_delta[n])
        area, t0, t1 = float(np.sum(frame_delta[n0:n])) * dt, start[n0], start[n]
        if new != cur:
            times.append((area - new * t1 + cur * t0) / (cur - new))
            values.append(new)
        else:
            width = (area - cur * (t1 - t0)) / (-2.0 * cur)
            centre = 0.5 * (t0 + t1)
            times += [centre - 0.5 * width, centre + 0.5 * width]
            values += [-cur, cur]
        cur = new
        n += 1
    return np.array(times), np.array(values), initial


def relay_at_samples(log: pd.DataFrame, relay: np.ndarray) -> pd.DataFrame:
    """Give each sample the continuous relay's deflection at its instant.

    A sample that falls on a sub-frame switching frame carries an intermediate deflection
    (the relay's mean over the frame) while the relay itself is at ``relay`` (the value of
    the equivalent switch instants, :func:`switch_events`, at the sample). The deflection
    and, through the engine's own d(F_Z)/d(delta) and d(M_Y)/d(delta), the forces and the
    accelerations ``wdot`` and ``qdot`` (mass and ``iy`` from the engine) are moved to
    that value; every other sample is unchanged (``relay_corrected`` marks the moved ones).
    """
    log = log.copy()
    change = np.asarray(relay, dtype=float) - log["delta_frame"].to_numpy()
    log["delta"] = relay
    log["FAZ"] = log["FAZ"] + log["fz_per_delta"] * change
    log["wdot"] = log["wdot"] + log["fz_per_delta"] * change / log["mass"]
    log["MY"] = log["MY"] + log["my_per_delta"] * change
    log["qdot"] = log["qdot"] + log["my_per_delta"] * change / log["iy"]
    log["relay_corrected"] = change != 0.0
    return log


def sensor_accelerations(log: pd.DataFrame, mass_kg: float, positions: np.ndarray
                         ) -> np.ndarray:
    """Return eq. 28 for each triad from the engine's forces and rates, shape (n, 2, 3)."""
    force = log[["FAX", "FAY", "FAZ"]].to_numpy() + log[["FTX", "FTY", "FTZ"]].to_numpy()
    omega = log[["p", "q", "r"]].to_numpy()
    omega_dot = log[["pdot", "qdot", "rdot"]].to_numpy()
    out = []
    for pos in np.asarray(positions, dtype=float):
        pos = np.broadcast_to(pos, omega.shape)
        out.append(force / mass_kg + np.cross(omega_dot, pos)
                   + np.cross(omega, np.cross(omega, pos)))
    return np.stack(out, axis=1)


def isa_altitude(rho: float) -> float:
    """Return the altitude [m] at which aeroid's ISA density equals ``rho`` [kg/m^3]."""
    return float(brentq(lambda h: float(isa_density(h)) - rho, -2000.0, 20000.0, xtol=1e-9))


def true_airframe(config: FlightConfig, mean_rho: float) -> Airframe:
    """Return the aeroid airframe of ``config`` with the ISA altitude of ``mean_rho``."""
    return Airframe(
        diameter_m=config.diameter_m, length_m=config.length_m, mass_kg=config.mass_kg,
        ix_kgm2=config.ix_kgm2, iy_kgm2=config.iy_kgm2, iz_kgm2=config.iz_kgm2,
        thrust_n=config.thrust_n,
        delta_max_deg=None if config.fin == "passive" else config.delta_max_deg, fin=config.fin,
        accel1_position_m=config.accel1_position_m,
        accel2_position_m=config.accel2_position_m,
        altitude_m=isa_altitude(mean_rho), prior=config.prior)


def make_flight(config: FlightConfig | None = None, *, noise: NoiseModel | None = None,
                rng: np.random.Generator | int | None = None) -> tuple[Flight, Truth]:
    """Fly ``config`` in JSBSim and return aeroid's view of the flight and the truth.

    Parameters
    ----------
    config : FlightConfig, optional
        Default: ``FlightConfig()`` (the climbing flight ``xe_climb``).
    noise : aeroid NoiseModel, optional
        Sensor noise (e.g. :class:`aeroid.GaussianNoise`); default none.
    rng : numpy.random.Generator or int, optional
        Source of the noise draws.

    Returns
    -------
    flight : Flight
        aeroid's channels only (t, ax1..az2, p, q, r, delta, u, v, w, alpha, beta, phi,
        theta, psi; in moving air (``FlightConfig.moving_air``) alpha and beta are air-relative);
        its airframe's ``[atmosphere]`` is the window's mean density and its metadata
        holds ``true_coefficients``, ``true_accel_positions_m`` and ``source``, and in
        still air ``wind = "still"`` (:func:`aeroid.flights.declared_wind`).
    truth : Truth
    """
    config = FlightConfig() if config is None else config
    noise = NoNoise() if noise is None else noise
    rng = np.random.default_rng(rng)
    log, frame_t, frame_delta, frame_dt = run_jsbsim(config)
    shift = 0.0 if config.integrator == "euler" else 0.5 * frame_dt
    if config.fin == "passive":  # no relay: the deflection is 0 throughout
        times, values, initial = np.array([]), np.array([]), 0.0
    else:
        times, values, initial = switch_events(frame_t, frame_delta,
                                               math.radians(config.delta_max_deg), shift)
    relay = np.concatenate([[initial], values])[
        np.searchsorted(times, log["t"].to_numpy(), side="right")]
    log = relay_at_samples(log, relay)
    airframe = true_airframe(config, float(log["rho"].mean()))
    accel = sensor_accelerations(log, config.mass_kg, airframe.accel_positions).reshape(-1, 6)
    for j, name in enumerate(ACCEL_CHANNELS):
        log[name] = accel[:, j]
    u, v, w = (log[c].to_numpy() for c in ("u", "v", "w"))
    log["alpha"] = np.arctan2(w, u)
    log["beta"] = np.arcsin(v / np.sqrt(u * u + v * v + w * w))
    if config.moving_air:  # a vane's angles: the engine's air-relative ones
        log["alpha"], log["beta"] = log["alpha_jsbsim"], log["beta_jsbsim"]
    truth = Truth(config=config, airframe=airframe, coefficients=config.coefficient_vector,
                  data=log, frame_dt=frame_dt, switch_times=times, switch_values=values,
                  initial_delta=initial)
    channels = {c: log[c].to_numpy() for c in
                ("t", *ACCEL_CHANNELS, "p", "q", "r", "delta", "u", "v", "w", "alpha", "beta",
                 "phi", "theta", "psi")}
    channels = noise.corrupt(channels, rng)
    metadata = {"source": f"jsbsim:{config.name}", "noise": noise.to_dict(),
                "true_coefficients": as_dict(config.coefficient_vector),
                "true_accel_positions_m": airframe.accel_positions.tolist(),
                "engine": {"name": "JSBSim", "planet": config.planet,
                           "integrator": config.integrator,
                           "frame_rate_hz": config.frame_rate_hz}}
    if not config.moving_air:  # the air flown, said as aeroid's simulator says it
        metadata["wind"] = "still"  # (in moving air nothing: a log that does not say)
    return aeroid_make_flight(channels, airframe, metadata), truth


def write_flight(flight: Flight, directory: str | Path, stem: str = "flight"
                 ) -> tuple[Path, Path]:
    """Write ``<stem>.csv`` (no sidecar) and ``<stem>-airframe.toml`` for ``aeroid estimate``.

    ``aeroid estimate DIR/flight.csv --airframe DIR/flight-airframe.toml`` reads them.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    csv = directory / f"{stem}.csv"
    toml = directory / f"{stem}-airframe.toml"
    flight.data.to_csv(csv, index=False, float_format="%.17g")
    save_airframe(flight.airframe, toml)
    return csv, toml


__all__ = ["FlightConfig", "Truth", "make_flight", "relay_at_samples", "run_jsbsim",
           "sensor_accelerations", "switch_events", "true_airframe", "write_flight"]
