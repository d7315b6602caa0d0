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

A manoeuvre's ``wind`` (:class:`~aeroid.flights._turbulence.Wind`) is the air the flight
crosses: the model's loads see the air-relative velocity; the states stay over the
ground. Its Dryden gusts are drawn from the simulation's generator before the sensor
noise, on the sample grid, and enter the truth integration as per-sample wind
(exogenous columns, linear within each interval); the recorded ``alpha`` and ``beta``
are then the air-relative angles (what a vane measures). ``metadata["wind"]`` holds
the ``[wind]`` table flown, all zeros in still air (:mod:`aeroid.flights._declared_air`:
the log says what air it was). Turbulence needs the latched relay (the closed relay loop with
switch instants inside the truth takes constants only: refused in one line).
"""

from __future__ import annotations

import numpy as np

from aeroid.errors import AirframeError
from aeroid.flights._air import flown_tables
from aeroid.flights._air_temperature import AIR_TEMPERATURE
from aeroid.flights._declared_air import wind_metadata
from aeroid.flights._flight import STATE_CHANNELS, Flight, air_angles, make_flight
from aeroid.flights._noise import ACCEL_CHANNELS, NoiseModel, NoNoise
from aeroid.flights._pitot import probe_pressures, true_air_temperature
from aeroid.flights._relay_loop import RelayLoop
from aeroid.flights._scenario import Manoeuvre, Scenario
from aeroid.flights._sim_metadata import actuator_metadata, manoeuvre_metadata, switch_metadata
from aeroid.flights._thrust_flight import recorded_constants, sample_thrust
from aeroid.flights._truth import Truth, passive_truth
from aeroid.model import (
    PHI,
    PSI,
    THETA,
    Airframe,
    Constants,
    MachTables,
    Schedule,
    accelerometers,
    as_dict,
    as_state,
    as_vector,
    constants,
    equations,
    exogenous_table,
    propagate,
    rk4_step,
    state_derivative,
)


def _latched(airframe: Airframe, coefficients: np.ndarray, manoeuvre: Manoeuvre,
             backend: str, const: Constants | None = None,
             exogenous: np.ndarray | None = None) -> Truth:
    """The paper's relay, evaluated at each sample instant and held (no delay, no rate).

    ``const``: the model constants (default the airframe's); ``exogenous``: a per-sample
    table (n, len(EXOGENOUS)) over the whole truth (a gusty wind), or None.
    """
    const = constants(airframe) if const is None else const
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
                          substeps=manoeuvre.truth_substeps, backend=backend,
                          exogenous=None if exogenous is None else exogenous[k:k + 2])[0, -1]
    change = np.flatnonzero(np.diff(delta)) + 1
    return Truth(t, states, delta, Schedule.hold(t, delta), t[change], delta[change])


def _latched_tables(airframe: Airframe, parameters: np.ndarray, tables: MachTables,
                    manoeuvre: Manoeuvre) -> Truth:
    """:func:`_latched` with coefficient tables: numpy RK4, coefficients at each stage's Mach.

    The numba kernels take constant coefficients; this is the numpy right-hand side
    (:func:`aeroid.model.state_derivative`) with the coefficients of
    :meth:`aeroid.model.MachTables.coefficient_array` at every RK4 stage, the model the
    output-error graph integrates (benchmarks/bench_tables.py measures its cost).
    """
    const = constants(airframe)
    flown, temperature = flown_tables(tables, manoeuvre.air, airframe.altitude_m)
    assert flown is not None  # tables given
    law = manoeuvre.fin_law(airframe.delta_max_rad)
    dt = manoeuvre.dt
    h = dt / manoeuvre.truth_substeps
    n = int(round(manoeuvre.window_s[1] / dt)) + 1
    t = np.arange(n) * dt
    states = np.empty((n, len(STATE_CHANNELS)))
    delta = np.empty(n)
    x = np.array(manoeuvre.initial_state)

    def rhs(_t: float, y: np.ndarray, d: float) -> np.ndarray:  # at each stage's temperature
        return state_derivative(y, d, flown.coefficient_array(parameters, y, temperature(_t)),
                                const)

    varying = law.time_varying
    with np.errstate(all="ignore"):
        for k in range(n):
            states[k] = x
            delta[k] = law(x[6], t[k] if varying else None)
            if k < n - 1:
                for sub in range(manoeuvre.truth_substeps):
                    x = rk4_step(rhs, t[k] + sub * h, x, h, delta[k])
    change = np.flatnonzero(np.diff(delta)) + 1
    return Truth(t, states, delta, Schedule.hold(t, delta), t[change], delta[change])


def simulate_truth(airframe: Airframe, coefficients: np.ndarray, manoeuvre: Manoeuvre,
                   *, backend: str = "auto", tables: MachTables | None = None,
                   rng: np.random.Generator | None = None) -> Truth:
    """Integrate the closed relay loop from t = 0 to the end of the window.

    With ``tables`` (:class:`aeroid.model.MachTables`), ``coefficients`` are the tables'
    parameters (:meth:`~aeroid.model.MachTables.parameter_names`), evaluated at each RK4
    stage's Mach by numpy (``backend`` unused); only the latched relay without delay or
    rate limit, in still air, is supported then (anything else: one-line error).
    ``rng``: the source of the manoeuvre's Dryden gusts (required with turbulence,
    unused otherwise).
    A passive-fin airframe (``fin = "passive"``) has no relay: its deflection is 0 and
    the manoeuvre's fin law is not used.

    Returns
    -------
    Truth
        ``(t, states, delta, schedule, command_t, command_delta, wind)``; its first three
        fields are the sample times [s], shape (n,), the true states at the samples,
        shape (n, 9), and the fin deflection at each sample [rad], shape (n,).
    """
    airframe = manoeuvre.flown(airframe)  # the true mass (Manoeuvre.mass_scale)
    if airframe.fin == "passive":
        if tables is not None or manoeuvre.wind is not None:
            raise AirframeError("simulate: a passive-fin airframe is simulated in still air "
                                "with constant coefficients only (no tables, no wind)")
        return passive_truth(airframe, coefficients, manoeuvre, backend)
    law = manoeuvre.fin_law(airframe.delta_max_rad)
    plain = (manoeuvre.evaluation == "latched" and law.delay_s == 0
             and law.rate_limit_dps is None)
    if tables is not None:
        if not plain or manoeuvre.wind is not None:
            raise AirframeError("simulate: coefficient tables are simulated in still air with "
                                "the latched relay without delay or rate limit only")
        return _latched_tables(airframe, _parameters(coefficients, tables), tables, manoeuvre)
    if airframe.thrust_curve is not None:  # the motor: the latched relay in still air
        if not plain or manoeuvre.wind is not None:
            raise AirframeError("simulate: a thrust curve is flown with the latched relay "
                                "without delay or rate limit, in still air, only")
        n = int(round(manoeuvre.window_s[1] / manoeuvre.dt)) + 1
        return _latched(airframe, coefficients, manoeuvre, backend, exogenous=exogenous_table(
            constants(airframe), n, sample_thrust(airframe.thrust_curve, np.arange(n) *
                                                  manoeuvre.dt, airframe.thrust_n,
                                                  manoeuvre.mass_scale)))
    if manoeuvre.wind is not None:
        return _windy(airframe, coefficients, manoeuvre, backend, plain, rng)
    if plain:
        return _latched(airframe, coefficients, manoeuvre, backend)
    return _relay_loop(airframe, coefficients, manoeuvre, backend, constants(airframe))


def _windy(airframe: Airframe, coefficients: np.ndarray, manoeuvre: Manoeuvre, backend: str,
           latched: bool, rng: np.random.Generator | None) -> Truth:
    """The truth in the manoeuvre's wind (module docstring)."""
    wind = manoeuvre.wind
    assert wind is not None
    const = wind.constants(constants(airframe))
    n = int(round(manoeuvre.window_s[1] / manoeuvre.dt)) + 1
    if not wind.turbulent:
        truth = (_latched(airframe, coefficients, manoeuvre, backend, const) if latched
                 else _relay_loop(airframe, coefficients, manoeuvre, backend, const))
        return truth._replace(wind=np.tile(np.array(wind.steady_ned_mps), (n, 1)))
    if not latched:
        raise AirframeError("manoeuvre: Dryden turbulence is simulated with the latched relay "
                            "only (no delay, rate limit or continuous evaluation)")
    if rng is None:
        raise AirframeError("manoeuvre: turbulence needs the simulation's random generator "
                            "(rng) for its gusts")
    x0 = np.array(manoeuvre.initial_state)
    # rows: each NED axis in body axes (the columns of the NED-to-body rotation R), so
    # this matrix is R^T and takes the body velocity to NED
    body_to_ned = np.array([equations.ned_to_body(x0[PHI], x0[THETA], x0[PSI], *e)
                            for e in np.eye(3)])
    velocity_ned = body_to_ned @ x0[:3]
    gusts = wind.gusts(n, manoeuvre.dt, velocity_ned, rng)
    truth = _latched(airframe, coefficients, manoeuvre, backend, const,
                     wind.exogenous(constants(airframe), gusts))
    return truth._replace(wind=np.array(wind.steady_ned_mps) + gusts)


def _relay_loop(airframe: Airframe, coefficients: np.ndarray, manoeuvre: Manoeuvre,
                backend: str, const: Constants) -> Truth:
    """The relay loop closed inside the truth integration (module docstring)."""
    law = manoeuvre.fin_law(airframe.delta_max_rad)
    rate = (None if manoeuvre.evaluation == "continuous" else
            manoeuvre.control_rate_hz or manoeuvre.sample_rate_hz)
    substeps = manoeuvre.truth_substeps
    n = int(round(manoeuvre.window_s[1] / manoeuvre.dt)) + 1
    h = manoeuvre.dt / substeps
    loop = RelayLoop(law, as_vector(coefficients), const,
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
    tables: MachTables | None = None,
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
        Source of every random draw (normalised once with ``default_rng``): the
        manoeuvre's Dryden gusts first, then the sensor noise.
    backend : {"auto", "numba", "numpy"}
        Integration backend (:func:`aeroid.model.propagate`).
    tables : MachTables, optional
        True coefficient tables in Mach: ``coefficients`` are then their parameters
        (:func:`simulate_truth`), and ``metadata`` holds ``true_parameters`` (name ->
        value) and ``true_tables`` (name -> knots) instead of ``true_coefficients``.

    Returns
    -------
    Flight
        Recorded window; its airframe carries the estimator's copy of the sensor
        positions, ``metadata`` the truth (coefficients, positions), noise and seed.
    """
    if tables is not None:
        coefficients = _parameters(coefficients, tables)
        truth = simulate_truth(airframe, coefficients, manoeuvre, backend=backend, tables=tables)
        return record_flight(airframe, coefficients, manoeuvre, truth, noise, rng=rng,
                             tables=tables)
    coefficients = as_vector(coefficients)
    if manoeuvre.wind is None or not manoeuvre.wind.turbulent:
        truth = simulate_truth(airframe, coefficients, manoeuvre, backend=backend)
        return record_flight(airframe, coefficients, manoeuvre, truth, noise, rng=rng)
    seed = rng if isinstance(rng, int | np.integer) else None
    generator = np.random.default_rng(rng)  # one stream: the gusts, then the sensor noise
    truth = simulate_truth(airframe, coefficients, manoeuvre, backend=backend, rng=generator)
    flight = record_flight(airframe, coefficients, manoeuvre, truth, noise, rng=generator)
    flight.metadata["seed"] = None if seed is None else int(seed)
    return flight


def _parameters(parameters: np.ndarray, tables: MachTables) -> np.ndarray:
    """The tables' parameter vector, checked for its length."""
    p = np.asarray(parameters, dtype=float).reshape(-1)
    if p.size != tables.n_parameters:
        raise AirframeError(f"simulate: {p.size} coefficient values for tables of "
                            f"{tables.n_parameters} parameters "
                            f"({', '.join(tables.parameter_names())})")
    return p


def record_flight(
    airframe: Airframe,
    coefficients: np.ndarray,
    manoeuvre: Manoeuvre,
    truth: Truth | tuple[np.ndarray, np.ndarray, np.ndarray],
    noise: NoiseModel | None = None,
    *,
    rng: np.random.Generator | int | None = None,
    tables: MachTables | None = None,
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
    if not isinstance(truth, Truth):
        t, states, delta = truth
        change = np.flatnonzero(np.diff(delta)) + 1
        truth = Truth(t, states, delta, Schedule.hold(t, delta), t[change], delta[change])
    k0 = int(round(manoeuvre.window_s[0] / manoeuvre.dt))
    t, states, delta = truth.t[k0:], truth.states[k0:], truth.delta[k0:]
    given = coefficients
    flown, temperature = flown_tables(tables, manoeuvre.air, airframe.altitude_m)
    coefficients = (as_vector(coefficients) if flown is None
                    else flown.coefficient_array(_parameters(given, flown), states,
                                                 temperature(t)))
    const = recorded_constants(manoeuvre.flown(airframe), manoeuvre, truth, k0)
    accel = accelerometers(states, delta, coefficients, const,
                           airframe.accel_positions).reshape(-1, 6)
    channels = {"t": t}
    channels.update({name: accel[:, j] for j, name in enumerate(ACCEL_CHANNELS)})
    channels.update({name: states[:, j] for j, name in enumerate(STATE_CHANNELS)})
    channels["delta"] = delta
    channels = noise.corrupt(channels, rng)
    if airframe.thrust_curve is not None:  # the exogenous columns the truth flew with
        channels.update(sample_thrust(airframe.thrust_curve, t))  # the stated mass
    if manoeuvre.air is not None and manoeuvre.air.log_temperature:  # the true air's [K]
        channels[AIR_TEMPERATURE] = manoeuvre.air.temperature(t, airframe.altitude_m)
    if manoeuvre.wind is not None:  # the air-relative angles (in still air: derived)
        channels["alpha"], channels["beta"] = air_angles(
            *equations.air_velocity(as_state(states), const))
    positions = noise.perturb_positions(airframe.accel_positions, rng)
    corrupt_air = getattr(noise, "corrupt_air", None)  # a probe's readings, drawn last
    if corrupt_air is not None and getattr(noise, "logs_air_data", False):
        channels = corrupt_air(channels, equations.air_velocity(as_state(states), const), rng)
    if getattr(noise, "logs_pitot", False):  # a pitot-static probe's pressures, drawn last
        air_t = true_air_temperature(airframe, manoeuvre.air,
                                     getattr(flown, "speed_of_sound_mps", None), t)
        channels = getattr(noise, "corrupt_pitot")(channels, probe_pressures(  # noqa: B009
            equations.air_velocity(as_state(states), const), const.rho, air_t), rng)
    sd = noise.position_sd(positions)  # the estimators are told how uncertain they are
    seen = airframe.replace(accel1_position_m=tuple(positions[0]),
                            accel2_position_m=tuple(positions[1]),
                            accel1_position_sd_m=tuple(sd[0]), accel2_position_sd_m=tuple(sd[1]))
    metadata = {
        "noise": noise.to_dict(),
        "seed": None if seed is None else int(seed),
        "true_coefficients": as_dict(coefficients) if tables is None else None,
        "true_accel_positions_m": airframe.accel_positions.tolist(),
        "manoeuvre": manoeuvre_metadata(manoeuvre),
        "actuator": actuator_metadata(manoeuvre, airframe),
        **switch_metadata(truth, float(t[0]), float(t[-1])),
    }
    if tables is not None:
        parameters = _parameters(given, tables).tolist()
        metadata["true_parameters"] = dict(zip(tables.parameter_names(), parameters,
                                               strict=True))
        metadata["true_tables"] = {**tables.to_table(),
                                   "speed_of_sound_mps": tables.speed_of_sound_mps}
    metadata.update(wind_metadata(manoeuvre.wind))  # the air flown, still air included
    if manoeuvre.air is not None:
        metadata["air"] = manoeuvre.air.describe()
    if manoeuvre.mass_scale != 1.0:
        metadata["true_mass_kg"] = manoeuvre.flown(airframe).mass_kg
    return make_flight(channels, seen, metadata)


def simulate_scenario(scenario: Scenario, noise: NoiseModel | None = None, *,
                      rng: np.random.Generator | int | None = None) -> Flight:
    """Simulate ``scenario`` with ``noise`` (default: the scenario's own noise model)."""
    return simulate(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                    scenario.noise if noise is None else noise, rng=rng,
                    tables=scenario.tables)
