"""Helpers shared by the baselines: measurements, noise levels, the filters' model (private)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.signal import savgol_filter

import aeroid
from aeroid import estimation
from aeroid.estimation import EstimationResult, Estimator
from aeroid.flights import INPUTS, Flight, flight_record, model_constants
from aeroid.model import Pieces, Record, symbolic
from baselines import _kalman

SG_WINDOW = 7
#: Default uniform noise amplitude of eq. 43 (the paper's xi on accelerations and rates).
PAPER_XI = 0.05


def measurements(flight: Flight) -> np.ndarray:
    """Return the measurement matrix ``[ax1, ay1, az1, ax2, ay2, az2, p, q, r]``, (n, 9)."""
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
    eq. 43's multiplicative uniform noise, ``xi / sqrt(3) * RMS(y)`` with ``xi = 0.05``.
    Both floored at ``floor_rel`` times the channel's RMS.
    """
    if method == "paper":
        sd = PAPER_XI / math.sqrt(3.0) * np.sqrt(np.mean(y * y, axis=0))
        return np.maximum(sd, floor_rel * np.sqrt(np.mean(y * y, axis=0)))
    if method == "data":
        return estimation.estimate_noise_sd(
            y, statistic="rms", use=estimation.switch_free_samples(flight["delta"]),
            floor_fraction=floor_rel)
    raise ValueError(f"measurement_noise must be 'data' or 'paper', got {method!r}")


def augmented_model(flight: Flight, substeps: int, record: Record | None = None
                    ) -> _kalman.DiscreteModel:
    """Return the 18-state augmented model ``[x, theta]`` of ``flight`` for the filters.

    The transition from sample k to k+1 is one interval of the model's record
    (``record``, default the logged deflection held; ``substeps`` RK4 steps per piece);
    coefficients are constant. Jacobians come from CasADi AD
    (:func:`aeroid.model.symbolic.augmented_functions`); the batched versions (UKF) use
    :func:`aeroid.model.propagate` and :func:`aeroid.model.accelerometers`.
    """
    const = model_constants(flight)
    record = record or flight_record(flight)
    delta, pieces_table, exo_table = record.symbolic_inputs()
    delta = delta[0]
    positions = flight.airframe.accel_positions
    pos_flat = positions.ravel()
    varying = record.exogenous is not None
    f, h = symbolic.augmented_functions(const, record.dt, substeps, record.n_pieces, varying)

    def transition(z: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        z_next, F = f(z, pieces_table[:, k], exo_table[:, k], exo_table[:, k + 1])
        return np.asarray(z_next).ravel(), np.asarray(F)

    def observe(z: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        y, H = h(z, delta[k], exo_table[:, k], pos_flat)
        return np.asarray(y).ravel(), np.asarray(H)

    def transition_batch(Z: np.ndarray, k: int) -> np.ndarray:
        # numpy backend: one RK4 step of 37 sets is too little work for numba's parallel
        # launch, which cost ~5 ms per call on a busy 2-core machine (measured)
        interval = Pieces(*(a[k:k + 1] for a in record.pieces))
        exo = None if not varying else record.exogenous[k:k + 2]
        x_next = aeroid.model.propagate(Z[:, :9], Z[:, 9:], interval, record.dt, const,
                                        substeps=substeps, backend="numpy",
                                        exogenous=exo)[:, 1]
        return np.concatenate([x_next, Z[:, 9:]], axis=1)

    def observe_batch(Z: np.ndarray, k: int) -> np.ndarray:
        const_k = const if not varying else aeroid.model.with_exogenous(
            const, record.exogenous[k])
        acc = aeroid.model.accelerometers(Z[:, :9], delta[k], Z[:, 9:], const_k, positions)
        return np.concatenate([acc.reshape(len(Z), 6), Z[:, 3:6]], axis=1)

    return _kalman.DiscreteModel(18, 9, transition, observe, transition_batch, observe_batch)


@dataclass(frozen=True, kw_only=True)
class AugmentedFilterOptions(Estimator):
    """Options shared by the augmented-state EKF and UKF (not registered itself).

    Attributes
    ----------
    input : {"hold", "midpoint", "events", "law"}
        How the fin deflection between samples is modelled (:data:`aeroid.flights.INPUTS`;
        default ``hold``).
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
    initial_velocity_sd_mps, initial_angle_sd_rad : float
        Initial sd of u, v, w [m/s] (default 0.05: the flight's velocity channels are
        measured, clean in the paper's noise model; every force scales with V^2, so a
        loose initial speed trades against all coefficients: 0.5 m/s made the Cx sd
        ~10x too large on Gaussian-noise flights, measured) and of phi, theta, psi [rad]
        (default 0.01); the initial rates get their measurement sd. The initial state is
        the first measured sample.
    process_velocity_sd_mps, process_rate_sd_radps, process_angle_sd_rad : float
        Process-noise sd per sample interval on u, v, w (default 1e-3 m/s), p, q, r
        (default 1e-3 rad/s) and the angles (default 1e-5 rad).
    coefficient_random_walk_rel : float
        Random-walk sd of the coefficients per sample interval as a fraction of
        ``|prior|`` (default 0: constant coefficients).
    """

    input: Literal["hold", "midpoint", "events", "law"] = "hold"
    delay_s: float = 0.0
    substeps: int = 1
    measurement_noise: Literal["data", "paper"] = "data"
    measurement_sd_floor_rel: float = 1e-4
    initial_coefficient_sd_rel: float = 0.3
    initial_velocity_sd_mps: float = 0.05
    initial_angle_sd_rad: float = 0.01
    process_velocity_sd_mps: float = 1e-3
    process_rate_sd_radps: float = 1e-3
    process_angle_sd_rad: float = 1e-5
    coefficient_random_walk_rel: float = 0.0

    def __post_init__(self) -> None:
        if self.input not in INPUTS:
            raise ValueError(f"input must be one of {', '.join(INPUTS)}, got {self.input!r}")
        if not (math.isfinite(self.delay_s) and abs(self.delay_s) < 0.1):
            raise ValueError(f"delay_s must be seconds below 0.1 in magnitude, got {self.delay_s}")
        if self.substeps < 1:
            raise ValueError(f"substeps must be >= 1, got {self.substeps}")
        for name in ("measurement_sd_floor_rel", "initial_coefficient_sd_rel",
                     "initial_velocity_sd_mps", "initial_angle_sd_rad"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        for name in ("process_velocity_sd_mps", "process_rate_sd_radps",
                     "process_angle_sd_rad", "coefficient_random_walk_rel"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")

    def setup(self, flight: Flight) -> tuple[np.ndarray, ...]:
        """Return ``x0 (18,), P0, Q (18, 18), R (9, 9), zs (n, 9), meas_sd (9,)``."""
        zs = measurements(flight)
        meas_sd = measurement_sd(flight, zs, self.measurement_noise,
                                 self.measurement_sd_floor_rel)
        prior = flight.airframe.prior_vector()
        x0 = np.concatenate([flight.states()[0], prior])
        sd0 = np.concatenate([
            np.full(3, self.initial_velocity_sd_mps), meas_sd[6:9],
            np.full(3, self.initial_angle_sd_rad),
            self.initial_coefficient_sd_rel * np.abs(prior),
        ])
        sdq = np.concatenate([
            np.full(3, self.process_velocity_sd_mps), np.full(3, self.process_rate_sd_radps),
            np.full(3, self.process_angle_sd_rad),
            self.coefficient_random_walk_rel * np.abs(prior),
        ])
        return x0, np.diag(sd0**2), np.diag(sdq**2), np.diag(meas_sd**2), zs, meas_sd

    def result(self, flight: Flight, out: _kalman.FilterOutput, meas_sd: np.ndarray,
               n_evaluations: int) -> EstimationResult:
        """Turn a filter pass into an :class:`EstimationResult` (history axis 'time')."""
        t = flight.t
        history = {"axis": "time", "step": t, "theta": out.x[:, 9:], "theta_sd": out.sd[:, 9:]}
        info = {"measurement_sd": meas_sd, "state": out.x[:, :9], "state_sd": out.sd[:, :9]}
        if out.failed_at is not None:
            message = f"filter diverged at t = {t[out.failed_at]:.4f} s: {out.reason}"
            return aeroid.failed_result(self.name, message, history=history, info=info,
                                        n_iterations=int(out.failed_at))
        cov = out.P[9:, 9:].copy()
        # the fit check reads the innovations of the second half (after the coefficients'
        # initial uncertainty has been worked off)
        half = len(t) // 2
        info["fit_residuals"] = {name: out.innovation[half:, j]
                                 for j, name in enumerate(aeroid.model.OUTPUT_CHANNELS)}
        return EstimationResult(
            estimator=self.name, theta=out.x[-1, 9:], stderr=np.sqrt(np.diag(cov)),
            covariance=cov, cost=math.nan, success=True, message="",
            n_evaluations=n_evaluations, n_iterations=len(t), history=history, info=info,
        )
