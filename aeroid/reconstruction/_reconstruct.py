"""Flight-path reconstruction: a suite log in, states and instrument errors out.

:func:`reconstruct` runs the kinematic EKF and RTS smoother (:mod:`._filter`,
:mod:`._kinematics`) driven by the log's IMU, aided by whatever of GNSS velocity and
position (or position only: :mod:`._gnss`), barometric altitude and INS attitude it holds
(each channel used needs its ``noise_sd``: nothing is assumed). The table is at the IMU's
rate; :meth:`Reconstruction.to_flight` makes a single-rate :class:`~aeroid.flights.Flight`
of it (corrected or raw IMU channels, reconstructed states, the fin from its own clock).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from scipy.signal import savgol_filter

from aeroid.errors import FlightError
from aeroid.flights import Flight, SuiteLog, body_to_ned, exogenous, make_flight
from aeroid.model import EXOGENOUS, Airframe
from aeroid.reconstruction._aiding import flight_aiding, logged_aiding
from aeroid.reconstruction._air_samples import flight_air, logged_air
from aeroid.reconstruction._barometer import (
    ATMOSPHERES,
    baro_altitude,
    baro_channel,
    baro_density,
    baro_model,
    flight_atmosphere,
)
from aeroid.reconstruction._filter import Aiding, _subset, run
from aeroid.reconstruction._gnss import gnss_track_start
from aeroid.reconstruction._kinematics import (
    ACCEL_BIAS,
    ACCEL_SCALE,
    ATT,
    GYRO_BIAS,
    GYRO_SCALE,
    IMU_CHANNELS,
    IX,
    N_STATES,
    POS,
    STATES,
    VEL,
    ned_velocity,
)
from aeroid.reconstruction._sensors import held_fin, mounted_positions, saturated_samples
from aeroid.reconstruction._wind import steady_wind

Model = Callable[[np.ndarray], np.ndarray]
#: Savitzky-Golay window [samples] and order of the gyro derivative (the lever-arm term).
OMEGA_DOT_WINDOW = 11
OMEGA_DOT_ORDER = 3
#: Prior sd of states with no measurement at the start (no GNSS: position from the
#: origin at the first IMU sample; no barometer: alt0, unobserved).
UNOBSERVED_SD = 1.0
#: Largest departure of an IMU interval from the median, relative (the gyro derivative
#: assumes uniform sampling).
UNIFORM_TOLERANCE = 0.01
#: A prior set from a first sample has that sample's sd times this (the sample then is not
#: used again), plus what the time from the sample to the first IMU sample may change.
PRIOR_INFLATION = 2.0


@dataclass(frozen=True)
class Reconstruction:
    """A reconstructed flight path.

    Attributes
    ----------
    table : pandas.DataFrame
        At the IMU's times: ``t``, every state of :data:`STATES` and its sd (``sd_NAME``),
        the corrected IMU channels ``ax1 ... r``, ``altitude`` and ``rho`` (with a
        barometer; ``metadata['density']``: ``"barometer"``, ``p / (R T)``, or ``"isa"``).
    covariance : ndarray, shape (n, N, N)
        Smoothed state covariance.
    nis : dict
        The residual check per aiding source: ``mean_nis_per_dof`` (1 for consistent
        innovations), ``n_updates``, ``n_values``, ``interval`` (chi-square, two-sided
        level 0.002) and ``consistent``.
    innovations : dict of str to ndarray, shape (m, d)
        Filter innovations over their predicted sd, per source.
    notes : tuple of str
        One line per interpretation made.
    airframe : Airframe
    fin : (t, delta), optional
        The fin group's times [s] and deflection [rad].
    metadata : dict
    raw_imu : ndarray, shape (n, 9), optional
        The IMU's readings as logged (:data:`IMU_CHANNELS`, SI), at the table's times.
    innovation_tables : dict of str to pandas.DataFrame
        Per aiding source: ``t`` (the measurement's time), each channel's innovation
        (measured - predicted, SI) and its predicted sd ``sd_CHANNEL`` (for the report).
    """

    table: pd.DataFrame
    covariance: np.ndarray
    nis: dict[str, dict[str, Any]]
    innovations: dict[str, np.ndarray]
    notes: tuple[str, ...]
    airframe: Airframe
    fin: tuple[np.ndarray, np.ndarray] | None = None
    metadata: dict[str, Any] = field(default_factory=dict)
    raw_imu: np.ndarray | None = None
    innovation_tables: dict[str, pd.DataFrame] = field(default_factory=dict)

    def to_flight(self, *, atmosphere: str = "airframe", imu: str = "corrected",
                  aiding: bool = False, air: str = "auto") -> Flight:
        """Return the reconstruction as a single-rate Flight at the IMU's times.

        Channels: the IMU readings (corrected by default), ``u v w phi theta psi``
        reconstructed, ``delta`` the latest fin sample at or before each IMU time (the fin
        is a relay: held, not interpolated). ``metadata['initial_state_sd']``: the
        smoothed sd of ``u v w phi theta psi`` at the first sample [m/s, rad] (for
        output-error's ``initial_velocity_prior``).

        Parameters
        ----------
        atmosphere : {"airframe", "per-sample", "altitude"}
            ``"airframe"``: the airframe's own atmosphere (as the model's simulator, which
            holds the density of one altitude); ``"per-sample"``: the reconstruction's
            density at each sample (needs a barometer): with a baro pressure and
            temperature ``rho = p / (R T)`` becomes the channel ``rho`` and the atmosphere
            ``per_sample = "rho"``, otherwise as ``"altitude"``; ``"altitude"``: the
            reconstructed altitude becomes a channel and the atmosphere
            ``per_sample = "altitude"`` (ISA density at each sample, even when the
            barometer has a temperature: the notes say so). One note names the density
            the flight got.
        imu : {"corrected", "raw"}
            ``"corrected"``: the readings less the reconstruction's biases and scale
            factors; ``"raw"``: the readings as logged, for an estimator that fits the
            IMU's errors itself (output-error's ``imu_errors``); the reconstructed
            states then serve as its initial state.
        aiding : bool
            Also pass the log's GNSS velocity and INS attitude samples within the flight's
            times, as logged and at their own times, in ``metadata["aiding"]`` (output-error's
            ``aiding``; :mod:`aeroid.reconstruction._aiding`).
        air : {"auto", "samples", "interpolate", "wind"}
            The log's air group's channels at the IMU's times where it samples there
            (``"auto"``: else the steady wind only; ``"samples"``: else refused), linearly
            interpolated (``"interpolate"``), or the steady wind only (``"wind"``); the
            probe's position in ``metadata["air_data_probe"]`` (:mod:`._air_samples`).
        """
        where = self.metadata.get("source", "suite log")
        if atmosphere not in ATMOSPHERES:
            raise FlightError(f"{where}: atmosphere must be one of "
                              f"{', '.join(map(repr, ATMOSPHERES))}, got {atmosphere!r}")
        if imu not in ("corrected", "raw"):
            raise FlightError(f"{where}: imu must be 'corrected' or 'raw', got {imu!r}")
        if imu == "raw" and self.raw_imu is None:
            raise FlightError(f"{where}: this reconstruction holds no raw IMU readings")
        if self.fin is None and self.airframe.fin != "passive":
            raise FlightError(f"{where}: no fin group: a Flight needs the fin deflection")
        tab = self.table
        channels = {c: tab[c].to_numpy() for c in ("t", *IMU_CHANNELS, "u", "v", "w", "phi",
                                                   "theta", "psi")}
        channels["delta"], fin_note = held_fin(self.fin, tab["t"].to_numpy(), self.metadata)
        imu_note = "IMU: corrected by the reconstruction's biases and scale factors"
        if imu == "raw":
            assert self.raw_imu is not None  # checked above
            channels.update({c: self.raw_imu[:, j] for j, c in enumerate(IMU_CHANNELS)})
            imu_note = ("IMU: raw readings, biases and scale factors not removed (fit them: "
                        "output-error imu_errors)")
        airframe, density_note = flight_atmosphere(atmosphere, self.table, self.airframe,
                                                   self.metadata, channels)
        notes = [*self.notes, imu_note, density_note, *([fin_note] if fin_note else [])]
        first_sd = {s: float(tab[f"sd_{s}"].iloc[0]) for s in STATES[:6]}  # u v w, angles
        meta = flight_air(flight_aiding(self.metadata, channels["t"], aiding, notes), channels,
                          air, notes)
        return make_flight(channels, airframe, {**meta, "notes": notes,
                                                "initial_state_sd": first_sd})


def reconstruct(log: SuiteLog, *, airframe: Airframe | None = None,
                accel_bias_sd: float = 0.2, gyro_bias_sd: float = 0.005,
                scale_sd: float = 0.005,
                initial_attitude: tuple[float, float, float] | None = None,
                initial_velocity: tuple[float, float, float] | None = None,
                initial_sd: tuple[float, float] = (0.05, 2.0)) -> Reconstruction:
    """Reconstruct the flight path of a suite log (module docstring).

    Parameters
    ----------
    log : SuiteLog
        Needs an ``imu`` group with all nine channels and their ``noise_sd``.
    airframe : Airframe, optional
        Wins over the log's (its accelerometer positions are used).
    accel_bias_sd, gyro_bias_sd, scale_sd : float
        Prior sd of the biases [m/s^2, rad/s] and scale factors [-] (prior mean 0).
    initial_attitude : (phi, theta, psi) [rad], optional
        Needed without an INS (else the INS sample nearest the first IMU time).
    initial_velocity : (u, v, w) [m/s], optional
        Needed without GNSS velocity (else the first fix turned into body axes).
    initial_sd : (attitude [rad], velocity [m/s])
        Prior sd of a given initial attitude and velocity (from the first INS and GNSS
        samples: their sd times :data:`PRIOR_INFLATION`).
    """
    source = log.source
    airframe = airframe or log.airframe
    if airframe is None:
        raise FlightError(f"{source}: no airframe (give one: the accelerometer positions "
                          "are needed)")
    imu_group = log["imu"]
    notes = [str(note) for note in log.metadata.get("notes", ())]
    airframe = mounted_positions(airframe, imu_group, notes)
    missing = [c for c in IMU_CHANNELS if c not in imu_group.channels]
    no_sd = [c for c in IMU_CHANNELS if c not in imu_group.noise_sd]
    if missing or no_sd:
        axial = not any(c in imu_group.channels for c in ("p", "q", "r"))
        raise FlightError(f"{imu_group.source}: the imu group needs all of "
                          f"{', '.join(IMU_CHANNELS)} with noise_sd; missing "
                          f"{', '.join(missing) or 'none'}, no noise_sd for "
                          f"{', '.join(no_sd) or 'none'}" + (
                              " (without gyros the attitude cannot be propagated: an "
                              "accelerometer-only log is not reconstructed; an axial one "
                              "with GNSS is fitted by make_estimator('axial-drag').fit(log))"
                              if axial else ""))
    t = imu_group.t
    if len(t) < OMEGA_DOT_WINDOW:
        raise FlightError(f"{imu_group.source}: {len(t)} IMU samples; the reconstruction "
                          f"needs at least {OMEGA_DOT_WINDOW}")
    imu = np.column_stack([imu_group.channels[c] for c in IMU_CHANNELS])
    dt = float(np.median(np.diff(t)))
    uneven = np.flatnonzero(np.abs(np.diff(t) - dt) > UNIFORM_TOLERANCE * dt)
    if uneven.size:
        k = int(uneven[0])
        raise FlightError(f"{imu_group.source}: IMU sampling not uniform: {t[k + 1] - t[k]:.6g} s "
                          f"after t = {t[k]:.9g} s, median interval {dt:.6g} s (split the log "
                          "at gaps)")
    omega_dot = savgol_filter(imu[:, 6:], OMEGA_DOT_WINDOW, OMEGA_DOT_ORDER, deriv=1,
                              delta=dt, axis=0)
    lever = airframe.accel_positions.mean(axis=0)
    notes += [f"specific force at the c.g.: mean of the two triads at {lever.tolist()} m, "
             "lever-arm terms from the corrected gyros and their Savitzky-Golay derivative"]
    used: dict[str, Any] = {}
    x0, p0 = _prior(log, t, imu, used, notes, accel_bias_sd, gyro_bias_sd, scale_sd,
                    initial_attitude, initial_velocity, initial_sd)
    aidings = _aidings(log, t, notes, used)
    # the derivative's noise enters the lever-arm term: sd(wdot) = sd(gyro) |SG weights| / dt
    weights = savgol_filter(np.eye(OMEGA_DOT_WINDOW)[OMEGA_DOT_WINDOW // 2], OMEGA_DOT_WINDOW,
                            OMEGA_DOT_ORDER, deriv=1, delta=dt, mode="constant")
    od_sd = max(imu_group.noise_sd[c] for c in ("p", "q", "r")) * np.linalg.norm(weights)
    extra = np.zeros(N_STATES)
    extra[VEL] = (od_sd * np.linalg.norm(lever)) ** 2 * dt
    imu_sd = np.array([imu_group.noise_sd[c] for c in IMU_CHANNELS])
    saturated, imu_sd_k = saturated_samples(imu_group, imu_sd, notes)
    passes = run(t, imu, imu_sd, omega_dot, lever, x0, p0, aidings, extra, imu_sd_k)
    sd = np.sqrt(np.clip(np.einsum("kii->ki", passes.covariance), 0.0, None))
    table = pd.DataFrame({"t": t, **{s: passes.states[:, j] for j, s in enumerate(STATES)},
                          **{f"sd_{s}": sd[:, j] for j, s in enumerate(STATES)}})
    xs = passes.states.T
    accel = (imu[:, :6].T - xs[ACCEL_BIAS]) / (1.0 + xs[ACCEL_SCALE])
    gyro = (imu[:, 6:].T - xs[GYRO_BIAS]) / (1.0 + xs[GYRO_SCALE])
    for j, c in enumerate(IMU_CHANNELS):
        table[c] = accel[j] if j < 6 else gyro[j - 6]
    fin = None
    if "fin" in log:
        fin = (log["fin"].t, log["fin"].channels["delta"])
    meta: dict[str, Any] = {"source": source, "reconstruction": "kinematic EKF + RTS smoother"}
    if saturated:
        meta["saturated"] = saturated
    meta.update({**logged_aiding(log), **logged_air(log)})
    meta.update(steady_wind(log, t, passes.states, passes.covariance, STATES, notes,
                            gyro.T, airframe))
    if "baro" in log:
        table["altitude"] = table["alt0"] - table["pd"]
        table["sd_altitude"] = np.sqrt(np.clip(
            passes.covariance[:, IX["alt0"], IX["alt0"]] + passes.covariance[:, IX["pd"], IX["pd"]]
            - 2 * passes.covariance[:, IX["alt0"], IX["pd"]], 0.0, None))
        probe = make_flight({"t": t, "altitude": table["altitude"].to_numpy()},
                            airframe.replace(altitude_m=None, given_density_kgm3=None,  # no
                                             atmosphere_channel="altitude", tables=None))  # Mach
        ex = exogenous(probe)
        assert ex is not None  # the altitude channel is there
        table["rho"] = ex[:, EXOGENOUS.index("rho")]
        rho = baro_density(log, t, table["altitude"].to_numpy(), notes)
        meta["density"] = "isa"
        if rho is not None:
            table["rho"] = rho
            meta["density"] = "barometer"
    else:
        notes.append("no barometer: no altitude or density in the output")
    innovation_tables = {
        aid.name: pd.DataFrame({"t": passes.innovation_detail[aid.name]["t"],
                                **{c: passes.innovation_detail[aid.name]["innovation"][:, j]
                                   for j, c in enumerate(aid.channels)},
                                **{f"sd_{c}": passes.innovation_detail[aid.name]["sd"][:, j]
                                   for j, c in enumerate(aid.channels)}})
        for aid in aidings}
    return Reconstruction(table, passes.covariance, passes.nis, passes.innovations,
                          tuple(notes), airframe, fin, meta, imu.copy(), innovation_tables)


def _aidings(log: SuiteLog, t: np.ndarray, notes: list[str], used: dict[str, Any]
             ) -> list[Aiding]:
    """Return the aiding sources, leaving out each sample that set the initial state."""
    dt = float(np.median(np.diff(t)))
    out = []
    baro = baro_channel(log) or "altitude"
    models: dict[str, Model] = {
        "gnss": lambda x: np.vstack([ned_velocity(x), x[POS]]),
        "baro": baro_model(baro, lambda x: (x[IX["alt0"]] - x[IX["pd"]])[None]),
        "ins": lambda x: x[ATT],
    }
    order = {"gnss": ("vn", "ve", "vd", "pn", "pe", "pd"), "baro": (baro,),
             "ins": ("phi", "theta", "psi")}
    for name, channels in order.items():
        if name not in log:
            notes.append(f"no {name} group: not used")
            continue
        group = log[name]
        present = [c for c in channels if c in group.channels]
        no_sd = [c for c in present if c not in group.noise_sd]
        if no_sd:
            raise FlightError(f"{group.source}: no noise_sd for {', '.join(no_sd)} (each "
                              "aiding channel needs one)")
        rows = [channels.index(c) for c in present]
        index = np.clip(np.searchsorted(t, group.t), 1, len(t) - 1)
        index = np.where(np.abs(group.t - t[index - 1]) <= np.abs(group.t - t[index]),
                         index - 1, index)
        lead = group.t - t[index]
        inside = np.abs(lead) <= dt
        if not inside.all():
            notes.append(f"{name}: {int((~inside).sum())} sample(s) outside the IMU record "
                         "not used")
        if name in used:
            inside[used[name]] = False
            notes.append(f"{name}: {np.size(used[name])} sample(s) near t[0] set the initial "
                         "state and are not used again")
        full = models[name]
        out.append(Aiding(name, index[inside], lead[inside],
                          np.column_stack([group.channels[c] for c in present])[inside],
                          np.array([group.noise_sd[c] for c in present]),
                          np.array([c in ("phi", "psi") for c in present]),
                          _subset(full, rows), tuple(present)))
    return out


def _prior(log: SuiteLog, t: np.ndarray, imu: np.ndarray, used: dict[str, Any],
           notes: list[str], accel_bias_sd: float, gyro_bias_sd: float, scale_sd: float,
           initial_attitude: Any, initial_velocity: Any, initial_sd: tuple[float, float]
           ) -> tuple[np.ndarray, np.ndarray]:
    x0 = np.zeros(N_STATES)
    sd = np.full(N_STATES, UNOBSERVED_SD)
    sd[ACCEL_BIAS], sd[GYRO_BIAS] = accel_bias_sd, gyro_bias_sd
    sd[ACCEL_SCALE] = sd[GYRO_SCALE] = scale_sd
    att_sd, vel_sd = initial_sd

    def first(name: str, channels: tuple[str, ...]) -> tuple[np.ndarray, float, float] | None:
        if name not in log or not all(c in log[name].channels for c in channels):
            return None
        group = log[name]
        no_sd = [c for c in channels if c not in group.noise_sd]
        if no_sd:
            raise FlightError(f"{group.source}: no noise_sd for {', '.join(no_sd)} (each "
                              "aiding channel needs one)")
        k = int(np.argmin(np.abs(group.t - t[0])))
        used[name] = k
        return (np.array([group.channels[c][k] for c in channels]), float(group.t[k] - t[0]),
                max(group.noise_sd[c] for c in channels))

    if initial_attitude is not None:
        x0[ATT], sd[ATT] = initial_attitude, att_sd
    elif (ins := first("ins", ("phi", "theta", "psi"))) is not None:
        angles, lead, ins_sd = ins
        x0[ATT] = angles - imu[0, 6:] * lead  # back to t[0] along the body rates
        sd[ATT] = PRIOR_INFLATION * ins_sd + np.abs(imu[0, 6:]) * abs(lead)
    else:
        raise FlightError(f"{log.source}: no INS attitude: give initial_attitude")
    track = (gnss_track_start(log, float(t[0]), used, notes) if initial_velocity is None
             else None)
    if initial_velocity is not None:
        x0[VEL], sd[VEL] = initial_velocity, vel_sd
    elif (gnss_v := first("gnss", ("vn", "ve", "vd"))) is not None:
        x0[VEL] = body_to_ned(*x0[ATT]).T @ gnss_v[0]
        sd[VEL] = (PRIOR_INFLATION * gnss_v[2] + np.linalg.norm(gnss_v[0]) * sd[ATT].max()
                   + 50.0 * abs(gnss_v[1]))  # 50 m/s^2: a bound on the change until t[0]
    elif track is not None:  # GNSS positions only
        x0[VEL] = body_to_ned(*x0[ATT]).T @ track.velocity
        sd[VEL] = track.velocity_sd.max() + np.linalg.norm(track.velocity) * sd[ATT].max()
    else:
        raise FlightError(f"{log.source}: no GNSS velocity: give initial_velocity")
    if initial_velocity is None and track is not None:
        x0[POS], sd[POS] = track.position, track.position_sd
    elif (gnss_p := first("gnss", ("pn", "pe", "pd"))) is not None:
        x0[POS] = gnss_p[0] - body_to_ned(*x0[ATT]) @ x0[VEL] * gnss_p[1]
        sd[POS] = PRIOR_INFLATION * gnss_p[2] + abs(gnss_p[1]) * sd[IX["u"]]
    else:
        notes.append("no GNSS position: NED position from the first IMU sample")
    channel = baro_channel(log)
    baro = first("baro", (channel,)) if channel else None
    if channel and baro is not None:
        altitude, baro_sd = baro_altitude(channel, float(baro[0][0]), baro[2])
        x0[IX["alt0"]] = altitude + x0[IX["pd"]]
        sd[IX["alt0"]] = (PRIOR_INFLATION * baro_sd + sd[IX["pd"]]
                          + np.linalg.norm(x0[VEL]) * abs(baro[1]))
    return x0, np.diag(sd ** 2)
