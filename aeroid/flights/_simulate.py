"""Make "flight test" data: integrate the truth, sample it, add sensor noise.

Conventions (reference/README.md, so that the embedded reference agrees with the
independent reference flight to about 1e-6): the truth starts at t = 0 and is
integrated with RK4 at ``dt / truth_substeps``; the relay is evaluated at each sample
instant ``t_k = k dt`` from the true roll angle and held until ``t_{k+1}``; the
recorded ``delta_k`` is that held value, and the accelerometers at ``t_k`` are computed
with it (eq. 28 at the true positions). Samples in the window ``[t0, t1]`` (both ends)
are recorded.

That is the manoeuvre's default ``evaluation = "latched"``. With ``"continuous"``, or
``"control_rate"`` (a relay latched at a clock of its own), or an actuator delay or rate
limit, the relay loop is closed inside the truth integration
(:mod:`aeroid.flights._relay_loop`): the fin deflection is a piecewise-linear schedule
whose knots split the RK4 steps, the recorded ``delta_k`` is the deflection at ``t_k``
(after a jump at ``t_k``), and the accelerometers see it. Every flight's metadata
carries the true deflection in the window (``delta_knots``: the knots of its
:class:`~aeroid.model.Schedule`, a jump being two knots at one time) and the commanded
switches (``command_switches``: instants and the command after each, before the delay).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from aeroid.flights._flight import STATE_CHANNELS, Flight, make_flight
from aeroid.flights._noise import ACCEL_CHANNELS, NoiseModel, NoNoise
from aeroid.flights._relay_loop import RelayLoop
from aeroid.flights._scenario import Manoeuvre, Scenario
from aeroid.model import (
    Airframe,
    Schedule,
    accelerometers,
    as_dict,
    as_vector,
    constants,
    propagate,
)


class Truth(NamedTuple):
    """A simulated truth from t = 0 (:func:`simulate_truth`).

    Attributes
    ----------
    t : ndarray, shape (n,)
        Sample times ``k dt`` [s].
    states : ndarray, shape (n, 9)
        True states at the samples.
    delta : ndarray, shape (n,)
        Fin deflection at each sample [rad] (after a jump at the sample).
    schedule : Schedule
        The true fin deflection from t = 0.
    command_t, command_delta : ndarray, shape (m,)
        Commanded switch instants [s] (before the actuator delay) and the command after
        each [rad].
    """

    t: np.ndarray
    states: np.ndarray
    delta: np.ndarray
    schedule: Schedule
    command_t: np.ndarray
    command_delta: np.ndarray


def _latched(airframe: Airframe, coefficients: np.ndarray, manoeuvre: Manoeuvre,
             backend: str) -> Truth:
    """The paper's relay, evaluated at each sample instant and held (no delay, no rate)."""
    const = constants(airframe)
    law = manoeuvre.fin_law(airframe.delta_max_rad)
    dt = manoeuvre.dt
    n = int(round(manoeuvre.window_s[1] / dt)) + 1
    t = np.arange(n) * dt
    states = np.empty((n, len(STATE_CHANNELS)))
    delta = np.empty(n)
    x = np.array(manoeuvre.initial_state)
    c = as_vector(coefficients)[None, :]
    varying = law.time_varying
    for k in range(n):
        states[k] = x
        delta[k] = law(x[6], t[k] if varying else None)
        if k < n - 1:
            x = propagate(x, c, delta[k:k + 1], dt, const,
                          substeps=manoeuvre.truth_substeps, backend=backend)[0, -1]
    change = np.flatnonzero(np.diff(delta)) + 1
    return Truth(t, states, delta, Schedule.hold(t, delta), t[change], delta[change])


def _passive(airframe: Airframe, coefficients: np.ndarray, manoeuvre: Manoeuvre,
             backend: str) -> Truth:
    """A passive fin (``fin = "passive"``): no fin law, the deflection 0 throughout."""
    n = int(round(manoeuvre.window_s[1] / manoeuvre.dt)) + 1
    t = np.arange(n) * manoeuvre.dt
    delta = np.zeros(n)
    states = propagate(np.array(manoeuvre.initial_state), as_vector(coefficients)[None, :],
                       delta[:-1], manoeuvre.dt, constants(airframe),
                       substeps=manoeuvre.truth_substeps, backend=backend)[0]
    return Truth(t, states, delta, Schedule.hold(t, delta), t[:0], delta[:0])


def simulate_truth(airframe: Airframe, coefficients: np.ndarray, manoeuvre: Manoeuvre,
                   *, backend: str = "auto") -> Truth:
    """Integrate the closed relay loop from t = 0 to the end of the window.

    A passive-fin airframe (``fin = "passive"``) has no relay: its deflection is 0 and
    the manoeuvre's fin law is not used.

    Returns
    -------
    Truth
        ``(t, states, delta, schedule, command_t, command_delta)``; its first three
        fields are the sample times [s], shape (n,), the true states at the samples,
        shape (n, 9), and the fin deflection at each sample [rad], shape (n,).
    """
    if airframe.fin == "passive":
        return _passive(airframe, coefficients, manoeuvre, backend)
    law = manoeuvre.fin_law(airframe.delta_max_rad)
    if manoeuvre.evaluation == "latched" and law.delay_s == 0 and law.rate_limit_dps is None:
        return _latched(airframe, coefficients, manoeuvre, backend)
    rate = (None if manoeuvre.evaluation == "continuous" else
            manoeuvre.control_rate_hz or manoeuvre.sample_rate_hz)
    substeps = manoeuvre.truth_substeps
    n = int(round(manoeuvre.window_s[1] / manoeuvre.dt)) + 1
    h = manoeuvre.dt / substeps
    loop = RelayLoop(law, as_vector(coefficients), constants(airframe),
                     np.array(manoeuvre.initial_state), h, (n - 1) * substeps,
                     control_rate_hz=rate, backend=backend)
    states = loop.run(every=substeps)
    t = loop.grid(np.arange(n) * substeps)
    return Truth(t, states, loop.schedule.at(t), loop.schedule,
                 np.array(loop.commands[0]), np.array(loop.commands[1]))


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
    coefficients : array_like, shape (N_COEFFICIENTS,) or mapping
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
    truth: Truth | tuple[np.ndarray, np.ndarray, np.ndarray],
    noise: NoiseModel | None = None,
    *,
    rng: np.random.Generator | int | None = None,
) -> Flight:
    """Record a flight from an integrated truth: window, accelerometers, noise.

    ``simulate(...)`` is ``record_flight(..., simulate_truth(...), ...)``; callers that
    simulate many noisy flights of one truth (the study runner) integrate it once.

    Parameters
    ----------
    truth : Truth or tuple of ndarray
        From :func:`simulate_truth` for the same airframe, coefficients and manoeuvre
        (a plain ``(t, states, delta)`` is taken as a deflection held over each
        interval).
    Other parameters
        As :func:`simulate`.
    """
    noise = noise or NoNoise()
    seed = rng if isinstance(rng, int | np.integer) else None
    rng = np.random.default_rng(rng)
    coefficients = as_vector(coefficients)
    if not isinstance(truth, Truth):
        t, states, delta = truth
        change = np.flatnonzero(np.diff(delta)) + 1
        truth = Truth(t, states, delta, Schedule.hold(t, delta), t[change], delta[change])
    k0 = int(round(manoeuvre.window_s[0] / manoeuvre.dt))
    t, states, delta = truth.t[k0:], truth.states[k0:], truth.delta[k0:]
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
        "manoeuvre": _manoeuvre_metadata(manoeuvre),
        "actuator": _actuator_metadata(manoeuvre, airframe),
        **_switch_metadata(truth, float(t[0]), float(t[-1])),
    }
    return make_flight(channels, seen, metadata)


def _manoeuvre_metadata(manoeuvre: Manoeuvre) -> dict[str, float | list[float]]:
    """The manoeuvre's numbers (the sidecar accepts numbers and lists of numbers here)."""
    out: dict[str, float | list[float]] = {
        key: value for key in ("command_amplitude", "command_phase_deg")
        if isinstance(value := getattr(manoeuvre, key), float)}
    out.update(sample_rate_hz=manoeuvre.sample_rate_hz, window_s=list(manoeuvre.window_s))
    return out


def _actuator_metadata(manoeuvre: Manoeuvre, airframe: Airframe) -> dict[str, object]:
    """The true fin law (the ``[fin_law]`` table's form) and how it was evaluated."""
    if airframe.fin == "passive":
        return {"fin": "passive"}
    table: dict[str, object] = dict(manoeuvre.fin_law(airframe.delta_max_rad).to_table())
    table["evaluation"] = manoeuvre.evaluation
    if manoeuvre.control_rate_hz is not None:
        table["control_rate_Hz"] = manoeuvre.control_rate_hz
    return table


def _switch_metadata(truth: Truth, start: float, end: float) -> dict[str, dict[str, list]]:
    """The true deflection's knots and the commanded switches within ``[start, end]``."""
    sched = truth.schedule
    inside = (sched.times > start) & (sched.times < end)
    times = [start, *sched.times[inside].tolist(), end]
    values = [float(sched.at(start)), *sched.values[inside].tolist(), float(sched.before(end))]
    if float(sched.at(end)) != values[-1]:  # a jump at the last sample
        times.append(end)
        values.append(float(sched.at(end)))
    commands = (truth.command_t >= start) & (truth.command_t <= end)
    return {"delta_knots": {"t": times, "delta": values},
            "command_switches": {"t": truth.command_t[commands].tolist(),
                                 "delta": truth.command_delta[commands].tolist()}}


def simulate_scenario(scenario: Scenario, noise: NoiseModel | None = None, *,
                      rng: np.random.Generator | int | None = None) -> Flight:
    """Simulate ``scenario`` with ``noise`` (default: the scenario's own noise model)."""
    return simulate(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                    scenario.noise if noise is None else noise, rng=rng)
