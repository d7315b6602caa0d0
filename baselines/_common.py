"""Helpers shared by the baselines: measurements, noise levels, the filters' options (private).

The filters' model (the augmented state and its transition and measurement) is in
:mod:`baselines._augmented`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar, Literal, NamedTuple

import numpy as np
from scipy.signal import savgol_filter

import aeroid
from aeroid import estimation
from aeroid.estimation import EstimationResult, Estimator
from aeroid.flights import INPUTS, Flight, PaperNoise, flight_record
from baselines import _gauss_newton, _kalman
from baselines._augmented import COEFFICIENTS, STATES, augmented_model

SG_WINDOW = 7
#: Floors of the initial state sd taken from the data (a logged value's resolution: a
#: float32 log keeps 7 significant digits) [relative to the channel's RMS; and m/s or rad].
INITIAL_SD_FLOOR_REL = 1e-6
INITIAL_SD_FLOOR = 1e-6
#: State columns of the body rates and of the Euler angles; output columns of the gyros.
RATES = slice(aeroid.model.P, aeroid.model.R + 1)
ANGLES = slice(aeroid.model.PHI, aeroid.model.PSI + 1)
GYROS = slice(len(aeroid.model.ACCEL_CHANNELS), len(aeroid.model.OUTPUT_CHANNELS))


def measurements(flight: Flight) -> np.ndarray:
    """Return the measurement matrix ``[ax1, ay1, az1, ax2, ay2, az2, p, q, r]``, (n, m)."""
    return np.column_stack([flight[c] for c in aeroid.model.OUTPUT_CHANNELS])


def smoothed_start(y: np.ndarray, window: int = SG_WINDOW) -> np.ndarray:
    """Return the first sample of ``y`` (n, m) smoothed by a quadratic SG fit of ``window``
    samples (scipy's ``mode='interp'`` end fit), shape (m,)."""
    window = min(window, y.shape[0] - 1 + y.shape[0] % 2)
    return savgol_filter(y, window, min(2, window - 1), axis=0)[0]


def measurement_sd(flight: Flight, y: np.ndarray, method: str, floor_rel: float) -> np.ndarray:
    """Return the measurement-noise sd the filters assume, per channel, shape (m,).

    ``"data"``: :func:`aeroid.estimation.estimate_noise_sd` (RMS of the 7-point SG
    residual over the samples whose window holds no relay switch); ``"paper"``: the sd of
    eq. 43's multiplicative uniform noise at the paper's xi, ``xi / sqrt(3) * RMS(y)``
    (:meth:`aeroid.flights.PaperNoise.output_sd`, homoscedastic form).
    Both floored at ``floor_rel`` times the channel's RMS.
    """
    if method == "paper":
        sd = PaperNoise().output_sd(y, form="homoscedastic")[0]
        return np.maximum(sd, floor_rel * np.sqrt(np.mean(y * y, axis=0)))
    if method == "data":
        return estimation.estimate_noise_sd(
            y, statistic="rms", use=estimation.switch_free_samples(flight["delta"]),
            floor_fraction=floor_rel)
    raise ValueError(f"measurement_noise must be 'data' or 'paper', got {method!r}")


#: The filter's passes stop when no coefficient moved by more than this fraction of its
#: standard error from one pass to the next (AugmentedFilterOptions.max_passes).
PASS_TOL = 0.1
#: A later pass starts its coefficients at the previous pass's estimate with
#: PASS_INFLATION^2 times that pass's final coefficient covariance: 1 % of the data's
#: information (the estimate is pulled by ~1 % of the way to the previous pass's, the
#: standard errors come out ~0.5 % small; nothing at a fixed point). Restarting wide
#: instead loses what the first pass found (the first updates, linearised at a poor state,
#: overshoot): PASS_INFLATION = 1000 gave 1.82 % mean error and coverage 0.59 against
#: 0.43 % and 0.99 (measured, paper noise, prior 10-25 % off, 10 flights, max_passes 10).
PASS_INFLATION = 10.0
#: The noise law is refitted to the innovations before passes 2 .. LAW_REFITS + 1 and
#: held after, so that the later passes settle on a fixed point of one filter. Refitting
#: before every pass moved the estimate by 0.3-0.5 standard errors from pass to pass on
#: some flights without settling (measured, 10 flights, 10 passes).
LAW_REFITS = 2


def reconstruction_sd(flight: Flight, names: tuple[str, ...] = ("u", "v", "w", "phi", "theta",
                                                                 "psi")) -> np.ndarray | None:
    """Return the sd of the states ``names`` at the first sample of a reconstruction's
    flight (``metadata['initial_state_sd']``), or None for another flight (or sd that are
    missing, not numbers or not positive)."""
    given = flight.metadata.get("initial_state_sd")
    try:
        sd = np.array([float(given[k]) for k in names])  # type: ignore[index]
    except (TypeError, KeyError, ValueError):
        return None
    return sd if np.all(np.isfinite(sd) & (sd > 0)) else None


class FilterSetup(NamedTuple):
    """A filter's start: state and covariance, noise covariances, measurements.

    ``law = (a, b)``: the measurement-noise variance ``a + b yhat^2`` per channel
    (``b = 0`` for the ``channel`` noise model); ``r_floor``: the floor of ``a``.
    """

    x0: np.ndarray
    P0: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    zs: np.ndarray
    meas_sd: np.ndarray
    law: tuple[np.ndarray, np.ndarray]
    r_floor: np.ndarray
    position_free: tuple[int, ...]

    def R_of(self, y_pred: np.ndarray) -> np.ndarray:  # noqa: N802 - the filter's R
        """The measurement-noise covariance at the predicted measurement ``y_pred``."""
        a, b = self.law
        return np.diag(a + b * y_pred * y_pred)


@dataclass(frozen=True, kw_only=True)
class AugmentedFilterOptions(Estimator):
    """Options shared by the augmented-state EKF and UKF (not registered itself).

    Attributes
    ----------
    input : {"auto", "hold", "midpoint", "events", "law"}
        How the fin deflection between samples is modelled: ``auto`` (default) is
        ``law`` when the flight's airframe has a ``[fin_law]``, else ``hold``
        (:data:`aeroid.flights.INPUTS`).
    delay_s : float
        A known actuator delay [s] applied to that deflection (default 0).
    substeps : int
        RK4 steps per sample interval in the prediction (default 1).
    measurement_noise : {"data", "paper"}
        Measurement-noise sd per channel: ``"data"`` (default) from the Savitzky-Golay
        residual of each channel away from relay switches; ``"paper"``:
        ``0.05 / sqrt(3) * RMS`` (eq. 43's uniform noise).
    measurement_sd_floor_rel : float
        Lower bound of each channel's sd as a fraction of its RMS (default 1e-4; keeps
        R positive definite on noise-free data).
    initial_coefficient_sd_rel : float
        Initial sd of each coefficient as a fraction of ``|prior|`` (default 0.3).
    initial_velocity_sd_mps, initial_angle_sd_rad : float or None
        Initial sd of u, v, w [m/s] and of phi, theta, psi [rad]; default (None): on a
        reconstruction's flight (``Reconstruction.to_flight``) the reconstruction's sd at
        the first sample (``metadata['initial_state_sd']``), else each
        channel's noise level estimated from the data
        (:func:`aeroid.estimation.estimate_noise_sd`): the state starts at the first
        measured sample, as uncertain as that measurement. Clean channels (the velocities
        and angles of the paper's and the Gaussian noise models) then start nearly exact;
        the former fixed 0.05 m/s and 0.01 rad gave the filter freedom that the data do
        not allow, and every force scales with V^2. The initial rates get their
        measurement sd.
    process_velocity_sd_mps, process_rate_sd_radps, process_angle_sd_rad : float
        Process-noise sd per sample interval on u, v, w [m/s], p, q, r [rad/s] and the
        angles [rad] (default 0: the model is deterministic). Measured (tactical Gaussian
        IMU, exact positions): process noise of 1e-3 rad/s per step on the rates put the
        EKF at 1.19 % mean error against output-error's 0.72 %, with intervals 10x too
        wide on Cl0/Clp; without it, at output-error.
    noise_model : {"channel", "signal"}
        Measurement noise: one sd per channel (``measurement_noise``), or per sample
        ``R_kc = a_c + b_c yhat_kc^2`` with ``a, b`` estimated from the data
        (:func:`aeroid.estimation.estimate_noise_law`) and ``yhat`` the predicted
        measurement (the paper's eq. 43 noise is proportional to the signal).
    positions : {"estimate", "known"}
        Accelerometer-position components the airframe calls uncertain (sd > 0) are
        carried in the state with that initial sd (default ``estimate``), or taken as
        known.
    coefficient_random_walk_rel : float
        Random-walk sd of the coefficients per sample interval as a fraction of
        ``|prior|`` (default 0: constant coefficients).
    max_passes : int
        Forward passes over the flight at most (default 6). The first starts from the
        prior with the noise law of the data's smoother residuals
        (``measurement_noise`` / :func:`aeroid.estimation.estimate_noise_law`). Each
        later pass starts its coefficients at the previous pass's estimate with
        :data:`PASS_INFLATION` times its standard errors (the position offsets, a real
        prior, start again at the given positions with their sd); before passes 2 and 3
        the noise law is refitted to the previous pass's innovations
        (:meth:`innovation_noise_law`, :data:`LAW_REFITS`). The passes stop when no
        coefficient moves by more than :data:`PASS_TOL` of its standard error; a filter
        still moving after ``max_passes`` says so in the result's warnings. Why: one
        pass linearises its first updates around the prior, 10-25 % off, and keeps
        what they did (no process noise); and the smoother's residuals misjudge the
        noise of the rolling accelerometers (the roll-frequency signal a 7-point
        quadratic does not follow: ``b`` of ax1 came out 0 where eq. 43 has 8.3e-4).
        Measured (``python benchmarks/bench_filter_passes.py``): paper noise with 10 %
        position error, prior 10-25 % off, 20 flights: one pass 2.17 % mean error,
        coverage 0.74; the passes (3-5) 0.43 %, coverage 0.97, against output-error's
        0.36 %; a tactical Gaussian IMU: 0.727 % against 0.729 %.
        ``max_passes = 1`` is the single pass.
    """

    uses_state_sd: ClassVar[bool] = True  # the initial covariance: reconstruction_sd

    input: Literal["auto", "hold", "midpoint", "events", "law"] = "auto"
    delay_s: float = 0.0
    substeps: int = 1
    measurement_noise: Literal["data", "paper"] = "data"
    measurement_sd_floor_rel: float = 1e-4
    initial_coefficient_sd_rel: float = 0.3
    initial_velocity_sd_mps: float | None = None
    initial_angle_sd_rad: float | None = None
    process_velocity_sd_mps: float = 0.0
    process_rate_sd_radps: float = 0.0
    process_angle_sd_rad: float = 0.0
    coefficient_random_walk_rel: float = 0.0
    noise_model: Literal["channel", "signal"] = "signal"
    positions: Literal["estimate", "known"] = "estimate"
    max_passes: int = 6

    def __post_init__(self) -> None:
        if self.input not in INPUTS:
            raise ValueError(f"input must be one of {', '.join(INPUTS)}, got {self.input!r}")
        if not (math.isfinite(self.delay_s) and abs(self.delay_s) < 0.1):
            raise ValueError(f"delay_s must be seconds below 0.1 in magnitude, got {self.delay_s}")
        if self.substeps < 1:
            raise ValueError(f"substeps must be >= 1, got {self.substeps}")
        if not (isinstance(self.max_passes, int) and self.max_passes >= 1):
            raise ValueError(f"max_passes must be an integer >= 1, got {self.max_passes!r}")
        for name in ("measurement_sd_floor_rel", "initial_coefficient_sd_rel",
                     "initial_velocity_sd_mps", "initial_angle_sd_rad"):
            if getattr(self, name) is not None and not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        for name in ("process_velocity_sd_mps", "process_rate_sd_radps",
                     "process_angle_sd_rad", "coefficient_random_walk_rel"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")

    def position_free(self, flight: Flight) -> tuple[int, ...]:
        """Position components carried in the state (indices into the six)."""
        if self.positions != "estimate":
            return ()
        return tuple(int(c) for c in np.flatnonzero(flight.airframe.accel_position_sd.ravel()))

    def setup(self, flight: Flight) -> FilterSetup:
        """Return the filter's start, noise covariances and measurements."""
        zs = measurements(flight)
        meas_sd = measurement_sd(flight, zs, self.measurement_noise,
                                 self.measurement_sd_floor_rel)
        prior = flight.airframe.prior_vector()
        free = self.position_free(flight)
        states = flight.states()
        # the data's noise, but never below a logger's resolution (noise-free flights, a
        # channel that stays at zero): INITIAL_SD_FLOOR_REL of the channel's RMS, and
        # INITIAL_SD_FLOOR in its unit
        rms = np.sqrt(np.mean(states * states, axis=0))
        data_sd = np.maximum(estimation.estimate_noise_sd(states),
                             np.maximum(INITIAL_SD_FLOOR_REL * rms, INITIAL_SD_FLOOR))
        given = reconstruction_sd(flight)  # a reconstruction's sd of the first state
        velocity_sd = (np.full(3, self.initial_velocity_sd_mps)
                       if self.initial_velocity_sd_mps is not None
                       else given[0:3] if given is not None else data_sd[0:3])
        angle_sd = (np.full(3, self.initial_angle_sd_rad)
                    if self.initial_angle_sd_rad is not None
                    else given[3:6] if given is not None else data_sd[ANGLES])
        position_sd = flight.airframe.accel_position_sd.ravel()[list(free)]
        x0 = np.concatenate([states[0], prior, np.zeros(len(free))])
        sd0 = np.concatenate([velocity_sd, meas_sd[GYROS], angle_sd,
                              self.initial_coefficient_sd_rel * np.abs(prior), position_sd])
        sdq = np.concatenate([
            np.full(3, self.process_velocity_sd_mps), np.full(3, self.process_rate_sd_radps),
            np.full(3, self.process_angle_sd_rad),
            self.coefficient_random_walk_rel * np.abs(prior), np.zeros(len(free)),
        ])
        r_floor = (self.measurement_sd_floor_rel * np.sqrt(np.mean(zs * zs, axis=0))) ** 2
        if self.noise_model == "signal":
            a, b = estimation.estimate_noise_law(
                zs, use=estimation.switch_free_samples(flight["delta"]))
            law = (np.maximum(a, r_floor), b)
        else:
            law = (meas_sd**2, np.zeros_like(meas_sd))
        return FilterSetup(x0, np.diag(sd0**2), np.diag(sdq**2), np.diag(meas_sd**2), zs,
                           meas_sd, law, r_floor, free)

    def innovation_noise_law(self, out: _kalman.FilterOutput, setup: FilterSetup
                             ) -> tuple[np.ndarray, np.ndarray]:
        """Refit the noise law to a pass's innovations.

        The squared innovations less the state's share of their variance
        (``innovation_var - noise_var``, the diagonal of ``H P^- H^T``) are regressed on
        ``[1, yhat^2]`` (``signal``) or on ``[1]`` (``channel``) by
        :func:`aeroid.estimation.fit_noise_law`; ``a`` keeps the setup's floor and at
        least ``A_FLOOR_REL`` of the mean squared innovation (as output-error's noise
        step).
        """
        e2 = out.innovation**2
        y_pred = setup.zs - out.innovation
        s2 = y_pred**2 if self.noise_model == "signal" else np.zeros_like(e2)
        floor = np.maximum(setup.r_floor, _gauss_newton.A_FLOOR_REL * np.mean(e2, axis=0))
        return estimation.fit_noise_law(e2, s2, known=out.innovation_var - out.noise_var,
                                        floor=floor)

    def run_passes(self, flight: Flight,
                   run_filter: Callable[[_kalman.DiscreteModel, FilterSetup],
                                        _kalman.FilterOutput],
                   evaluations_per_pass: Callable[[_kalman.DiscreteModel], int]
                   ) -> EstimationResult:
        """Run the filter's passes over the flight (``max_passes``) and return the result.

        ``run_filter(model, setup)`` is one forward pass (EKF or UKF). A pass that fails
        after a good one leaves the good one as the result, with a warning.
        """
        setup = self.setup(flight)
        model = augmented_model(flight, self.substeps,
                                flight_record(flight, self.input, self.delay_s),
                                setup.position_free)
        out = run_filter(model, setup)
        changes: list[float] = []
        warnings: list[str] = []
        n_passes = 1
        while out.failed_at is None and n_passes < self.max_passes:
            x0 = setup.x0.copy()
            x0[COEFFICIENTS] = out.x[-1, COEFFICIENTS]
            P0 = setup.P0.copy()
            P0[COEFFICIENTS, COEFFICIENTS] = PASS_INFLATION**2 * out.P[COEFFICIENTS,
                                                                        COEFFICIENTS]
            law = self.innovation_noise_law(out, setup) if n_passes <= LAW_REFITS else setup.law
            nxt_setup = setup._replace(x0=x0, P0=P0, law=law)
            nxt = run_filter(model, nxt_setup)
            n_passes += 1
            if nxt.failed_at is not None:
                warnings.append(
                    f"pass {n_passes} diverged at t = {flight.t[nxt.failed_at]:.4f} s "
                    f"({nxt.reason}); the result is pass {n_passes - 1}'s")
                break
            changes.append(float(np.nanmax(np.abs(nxt.x[-1, COEFFICIENTS]  # held: 0/0
                                               - out.x[-1, COEFFICIENTS])
                                        / nxt.sd[-1, COEFFICIENTS])))
            out, setup = nxt, nxt_setup
            if changes[-1] <= PASS_TOL:
                break
        else:
            if changes and changes[-1] > PASS_TOL:
                warnings.append(
                    f"the passes had not settled after {n_passes} (max_passes): the last "
                    f"moved a coefficient by {changes[-1]:.2f} standard errors")
        result = self.result(flight, out, setup,
                             n_evaluations=n_passes * evaluations_per_pass(model))
        result.info["passes"] = n_passes
        result.info["pass_changes"] = changes
        result.info["noise_law"] = {"a": setup.law[0], "b": setup.law[1]}
        if not warnings:
            return result
        return dataclasses.replace(result, warnings=(*result.warnings, *warnings))

    def result(self, flight: Flight, out: _kalman.FilterOutput, setup: FilterSetup,
               n_evaluations: int) -> EstimationResult:
        """Turn a filter pass into an :class:`EstimationResult` (history axis 'time')."""
        t = flight.t
        history = {"axis": "time", "step": t, "theta": out.x[:, COEFFICIENTS],
                   "theta_sd": out.sd[:, COEFFICIENTS]}
        info = {"measurement_sd": setup.meas_sd, "state": out.x[:, STATES],
                "state_sd": out.sd[:, STATES]}
        if out.failed_at is not None:
            message = f"filter diverged at t = {t[out.failed_at]:.4f} s: {out.reason}"
            return aeroid.failed_result(self.name, message, history=history, info=info,
                                        n_iterations=int(out.failed_at))
        cov = out.P[COEFFICIENTS, COEFFICIENTS].copy()
        # the fit check reads the innovations of the second half (after the coefficients'
        # initial uncertainty has been worked off)
        half = len(t) // 2
        info["fit_residuals"] = {name: out.innovation[half:, j]
                                 for j, name in enumerate(aeroid.model.OUTPUT_CHANNELS)}
        positions = flight.airframe.accel_positions.ravel().copy()
        position_sd = np.zeros(6)
        for j, c in enumerate(setup.position_free):
            positions[c] += out.x[-1, COEFFICIENTS.stop + j]
            position_sd[c] = out.sd[-1, COEFFICIENTS.stop + j]
        info["accel_positions_m"] = positions.reshape(2, 3)
        info["accel_position_stderr_m"] = position_sd.reshape(2, 3)
        return EstimationResult(
            estimator=self.name, theta=out.x[-1, COEFFICIENTS], stderr=np.sqrt(np.diag(cov)),
            covariance=cov, cost=math.nan, success=True, message="",
            n_evaluations=n_evaluations, n_iterations=len(t), history=history, info=info,
        )


def pooled_sd(levels: list[np.ndarray], counts: list[int]) -> np.ndarray:
    """``sqrt(sum n_w s_w^2 / sum n_w)`` per channel: noise levels pooled over windows."""
    total = sum(n * np.asarray(s, dtype=float) ** 2 for s, n in zip(levels, counts, strict=True))
    return np.sqrt(total / sum(counts))
