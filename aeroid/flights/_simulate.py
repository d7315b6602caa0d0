"""Make "flight test" data: integrate the truth, sample it, add sensor noise.

Conventions (reference/README.md, so that the embedded reference agrees with the
independent reference flight to about 1e-6): the truth starts at t = 0 and is
integrated with RK4 at ``dt / truth_substeps``; the relay is evaluated at each sample
instant ``t_k = k dt`` from the true roll angle and held until ``t_{k+1}``; the
recorded ``delta_k`` is that held value, and the accelerometers at ``t_k`` are computed
with it (eq. 28 at the true positions). Samples in the window ``[t0, t1]`` (both ends)
are recorded.
"""

from __future__ import annotations

import numpy as np

from aeroid.flights._flight import STATE_CHANNELS, Flight, make_flight
from aeroid.flights._noise import ACCEL_CHANNELS, NoiseModel, NoNoise
from aeroid.flights._scenario import Manoeuvre, Scenario
from aeroid.model._actuator import RelayActuator
from aeroid.model._airframe import Airframe
from aeroid.model._coefficients import as_dict, as_vector
from aeroid.model._dynamics import accelerometers, constants
from aeroid.model._integrate import propagate


def simulate_truth(airframe: Airframe, coefficients: np.ndarray, manoeuvre: Manoeuvre,
                   *, backend: str = "auto") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integrate the closed relay loop from t = 0 to the end of the window.

    Returns
    -------
    t : ndarray, shape (n,)
        Sample times ``k dt`` [s], k = 0..n-1.
    states : ndarray, shape (n, 9)
        True states at the samples.
    delta : ndarray, shape (n,)
        Fin deflection latched at each sample [rad].
    """
    const = constants(airframe)
    relay = RelayActuator(delta_max_rad=airframe.delta_max_rad,
                          command_amplitude=manoeuvre.command_amplitude,
                          command_phase_rad=np.radians(manoeuvre.command_phase_deg))
    dt = manoeuvre.dt
    n = int(round(manoeuvre.window_s[1] / dt)) + 1
    states = np.empty((n, 9))
    delta = np.empty(n)
    x = np.array(manoeuvre.initial_state)
    c = as_vector(coefficients)[None, :]
    for k in range(n):
        states[k] = x
        delta[k] = relay(x[6])
        if k < n - 1:
            x = propagate(x, c, delta[k:k + 1], dt, const,
                          substeps=manoeuvre.truth_substeps, backend=backend)[0, -1]
    return np.arange(n) * dt, states, delta


def simulate(
    airframe: Airframe,
    coefficients: np.ndarray,
    manoeuvre: Manoeuvre,
    noise: NoiseModel | None = None,
    *,
    rng: np.random.Generator | int | None = None,
    backend: str = "auto",
) -> Flight:
    """Simulate a recorded flight.

    Parameters
    ----------
    airframe : Airframe
        The true airframe (its accelerometer positions are the true ones).
    coefficients : array_like, shape (9,) or mapping
        True coefficients.
    manoeuvre : Manoeuvre
    noise : NoiseModel, optional
        Sensor noise and position error; default :class:`~aeroid.flights.NoNoise`.
    rng : numpy.random.Generator or int, optional
        Source of every random draw (normalised once with ``default_rng``).
    backend : {"auto", "numba", "numpy"}
        Integration backend (:func:`aeroid.model.propagate`).

    Returns
    -------
    Flight
        Recorded window; its airframe carries the estimator's copy of the sensor
        positions, ``metadata`` the truth (coefficients, positions), noise and seed.
    """
    coefficients = as_vector(coefficients)
    truth = simulate_truth(airframe, coefficients, manoeuvre, backend=backend)
    return record_flight(airframe, coefficients, manoeuvre, truth, noise, rng=rng)


def record_flight(
    airframe: Airframe,
    coefficients: np.ndarray,
    manoeuvre: Manoeuvre,
    truth: tuple[np.ndarray, np.ndarray, np.ndarray],
    noise: NoiseModel | None = None,
    *,
    rng: np.random.Generator | int | None = None,
) -> Flight:
    """Record a flight from an integrated truth: window, accelerometers, noise.

    ``simulate(...)`` is ``record_flight(..., simulate_truth(...), ...)``; callers that
    simulate many noisy flights of one truth (the study runner) integrate it once.

    Parameters
    ----------
    truth : tuple of ndarray
        ``(t, states, delta)`` from :func:`simulate_truth` for the same airframe,
        coefficients and manoeuvre.
    Other parameters
        As :func:`simulate`.
    """
    noise = noise or NoNoise()
    seed = rng if isinstance(rng, int | np.integer) else None
    rng = np.random.default_rng(rng)
    coefficients = as_vector(coefficients)
    t, states, delta = truth
    k0 = int(round(manoeuvre.window_s[0] / manoeuvre.dt))
    t, states, delta = t[k0:], states[k0:], delta[k0:]
    accel = accelerometers(states, delta, coefficients, constants(airframe),
                           airframe.accel_positions).reshape(-1, 6)
    channels = {"t": t}
    channels.update({name: accel[:, j] for j, name in enumerate(ACCEL_CHANNELS)})
    channels.update({name: states[:, j] for j, name in enumerate(STATE_CHANNELS)})
    channels["delta"] = delta
    channels = noise.corrupt(channels, rng)
    positions = noise.perturb_positions(airframe.accel_positions, rng)
    sd = noise.position_sd(positions)  # the estimators are told how uncertain they are
    seen = airframe.replace(accel1_position_m=tuple(positions[0]),
                            accel2_position_m=tuple(positions[1]),
                            accel1_position_sd_m=tuple(sd[0]), accel2_position_sd_m=tuple(sd[1]))
    metadata = {
        "noise": noise.to_dict(),
        "seed": None if seed is None else int(seed),
        "true_coefficients": as_dict(coefficients),
        "true_accel_positions_m": airframe.accel_positions.tolist(),
        "manoeuvre": {"command_amplitude": manoeuvre.command_amplitude,
                      "command_phase_deg": manoeuvre.command_phase_deg,
                      "sample_rate_hz": manoeuvre.sample_rate_hz,
                      "window_s": list(manoeuvre.window_s)},
    }
    return make_flight(channels, seen, metadata)


def simulate_scenario(scenario: Scenario, noise: NoiseModel | None = None, *,
                      rng: np.random.Generator | int | None = None) -> Flight:
    """Simulate ``scenario`` with ``noise`` (default: the scenario's own noise model)."""
    return simulate(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                    scenario.noise if noise is None else noise, rng=rng)
