"""Air data (alpha, beta, airspeed) as measured outputs of the EKF and UKF (issue 26; private).

``air_data = "measured"`` (or ``"auto"`` on a flight that has air data;
:class:`AirFilterOptions`) appends the log's air-data channels to the filter's
measurements at every sample, as output-error's ``air_data`` does
(:mod:`baselines._oe_airdata`):

- **Prediction**: the model's own air-relative velocity. The air data of the filter's
  state ``z`` are output-error's probe outputs (:func:`baselines._oe_airdata.
  _probe_outputs`: :func:`aeroid.model.equations.air_velocity` with the wind in the
  constants by :func:`aeroid.model.with_wind_symbols`, plus the rotation-induced flow at
  the probe ``omega x r``, then :func:`aeroid.model.equations.air_data`), evaluated at the
  airframe's states and the wind the loads see: the steady wind's states
  (``estimate_wind``) plus the gust states (``gust_sd_mps``, ``estimate_gust_sd``), 0 in
  still air. Jacobians exact (CasADi AD); the UKF maps the same function over its sigma
  points.
- **Calibration** (``air_data_calibration``, default ``factor+offset``, as output-error's):
  ``logged = (1 + k) angle + b`` per angle, ``k`` and ``b`` constant states appended to
  the filter's state, started at 0 with ``air_data_factor_sd`` and
  ``air_data_offset_sd_rad`` as sd (each pass afresh with the smoothed passes; with the
  carried passes where the last ended, with ``PASS_INFLATION`` times their sd).
- **Probe position**: ``metadata["air_data_probe"]["position_m"]``
  (:func:`baselines._oe_airdata.probe_position`; the c.g. without it, said).
- **Noise** (``air_data_noise``): ``data`` (default) one variance per channel, started
  at the channel's smoother-residual level (:func:`aeroid.estimation.estimate_noise_sd`)
  and refitted to the innovations with the IMU's law (before passes 2 and 3); or
  ``metadata``: the log's ``metadata["air_data_probe"]["noise_sd"]`` (a table ``channel
  = sd``, SI), held.

Not built (refused in one line): with ``imu_errors``, GNSS ``aiding`` or several windows.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

import casadi as ca
import numpy as np

from aeroid import estimation
from aeroid.errors import EstimatorError, FlightError
from aeroid.flights import Flight, flight_record, model_constants
from aeroid.model import EXOGENOUS, N_STATE, Constants, symbolic, with_wind_symbols
from baselines import _common, _kalman
from baselines._oe_airdata import (
    CALIBRATIONS,
    OE_CHOICES,
    PROBE_KEY,
    _probe_outputs,
    air_channels,
    calibration_names,
    probe_position,
)

#: The option ``air_data_noise``.
NOISE_CHOICES: tuple[str, ...] = ("data", "metadata")
#: Default initial sd of a flow-angle calibration factor (a vane's gain or upwash of a
#: few per cent lies well inside) and offset [rad] (1 deg).
FACTOR_SD = 0.1
OFFSET_SD_RAD = float(np.radians(1.0))
#: Units of the air-data channels in the notice.
UNITS = {"alpha": "rad", "beta": "rad", "airspeed": "m/s"}
#: Floor of an air-data channel's noise variance, relative to its mean square (as the
#: filters' ``measurement_sd_floor_rel`` = 1e-4 on the sd).
VAR_FLOOR_REL = 1e-8


@dataclass(frozen=True, kw_only=True)
class AirOutputOptions:
    """The air-data options of every filter that takes air data as measured outputs
    (filter-error's as they are, :class:`baselines._fem_air.FemAirOption`; the EKF/UKF's
    add their calibration states' initial sd, :class:`AirFilterOptions`): ``air_data``,
    ``air_data_calibration``, ``air_data_noise`` (their meaning: those classes)."""

    air_data: Literal["inertial", "auto", "measured"] = "inertial"
    air_data_calibration: Literal["none", "offset", "factor", "factor+offset"] = \
        "factor+offset"
    air_data_noise: Literal["data", "metadata"] = "data"

    @property
    def uses_air_data(self) -> bool:  # Estimator's flag: fit() warns when False
        """Whether the fit may use the flight's air data (``air_data`` not inertial)."""
        return self.air_data != "inertial"

    def check_air_options(self) -> None:
        """Raise ValueError (one line) for an air-data option out of its range."""
        for name, choices in (("air_data", OE_CHOICES),
                              ("air_data_calibration", CALIBRATIONS),
                              ("air_data_noise", NOISE_CHOICES)):
            if getattr(self, name) not in choices:
                raise ValueError(f"{name} must be one of {', '.join(choices)}, got "
                                 f"{getattr(self, name)!r}")


@dataclass(frozen=True, kw_only=True)
class AirFilterOptions(AirOutputOptions):
    """The EKF/UKF's air-data options (a base of :class:`baselines._imu_states.
    ImuFilterOptions`).

    Attributes
    ----------
    air_data : {"inertial", "auto", "measured"}
        ``"measured"``: the flight's air data (logged ``alpha``, ``beta`` that differ from
        the inertial ones; a logged ``airspeed``) as measured outputs at every sample, or
        a one-line refusal of a flight without them; ``"auto"``: those outputs when the
        flight has air data; ``"inertial"`` (default: the option adds measurements and
        states): left out, and said ignored (:mod:`baselines._kalman_air`).
    air_data_calibration : {"none", "offset", "factor", "factor+offset"}
        Flow-angle calibration states (default ``"factor+offset"``): ``logged = (1 + k)
        angle + b`` per angle.
    air_data_factor_sd, air_data_offset_sd_rad : float
        Initial sd of the calibration factors [-] and offsets [rad] (defaults 0.1, 1 deg).
    air_data_noise : {"data", "metadata"}
        The probe's noise variance per channel: from the data, refitted to the
        innovations (default), or the log's ``metadata["air_data_probe"]["noise_sd"]``.
    """

    air_data_factor_sd: float = FACTOR_SD
    air_data_offset_sd_rad: float = OFFSET_SD_RAD

    def check_air_options(self) -> None:
        """Raise ValueError (one line) for an air-data option out of its range."""
        super().check_air_options()
        for name in ("air_data_factor_sd", "air_data_offset_sd_rad"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")


@dataclass(frozen=True)
class AirPlan:
    """The air data a fit uses: channels, calibration states, probe, measurements, noise.

    ``z`` (n, k) the logged values; ``var`` (k,) the initial noise variances; ``held``:
    the variances are the log's (not refitted); ``cal_sd`` the calibration states'
    initial sd.
    """

    channels: tuple[str, ...]
    calibration: tuple[str, ...]
    probe: np.ndarray
    probe_where: str
    z: np.ndarray
    var: np.ndarray
    held: bool
    cal_sd: np.ndarray
    floor: np.ndarray


def air_plan(est: Any, flight: Flight) -> AirPlan | None:
    """The air data ``est`` uses on ``flight`` (None: none).

    Raises
    ------
    FlightError
        ``air_data = "measured"`` on a flight without air data; a bad probe position or
        noise table.
    EstimatorError
        Air data with ``imu_errors`` or GNSS ``aiding`` (not built).
    """
    parts = measured_air(est, flight)
    if parts is None:
        return None
    for on, what in ((est.imu_errors != "none", f"imu_errors = {est.imu_errors}"),
                     (est.aiding != "none", f"aiding = {est.aiding}")):
        if on:
            raise EstimatorError(f"{est.name}: air_data = {est.air_data} with {what} is not "
                                 "built; set air_data = inertial")
    cal_sd = np.array([est.air_data_factor_sd if c.endswith("_factor")
                       else est.air_data_offset_sd_rad for c in parts["calibration"]])
    return AirPlan(**parts, cal_sd=cal_sd)


def measured_air(est: Any, flight: Flight) -> dict[str, Any] | None:
    """What every filter taking air data as measurements reads from ``flight`` for
    ``est``'s options (:class:`AirOutputOptions`): ``channels``, ``calibration``,
    ``probe``, ``probe_where``, ``z`` (n, k), ``var`` (k,) the initial noise variances
    (the log's with ``air_data_noise = metadata``, else the data's), ``held``, ``floor``;
    None without air data (``air_data = "measured"`` then refused in one line)."""
    if est.air_data == "inertial":
        return None
    channels = air_channels(flight)
    if not channels:
        if est.air_data == "measured":
            where = flight.metadata.get("source", "flight")
            raise FlightError(f"{est.name}: air_data = 'measured' but {where} has no airspeed "
                              "channel and no logged alpha and beta apart from the inertial "
                              "atan(w/u), asin(v/V)")
        return None
    probe, probe_where = probe_position(flight)
    z = np.column_stack([np.asarray(flight[c], dtype=float) for c in channels])
    floor = VAR_FLOOR_REL * np.mean(z * z, axis=0) + 1e-300
    held = est.air_data_noise == "metadata"
    var = (_metadata_variances(flight, channels, est.name) if held
           else estimation.estimate_noise_sd(z, statistic="rms") ** 2)
    return {"channels": channels, "calibration": tuple(calibration_names(est, channels)),
            "probe": probe, "probe_where": probe_where, "z": z,
            "var": np.maximum(var, floor), "held": held, "floor": floor}


def _metadata_variances(flight: Flight, channels: tuple[str, ...], who: str) -> np.ndarray:
    where = flight.metadata.get("source", "flight")
    probe = flight.metadata.get(PROBE_KEY)
    table = probe.get("noise_sd") if isinstance(probe, Mapping) else None
    try:
        if not isinstance(table, Mapping):
            raise TypeError("no table")
        sd = np.array([float(table[c]) for c in channels])
        if not np.all(np.isfinite(sd) & (sd > 0)):
            raise ValueError("not positive")
    except (KeyError, TypeError, ValueError) as exc:
        raise FlightError(f"{who}: air_data_noise = metadata needs {where}'s metadata "
                          f"{PROBE_KEY}.noise_sd with a positive sd (SI) for each of "
                          f"{', '.join(channels)}: {exc}") from None
    return sd**2


@functools.lru_cache(maxsize=16)
def _air_functions(const: Constants, varying: bool, channels: tuple[str, ...],
                   calibration: tuple[str, ...]) -> tuple[ca.Function, ca.Function]:
    """``air(x (9), wind (3), exo, r (3), cal) -> (y, dy/dx, dy/dwind, dy/dcal)`` and
    its plain form (``y`` only)."""
    x, wind, r = ca.SX.sym("x", N_STATE), ca.SX.sym("wind", 3), ca.SX.sym("r", 3)
    sym = symbolic.interval_symbols(1, varying)
    exo = ca.SX.sym("exo", sym.exo_a.shape[0])
    cal = ca.SX.sym("cal", len(calibration))
    const_w, _, row = with_wind_symbols(const, sym, wind)
    y = _probe_outputs(x, symbolic.sample_constants(const_w, exo + row), r, cal, channels,
                       calibration)
    jac = [ca.densify(ca.jacobian(y, v)) for v in (x, wind, cal)]
    return (ca.Function("air_filter", [x, wind, exo, r, cal], [y, *jac]),
            ca.Function("air_filter_plain", [x, wind, exo, r, cal], [y]))


def air_model(model: _kalman.DiscreteModel, flight: Flight, plan: AirPlan, input_: str,
              delay_s: float, wind_columns: tuple[int, ...]) -> _kalman.DiscreteModel:
    """``model`` with the calibration states appended and the air data after its outputs.

    ``wind_columns``: the first index of each three-component wind block of ``model``'s
    state the loads see (the steady wind's, the gusts'; summed), empty in still air.
    State ``[z, c]``, ``c`` constant (transition Jacobian identity); measurement ``[h(z),
    air(z, c)]`` with ``air``'s Jacobian in the airframe's states, each wind block and
    ``c``.
    """
    const = model_constants(flight)
    record = flight_record(flight, input_, delay_s)
    varying = record.exogenous is not None
    const = Constants(*(float(v) for v in const))
    if varying:  # as the wind model: per-sample values replace these
        const = const._replace(**dict.fromkeys(EXOGENOUS, 0.0))
    _, _, exo_table = record.symbolic_inputs()
    full, plain = _air_functions(const, varying, plan.channels, plan.calibration)
    n_in, n_cal, k = model.dim_x, len(plan.calibration), len(plan.channels)
    n, m = n_in + n_cal, model.dim_z
    probe = plan.probe
    mapped: dict[int, ca.Function] = {}

    def wind_of(z: np.ndarray) -> np.ndarray:
        total = np.zeros(z.shape[:-1] + (3,))
        for c in wind_columns:
            total = total + z[..., c:c + 3]
        return total

    def transition(z: np.ndarray, step: int) -> tuple[np.ndarray, np.ndarray]:
        z_next, F_in = model.transition(z[:n_in], step)
        F = np.eye(n)
        F[:n_in, :n_in] = F_in
        return np.concatenate([np.asarray(z_next, dtype=float).ravel(), z[n_in:]]), F

    def observe(z: np.ndarray, step: int) -> tuple[np.ndarray, np.ndarray]:
        y, H_in = model.observe(z[:n_in], step)
        ya, dx, dw, dc = full(z[:N_STATE], wind_of(z), exo_table[:, step], probe, z[n_in:])
        H = np.zeros((m + k, n))
        H[:m, :n_in] = H_in
        H[m:, :N_STATE] = np.asarray(dx)
        for c in wind_columns:
            H[m:, c:c + 3] += np.asarray(dw)
        H[m:, n_in:] = np.asarray(dc).reshape(k, n_cal)
        return np.concatenate([np.asarray(y, dtype=float).ravel(),
                               np.asarray(ya).ravel()]), H

    def transition_batch(Z: np.ndarray, step: int) -> np.ndarray:
        assert model.transition_batch is not None
        return np.hstack([model.transition_batch(Z[:, :n_in], step), Z[:, n_in:]])

    def observe_batch(Z: np.ndarray, step: int) -> np.ndarray:
        assert model.observe_batch is not None
        if len(Z) not in mapped:
            mapped[len(Z)] = plain.map(len(Z))
        ya = mapped[len(Z)](Z[:, :N_STATE].T, wind_of(Z).T, exo_table[:, step], probe,
                            Z[:, n_in:].T)
        return np.hstack([model.observe_batch(Z[:, :n_in], step), np.asarray(ya).T])

    batched = model.transition_batch is not None and model.observe_batch is not None
    return _kalman.DiscreteModel(n, m + k, transition, observe,
                                 transition_batch if batched else None,
                                 observe_batch if batched else None)


def air_setup(setup: _common.FilterSetup, plan: AirPlan, var: np.ndarray,
              last: _kalman.FilterOutput | None = None) -> _common.FilterSetup:
    """``setup`` with the calibration states (at 0 with their sd; ``last``: where that
    pass ended, with ``PASS_INFLATION`` times its sd) and the air-data measurements with
    noise variances ``var`` appended."""
    n, n_cal, k = setup.x0.size, len(plan.calibration), len(plan.channels)
    x0 = np.concatenate([setup.x0, np.zeros(n_cal)])
    P0, Q = np.zeros((n + n_cal, n + n_cal)), np.zeros((n + n_cal, n + n_cal))
    P0[:n, :n], Q[:n, :n] = setup.P0, setup.Q
    P0[n:, n:] = np.diag(plan.cal_sd**2)
    if last is not None and n_cal:
        x0[n:] = last.x[-1, -n_cal:]
        P0[n:, n:] = _common.PASS_INFLATION**2 * last.P[-n_cal:, -n_cal:]
    m = setup.zs.shape[1]
    R = np.zeros((m + k, m + k))
    R[:m, :m], R[m:, m:] = setup.R, np.diag(var)
    a, b = setup.law
    return setup._replace(
        x0=x0, P0=P0, Q=Q, R=R, zs=np.hstack([setup.zs, plan.z]),
        meas_sd=np.concatenate([setup.meas_sd, np.sqrt(var)]),
        law=(np.concatenate([a, var]), np.concatenate([b, np.zeros(k)])),
        r_floor=np.concatenate([setup.r_floor, plan.floor]))


def refit_variances(out: _kalman.FilterOutput, plan: AirPlan) -> np.ndarray:
    """The air channels' noise variances refitted to a pass's innovations: the mean of
    ``e^2`` less the state's share ``innovation_var - noise_var`` (as the IMU's law,
    constant) over the second half (as the fit check reads them: over the whole record
    the first samples' share, from the calibration's wide start, is larger than what
    their innovations show, and the airspeed's sd came out 0.28 m/s for the true 0.5,
    seed 1), floored; the log's variances when held."""
    if plan.held or out.innovation_var is None or out.noise_var is None:
        return plan.var
    k, half = len(plan.channels), out.innovation.shape[0] // 2
    e, s, r = (a[half:, -k:] for a in (out.innovation, out.innovation_var, out.noise_var))
    with np.errstate(invalid="ignore"):
        var = np.nanmean(e * e - (s - r), axis=0)
    return np.where(np.isfinite(var), np.maximum(var, plan.floor), plan.var)


def air_report(out: _kalman.FilterOutput, plan: AirPlan, var: np.ndarray, who: str,
               flight: Flight, wind_first: int | None) -> tuple[dict[str, Any], tuple[str, ...]]:
    """``info`` entries (``fit_residuals`` of the air channels over the second half, as
    the IMU's; ``air_data``: channels, calibration with its sd, noise sd, probe, and
    ``air_data_verdict``) and the fit's one-line notices: what was used, and still air,
    a steady wind or turbulence (:mod:`aeroid.estimation._air_verdict`). With the
    steady wind's states at ``wind_first`` (no gust states), as output-error's: what the
    filtered wind and calibration leave of the air data (the second half's innovations,
    in m/s), so a miscalibrated vane turning with the roll is not called turbulence;
    otherwise the log alone (with gust states the filtered gust path is the figure)."""
    k, n_cal = len(plan.channels), len(plan.calibration)
    half = out.innovation.shape[0] // 2
    residuals = {c: out.innovation[half:, -k + j] for j, c in enumerate(plan.channels)}
    x, sd = out.x[-1], np.sqrt(np.diag(out.P))
    cal = dict(zip(plan.calibration, x[x.size - n_cal:].tolist(), strict=True))
    cal_sd = dict(zip(plan.calibration, sd[sd.size - n_cal:].tolist(), strict=True))
    noise = dict(zip(plan.channels, np.sqrt(var).tolist(), strict=True))
    info = {"channels": plan.channels, "calibration": cal, "calibration_stderr": cal_sd,
            "noise_sd": noise, "noise": "the log's (held)" if plan.held else
            "from the data, refitted to the innovations",
            "probe_position_m": plan.probe.tolist(), "probe": plan.probe_where}
    shown = ", ".join(f"{c} {noise[c]:.3g} {UNITS[c]}" for c in plan.channels)
    calib = "; ".join(f"{c} {v:+.4g} +- {cal_sd[c]:.2g}" for c, v in cal.items()) or "none"
    if wind_first is None:
        verdict = estimation.air_data_verdict(flight, who)
    else:
        speed = float(np.mean(flight["airspeed"] if "airspeed" in plan.channels else
                              np.sqrt(sum(flight[c] ** 2 for c in ("u", "v", "w")))))
        rest = np.column_stack([r * (1.0 if c == "airspeed" else speed)
                                for c, r in residuals.items()])
        w = slice(wind_first, wind_first + 3)
        verdict = estimation.verdict_of(flight, who, rest, x[w], sd[w], source=(
            " after the filtered steady wind and calibration"))
    if verdict is not None:
        info["air_data_verdict"] = verdict.as_info()
    return {"air_innovations": residuals, "air_data": info}, (
        f"{who}: air data as measured outputs ({', '.join(plan.channels)}; "
        f"{plan.probe_where}); noise sd {shown} ({info['noise']}); calibration {calib}",
        *(() if verdict is None else (verdict.line,)))


def refuse_windows(est: Any, windows: Any) -> None:
    """Raise the one-line error for air data with several windows (not built): with
    ``measured``, or ``auto`` when a window has air data."""
    if est.air_data == "measured" or (est.air_data == "auto" and any(
            air_channels(f) for f in windows.flights)):
        raise EstimatorError(f"{est.name}: air_data = {est.air_data} with several windows is "
                             "not built; set air_data = inertial")
