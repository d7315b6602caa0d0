"""Simulate a flight-test sensor suite: an IMU, GNSS, a barometer, an INS, the fin, a probe.

Conventions. The truth is the model's: body axes (u v w, p q r) and 3-2-1 Euler angles (phi
theta psi) over a flat, non-rotating Earth in the scenario's wind (:mod:`._suite_truth`; the
probe: :mod:`._suite_air`). Positions are NED (north, east, down) in metres from the
airframe's position at t = 0, integrated here from the truth (the model has no position
states): the NED velocity ``C_nb(phi, theta, psi) [u v w]`` by the trapezoid rule at the
IMU's step (1 ms: an error of order 1e-4 m over 6 s). The barometer reads pressure altitude
``h0 - down`` with ``h0`` the airframe's ``[atmosphere] altitude_m`` (or, ``baro_channels``,
the ISA pressure and temperature of it; ``baro_board_temperature_k``: a flight computer's
own temperature, constant, instead of the air's); the model's dynamics hold the density of
``h0`` constant, so an ISA density of the logged altitude differs from the truth's by the
climb. ``gnss_channels``: NED velocity and position, or position only.

Sampling. Each group samples the truth at its own rate, every ``imu_rate / rate``-th IMU
instant (so the rates must divide the IMU rate; a group's ``offset_s`` shifts its logged
clock). The truth is simulated at the IMU's rate: the manoeuvre's ``sample_rate_hz`` is
set to ``imu_rate_hz`` with ``truth_substeps`` scaled to keep the RK4 step, and a
``latched`` relay keeps the manoeuvre's own clock (it becomes ``control_rate`` at the
manoeuvre's rate: the same switch instants, so the same flight; the 500 Hz reference and
its 1000 Hz suite agree to 3e-7 m/s).

Sensor errors, per axis: ``reading = (1 + scale) truth + bias + noise``, with bias and
scale drawn once per flight (uniform magnitude in the stated range, random sign), noise
white Gaussian per sample. The accelerometers read specific force at their true
positions (eq. 28) with the fin deflection at the sample and, with a ``[thrust_curve]``,
the thrust over the flown mass at the sample (``truth["thrust"]``, ``["mass"]``). INS
angles are wrapped to (-pi, pi] after the noise.

Board mounting (``imu_mounting``, ``imu_angles_deg``): the IMU reads in the board's axes,
``v_sensor = C^T v_body`` (``C`` from sensor to body axes, :mod:`._mounting`); its errors,
noise and range are the sensor axes'. Range (``accel_range_mps2``, ``gyro_range_radps``):
a reading is clipped to +-range. The log's imu group holds the body axes (the mounting
applied, as on reading a file), the readings as logged in ``sensor_channels`` and the
saturated samples marked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from scipy.integrate import cumulative_trapezoid

from aeroid.errors import AirframeError, FlightError
from aeroid.flights._declared_air import wind_metadata
from aeroid.flights._flight_computer import BARO_CHANNELS, GNSS_CHANNELS, check_flight_computer
from aeroid.flights._frames import body_to_ned, wrap_angle
from aeroid.flights._mounting import Mounting, board_mounting
from aeroid.flights._pitot import true_air_temperature
from aeroid.flights._scenario import Manoeuvre
from aeroid.flights._suite_air import AirProbe, check_probe_rate, suite_probe
from aeroid.flights._suite_log import GROUPS, SensorGroup, SuiteLog, mounted_group
from aeroid.flights._suite_truth import suite_truth, wind_constants
from aeroid.flights._thrust_flight import sample_thrust
from aeroid.model import (
    OUTPUT_CHANNELS,
    PHI,
    PSI,
    STATE_NAMES,
    THETA,
    Airframe,
    accelerometers,
    as_vector,
    constants,
    isa_pressure,
    isa_temperature,
)

#: The IMU errors an estimator may fit (``imu_errors``): per output channel nothing, a bias
#: (name ``b`` + channel), or a bias and a scale factor (``s`` + channel), in the sensor law
#: ``reading = (1 + s) truth + b`` this module simulates.
IMU_ERROR_KINDS: dict[str, tuple[str, ...]] = {"none": (), "bias": ("b",),
                                               "bias+scale": ("b", "s")}


def imu_error_names(kind: str, channels: tuple[str, ...] = OUTPUT_CHANNELS
                    ) -> tuple[str, ...]:
    """Names of the IMU errors of ``kind`` (:data:`IMU_ERROR_KINDS`): ``bax1`` ... ``sr``."""
    return tuple(prefix + channel for prefix in IMU_ERROR_KINDS[kind] for channel in channels)


@dataclass(frozen=True, kw_only=True)
class SensorSuite:
    """The sensors of a flight-test logger: rates [Hz], error ranges and noise sd (SI).

    Ranges ``(low, high)`` are magnitudes drawn uniformly, with a random sign, once per
    flight for every axis; noise sd are per sample. A rate of 0 leaves the group out.
    ``gnss_channels``: one of :data:`GNSS_CHANNELS`; ``baro_board_temperature_k``: the
    temperature channel is the board's, constant at that value [K] (module docstring).
    """

    imu_rate_hz: float = 1000.0
    gnss_rate_hz: float = 10.0
    baro_rate_hz: float = 50.0
    ins_rate_hz: float = 100.0
    fin_rate_hz: float = 1000.0
    accel_bias_mps2: tuple[float, float] = (0.02, 0.2)
    gyro_bias_radps: tuple[float, float] = (0.001, 0.005)
    scale_factor: tuple[float, float] = (0.001, 0.005)
    accel_noise_mps2: float = 0.05
    gyro_noise_radps: float = 0.002
    gnss_velocity_sd_mps: float = 0.1
    gnss_position_sd_m: float = 1.5
    baro_altitude_sd_m: float = 1.0
    baro_channels: tuple[str, ...] = ("altitude",)
    baro_pressure_sd_pa: float = 10.0
    baro_temperature_sd_k: float = 0.2
    ins_attitude_sd_rad: float = 0.003
    fin_sd_rad: float = 0.0
    offsets_s: tuple[tuple[str, float], ...] = ()
    imu_mounting: str = ""
    imu_angles_deg: tuple[float, ...] = ()
    accel_range_mps2: float | None = None
    gyro_range_radps: float | None = None
    gnss_channels: tuple[str, ...] = GNSS_CHANNELS[0]
    baro_board_temperature_k: float | None = None
    air_probe: AirProbe | None = None  # an air-data probe's group (:mod:`._suite_air`)

    def __post_init__(self) -> None:
        if not self.imu_rate_hz > 0:
            raise AirframeError(f"sensor suite: imu_rate_hz must be positive, got "
                                f"{self.imu_rate_hz}")
        check_probe_rate(self.air_probe, self.imu_rate_hz)
        for name in ("gnss", "baro", "ins", "fin"):
            rate = getattr(self, f"{name}_rate_hz")
            stride = self.imu_rate_hz / rate if rate > 0 else 1.0
            if rate < 0 or abs(stride - round(stride)) > 1e-9:
                raise AirframeError(f"sensor suite: {name}_rate_hz = {rate:g} must divide "
                                    f"imu_rate_hz = {self.imu_rate_hz:g} (or be 0)")
        for name, range_ in (("accel_bias_mps2", self.accel_bias_mps2),
                             ("gyro_bias_radps", self.gyro_bias_radps),
                             ("scale_factor", self.scale_factor)):
            if len(range_) != 2 or not 0 <= range_[0] <= range_[1]:
                raise AirframeError(f"sensor suite: {name} must be (low, high) with "
                                    f"0 <= low <= high, got {range_}")
        if tuple(self.baro_channels) not in BARO_CHANNELS:
            raise AirframeError(f"sensor suite: baro_channels must be one of "
                                f"{', '.join(map(str, BARO_CHANNELS))}, got "
                                f"{self.baro_channels}")
        check_flight_computer(self.gnss_channels, self.baro_channels,
                              self.baro_board_temperature_k)
        unknown = sorted({g for g, _ in self.offsets_s} - set(GROUPS))
        if unknown:
            raise AirframeError(f"sensor suite: offsets_s names unknown group(s) {unknown}")
        self.mounting()  # refuses an improper one
        for name in ("accel_range_mps2", "gyro_range_radps", "baro_board_temperature_k"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise AirframeError(f"sensor suite: {name} must be a positive number or "
                                    f"None, got {value}")

    def mounting(self) -> Mounting | None:
        """The IMU's board mounting (``imu_mounting`` axis map or ``imu_angles_deg``)."""
        try:
            return board_mounting(self.imu_mounting, self.imu_angles_deg,
                                  "sensor suite: imu_mounting / imu_angles_deg")
        except FlightError as exc:
            raise AirframeError(str(exc)) from None

    def ranges(self) -> dict[str, float]:
        """The IMU's stated ranges by the suite log's keys (``accel_range``, ``gyro_range``)."""
        given = {"accel_range": self.accel_range_mps2, "gyro_range": self.gyro_range_radps}
        return {k: float(v) for k, v in given.items() if v is not None}


class SuiteSimulation(NamedTuple):
    """A simulated suite log with its truth.

    Attributes
    ----------
    log : SuiteLog
        The groups at their own rates (SI, true time axis).
    truth : dict of str to ndarray, shape (n,)
        At the IMU instants: ``t``, the nine states, ``pn pe pd`` [m], ``vn ve vd`` [m/s],
        ``altitude`` [m], ISA ``pressure`` [Pa] and ``temperature`` [K] of it, ``delta``
        [rad]; with a probe the wind and its clean readings (:func:`._suite_air.suite_probe`).
    errors : dict of str to ndarray
        ``accel_bias`` and ``accel_scale`` (2, 3) (triad, axis), ``gyro_bias`` and
        ``gyro_scale`` (3,).
    """

    log: SuiteLog
    truth: dict[str, np.ndarray]
    errors: dict[str, np.ndarray]


def simulate_suite(airframe: Airframe, coefficients: Any, manoeuvre: Manoeuvre,
                   suite: SensorSuite | None = None, *,
                   rng: np.random.Generator | int | None = None,
                   backend: str = "auto") -> SuiteSimulation:
    """Simulate a flight and log it with a sensor suite (module docstring).

    Parameters
    ----------
    airframe : Airframe
        True airframe (accelerometer positions; ``altitude_m`` is the barometer's origin).
    coefficients : array_like, shape (9,) or mapping
    manoeuvre : Manoeuvre
        The flight; its window is what the log records.
    suite : SensorSuite, optional
        Default :class:`SensorSuite()`.
    rng : numpy.random.Generator or int, optional
        Source of every draw (sensor errors first, then the noise, group by group).
    """
    suite = suite or SensorSuite()
    rng = np.random.default_rng(rng)
    if suite.baro_rate_hz > 0 and airframe.altitude_m is None:
        raise AirframeError("sensor suite: the barometer needs the airframe's [atmosphere] "
                            "altitude_m (its altitude at t = 0)")
    coefficients = as_vector(coefficients)
    truth, sampled, imu_sampling = suite_truth(airframe, coefficients, manoeuvre,
                                               suite.imu_rate_hz, rng, backend)
    ned_velocity = np.einsum("kij,kj->ki", body_to_ned(*truth.states[:, [PHI, THETA, PSI]].T),
                             truth.states[:, :3])
    position = cumulative_trapezoid(ned_velocity, truth.t, axis=0, initial=0.0)
    k0 = int(round(manoeuvre.window_s[0] * suite.imu_rate_hz))
    t, states, delta = truth.t[k0:], truth.states[k0:], truth.delta[k0:]
    wind = None if truth.wind is None else truth.wind[k0:]  # the air the truth flew in
    const, motor = wind_constants(constants(manoeuvre.flown(airframe)), wind), {}
    extra: dict[str, Any] = wind_metadata(manoeuvre.wind)  # the air it flew, declared
    if airframe.thrust_curve is not None:  # the IMU sees the thrust, over the flown mass
        motor = sample_thrust(airframe.thrust_curve, t, airframe.thrust_n,
                              manoeuvre.mass_scale)
        const, extra["thrust"] = const._replace(**motor), airframe.thrust_curve.describe()
    air_t = true_air_temperature(airframe, manoeuvre.air, None, t) if suite.air_probe else None
    specific = accelerometers(states, delta, coefficients, const,
                              airframe.accel_positions).reshape(-1, 2, 3)
    sim = log_trajectory(t, states, delta, specific, airframe, suite, rng=rng,
                         position=position[k0:], source="simulated suite log",
                         metadata={"imu_sampling": imu_sampling, **extra}, wind=wind,
                         air_temperature=air_t)
    sim.truth.update({k: np.broadcast_to(v, t.shape).copy() for k, v in motor.items()})
    return sim


def log_trajectory(t: np.ndarray, states: np.ndarray, delta: np.ndarray,
                   specific_force: np.ndarray, airframe: Airframe,
                   suite: SensorSuite | None = None, *,
                   rng: np.random.Generator | int | None = None,
                   position: np.ndarray | None = None,
                   atmosphere: dict[str, np.ndarray] | None = None,
                   source: str = "suite log",
                   metadata: dict[str, Any] | None = None,
                   wind: np.ndarray | None = None,
                   air_temperature: np.ndarray | None = None) -> SuiteSimulation:
    """Log a given truth trajectory through a sensor suite (module docstring).

    The sensor layer alone, shared by :func:`simulate_suite` and any other source of a
    truth (another simulator), drawing and sampling exactly as there.

    Parameters
    ----------
    t : ndarray, shape (n,)
        The truth's times [s], uniform at ``suite.imu_rate_hz``.
    states : ndarray, shape (n, N_STATES)
        The model's states at ``t`` [m/s, rad/s, rad] (``STATE_NAMES``).
    delta : ndarray, shape (n,)
        Fin deflection at ``t`` [rad].
    specific_force : ndarray, shape (n, 2, 3)
        True specific force at each accelerometer triad's position [m/s^2].
    airframe : Airframe
        Accelerometer positions; ``altitude_m``: the barometer's altitude at the origin.
    suite, rng
        As :func:`simulate_suite`.
    position : ndarray, shape (n, 3), optional
        NED position [m]; default the NED velocity integrated by the trapezoid rule from
        the origin at ``t[0]``.
    atmosphere : dict with ``pressure`` [Pa] and ``temperature`` [K], shape (n,), optional
        The truth's own air at ``t`` (another simulator's atmosphere); default the ISA of
        the altitude ``altitude_m - pd``.
    source : str
        The log's name in messages.
    metadata : dict, optional
        Kept in the log's metadata beside the drawn ``truth`` errors.
    wind, air_temperature : ndarray, shape (n, 3) and (n,), optional
        The air the truth flew in, NED [m/s] (default still air), and its temperature [K]
        (default ``atmosphere``'s, else the ISA at ``altitude_m``): the air probe's
        (``suite.air_probe``, :mod:`._suite_air`; its static pressure from the airframe's
        density, or ``atmosphere``'s pressure).

    Raises
    ------
    AirframeError
        One line: shapes that do not match, a time axis that is not the IMU's rate, a
        barometer without the airframe's altitude.
    """
    suite = suite or SensorSuite()
    rng = np.random.default_rng(rng)
    t = np.asarray(t, dtype=float)
    states = np.asarray(states, dtype=float)
    delta = np.asarray(delta, dtype=float)
    specific = np.asarray(specific_force, dtype=float)
    n = len(t)
    shapes = {"states": (states.shape, (n, len(STATE_NAMES))), "delta": (delta.shape, (n,)),
              "specific_force": (specific.shape, (n, *airframe.accel_positions.shape))}
    if position is not None:
        position = np.asarray(position, dtype=float)
        shapes["position"] = (position.shape, (n, 3))
    if atmosphere is not None:
        if sorted(atmosphere) != ["pressure", "temperature"]:
            raise AirframeError(f"{source}: atmosphere must give pressure and temperature, "
                                f"got {sorted(atmosphere)}")
        atmosphere = {k: np.asarray(v, dtype=float) for k, v in atmosphere.items()}
        shapes.update({k: (v.shape, (n,)) for k, v in atmosphere.items()})
    if wind is not None:
        wind = np.asarray(wind, dtype=float)
        shapes["wind"] = (wind.shape, (n, 3))
    for name, (got, want) in shapes.items():
        if got != want:
            raise AirframeError(f"{source}: {name} has shape {got}, expected {want} "
                                f"(t has {n} samples)")
    step = np.diff(t)
    if n < 2 or np.max(np.abs(step * suite.imu_rate_hz - 1.0)) > 1e-6:
        raise AirframeError(f"{source}: the truth's times must be uniform at the IMU's "
                            f"{suite.imu_rate_hz:g} Hz")
    if suite.baro_rate_hz > 0 and airframe.altitude_m is None:
        raise AirframeError("sensor suite: the barometer needs the airframe's [atmosphere] "
                            "altitude_m (its altitude at t = 0)")
    ned_velocity = np.einsum("kij,kj->ki", body_to_ned(*states[:, [PHI, THETA, PSI]].T),
                             states[:, :3])
    if position is None:
        position = cumulative_trapezoid(ned_velocity, t, axis=0, initial=0.0)
    altitude = (airframe.altitude_m or 0.0) - position[:, 2]
    table = {"t": t, **{name: states[:, j] for j, name in enumerate(STATE_NAMES)},
             **{c: position[:, j] for j, c in enumerate(("pn", "pe", "pd"))},
             **{c: ned_velocity[:, j] for j, c in enumerate(("vn", "ve", "vd"))},
             "altitude": altitude, "pressure": isa_pressure(altitude),
             "temperature": isa_temperature(altitude), **(atmosphere or {}), "delta": delta}

    def draw(range_: tuple[float, float], shape: tuple[int, ...]) -> np.ndarray:
        return rng.uniform(*range_, size=shape) * rng.choice([-1.0, 1.0], size=shape)

    errors = {"accel_bias": draw(suite.accel_bias_mps2, (2, 3)),
              "accel_scale": draw(suite.scale_factor, (2, 3)),
              "gyro_bias": draw(suite.gyro_bias_radps, (3,)),
              "gyro_scale": draw(suite.scale_factor, (3,))}
    mounting = suite.mounting()
    rates = states[:, 3:6]
    if mounting is not None:  # the board's axes: v_sensor = C^T v_body (rows: v @ C)
        specific, rates = specific @ mounting.rotation, rates @ mounting.rotation
    accel = ((1.0 + errors["accel_scale"]) * specific + errors["accel_bias"]
             + suite.accel_noise_mps2 * rng.standard_normal(specific.shape)).reshape(-1, 6)
    gyro = ((1.0 + errors["gyro_scale"]) * rates + errors["gyro_bias"]
            + suite.gyro_noise_radps * rng.standard_normal((len(t), 3)))
    ranges = suite.ranges()
    if "accel_range" in ranges:  # a real IMU's full scale
        accel = np.clip(accel, -ranges["accel_range"], ranges["accel_range"])
    if "gyro_range" in ranges:
        gyro = np.clip(gyro, -ranges["gyro_range"], ranges["gyro_range"])
    imu = {c: accel[:, j] for j, c in enumerate(GROUPS["imu"][:6])}
    imu.update(p=gyro[:, 0], q=gyro[:, 1], r=gyro[:, 2])
    sd_imu = {**{c: suite.accel_noise_mps2 for c in GROUPS["imu"][:6]},
              **{c: suite.gyro_noise_radps for c in ("p", "q", "r")}}
    groups = {"imu": mounted_group("imu", t.copy(), imu, sd_imu,
                                   float(dict(suite.offsets_s).get("imu", 0.0)),
                                   "simulated imu", mounting, ranges)}
    baro = dict(table)  # the truth's air, or a flight computer's own (board) temperature
    if suite.baro_board_temperature_k is not None:
        baro["temperature"] = np.full(n, suite.baro_board_temperature_k)
    aiding = {"gnss": ({c: table[c] for c in suite.gnss_channels},
                       {**{c: suite.gnss_velocity_sd_mps for c in ("vn", "ve", "vd")},
                        **{c: suite.gnss_position_sd_m for c in ("pn", "pe", "pd")}}),
              "baro": ({c: baro[c] for c in suite.baro_channels},
                       {"altitude": suite.baro_altitude_sd_m,
                        "pressure": suite.baro_pressure_sd_pa,
                        "temperature": suite.baro_temperature_sd_k}),
              "ins": ({c: table[c] for c in ("phi", "theta", "psi")},
                      dict.fromkeys(("phi", "theta", "psi"), suite.ins_attitude_sd_rad)),
              "fin": ({"delta": delta}, {"delta": suite.fin_sd_rad})}
    for name, (values, sd) in aiding.items():
        rate = getattr(suite, f"{name}_rate_hz")
        if rate == 0:
            continue
        every = int(round(suite.imu_rate_hz / rate))
        noisy = {c: v[::every] + sd[c] * rng.standard_normal(len(v[::every]))
                 for c, v in values.items()}
        if name == "ins":
            noisy = {c: wrap_angle(v) if c != "theta" else v for c, v in noisy.items()}
        groups[name] = _group(name, t[::every], noisy,
                              {c: s for c, s in sd.items() if s > 0 and c in noisy},
                              suite)
    if suite.air_probe is not None:  # drawn last: the other groups of a seed unchanged
        groups["air"], air_truth = suite_probe(t, states, airframe, suite, rng, wind,
                                               atmosphere, air_temperature)
        table.update(air_truth)
    metadata = {"truth": {k: v.tolist() for k, v in errors.items()}, **(metadata or {})}
    if groups["imu"].notes:
        metadata["notes"] = list(groups["imu"].notes)
    return SuiteSimulation(SuiteLog(groups, airframe, metadata, source), table, errors)


def _group(name: str, t: np.ndarray, channels: dict[str, np.ndarray],
           noise_sd: dict[str, float], suite: SensorSuite) -> SensorGroup:
    offset = dict(suite.offsets_s).get(name, 0.0)
    board = name == "baro" and suite.baro_board_temperature_k is not None
    return SensorGroup(name, t.copy(), channels, noise_sd, float(offset),
                       f"simulated {name}", temperature_of="board" if board else "air")
