"""Equation-error least-squares baseline: the closed-form answer of the EBM second step.

Two-step (default): EBM step 1 (:func:`aeroid.estimation.reconstruct`) gives the
forces and moments per sample, :func:`aeroid.estimation.ebm_regression` the regression
``FM = X theta``; every SEBM sub-problem is then linear least squares
(:func:`scipy.linalg.lstsq`): F_AX on Cx; F_AZ on Cza, Czd, Czq; M_X on Cl0, Clp; M_Y on
Cma, Cmd, Cmq. With ``lateral_rows`` the F_AY rows join the F_AZ problem and the M_Z rows
the M_Y problem through the symmetry ties of eq. 1 (rows weighted by the inverse noise
sd of their channel).

One-step (``one_step=True``): the six accelerations of eq. 28 and the SG derivatives of
the measured p, q, r are each affine in the coefficients once the measured states are
given (``a = c(x) + A(x) theta``; ``A`` and ``c`` are read off
:func:`aeroid.model.accelerometers` and :func:`aeroid.model.state_derivative` at the unit vectors),
so one weighted least-squares problem over all nine coefficients avoids inverting step
1. Channel weights are the inverse residual sds of a first unweighted-by-channel pass
(two passes); standard errors from the weighted normal matrix.

Roll coefficients, an information limit: both triads lie on the body x axis, so the
accelerometers cannot see the roll acceleration (eq. 29 has rank 5) and the roll moment,
with it Cl0 and Clp, comes from the differentiated p gyro alone (in both forms). No
method that takes the roll moment from the p gyro beats the gyro-only Cramér-Rao floor
(:func:`aeroid.estimation.gyro_only_floor`): on the reference flight 131 / 162 % of
Cl0 / Clp under the paper's noise (sd; 104 / 129 % as a mean |error|) and 0.44 / 0.55 %
with the Gaussian tactical IMU. Over 40 seeded flights the two-step method's mean
|error| is 96 / 117 % (paper noise: at the floor) and 0.92 / 1.14 % (Gaussian: 2.6x the
floor, the price of the 101-point derivative of p). ``info["gyro_only_floor"]`` holds
each fit's floor, linearised at its own estimates with the p noise from the data.

Smoothing default, by measurement (benchmarks/bench_equation_error.py, 40 seeded flights
of the reference scenario per noise model; mean |error| over the nine coefficients and
the coverage of the 95 % intervals)::

    noise                     form       both          forces        none
    paper (eq. 43, +-10 %)    two-step   61.9 %  0.76  49.0 %  0.72  46.7 %  0.75
    Gaussian tactical IMU     two-step   1.22 %  0.91  3.43 %  0.73  1.22 %  0.92
    none                      two-step   6e-4 %  1.00  2.30 %  0.78  6e-4 %  1.00
    Gaussian tactical IMU     one-step   2.00 %  0.95  4.10 %  0.73  1.81 %  0.96
    paper (eq. 43, +-10 %)    one-step   625 %   0.49  582 %   0.51  1060 %  0.48

``"none"`` (the default) equals ``"both"`` on a Gaussian IMU and on noise-free data and
is the best under the paper's noise, where smoothing raises the Cl0 / Clp error from
96 / 117 % to 156 / 192 %. ``"forces"`` (the paper's way) biases the fin coefficients
Czd, Cmd by ~7 % (targets smoothed, regressors not: the relay's steps are blurred in one
and sharp in the other). Only the one-step form under the paper's noise does better
smoothed, where every choice is thousands of percent off on Cl0 and Clp.

Standard errors: SG smoothing (option ``smoothing``), the SG rate derivatives and the
step-1 reconstruction colour the residuals, so ``sigma^2 (X^T X)^-1`` (option
``covariance="ols"``) gives intervals that are too narrow: over 50 Gaussian-noise
flights its nominal 95 % intervals covered the truth in 59 % of coefficient-runs
(two-step; 22 % for Cl0 and Clp) and 80 % (one-step). The default is therefore the
Newey-West (HAC) covariance with a Bartlett window of twice the residuals' measured
correlation length (tests/statistical/test_coverage.py gives the coverage), capped at
:data:`baselines.newey_west.MAX_CORRELATION_LENGTH` samples; it costs O(n L) in the
number of samples n and the bandwidth L (:mod:`baselines.newey_west`;
benchmarks/bench_newey_west.py).

Uncertain sensor positions (the airframe's ``accel1/2_position_sd_m``): the regression
takes the given positions as exact, and a position error is one draw per flight that no
residual-based covariance can see. By default (``positions="consider"``) the covariance
adds it: ``G diag(sd^2) G^T``, ``G`` the central difference of the estimate over +-1 sd
of each uncertain component (two more solves per component, without their covariance).
Measured under the paper's noise with its 10 % position error, two-step form: coverage
of the 95 % intervals 0.74 with the positions taken as known (Cx 0.05, Czd 0.55, Cmd
0.35; 20 flights), 0.944 considered (30 flights, prior off the truth:
``python -m pytest -m slow -s tests/statistical/test_coverage.py -k paper``). The
one-step form under that noise: 0.59 -> 0.78 (6 flights; its Cl0, Clp, Cmd are
thousands of % off there, see above).

Memory (two-step): the regressors are built a time block at a time
(:func:`aeroid.estimation.regressor_blocks`, :data:`BLOCK_SAMPLES`), their entries copied
into each sub-problem's own columns (9 numbers per sample, not the 54 of the ``n x 6 x 9``
array), and the fit check's residuals ``y - X theta`` are computed block by block too;
the numbers are those of the one-shot array to the bit (tests/unit/test_blocked_regression.py;
``python benchmarks/bench_memory.py --stages``: benchmarks/results/memory_stages.md).
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np

import aeroid
from aeroid import estimation as rc
from aeroid.estimation import EstimationResult, Estimator
from aeroid.flights import Flight
from baselines import _held, _tables_fit
from baselines._ee_air import refuse_unseen_gusts, with_wind_consider
from baselines._ee_least_squares import (  # the sub-problems' names are read from here
    LATERAL,
    SUBPROBLEMS,
    _correlation,
    _lstsq,
    moved_positions,
    one_step_target,
    solve_subproblems,
    with_position_consider,
)
from baselines._ee_roll import roll_window_blocks, with_roll_covariance

__all__ = ["COLLINEAR_R", "LATERAL", "SUBPROBLEMS", "EquationErrorEstimator",
           "affine_accelerations", "roll_floor", "solve_subproblems"]

#: Regressor pairs with |correlation| above this are reported as collinear (Cl0/Clp on
#: the reference flight: 0.9998).
COLLINEAR_R = 0.99
#: Time samples per block of the two-step regressors
#: (:data:`aeroid.estimation.REGRESSION_BLOCK`): the ``n x 6 x 9`` array is never held,
#: only each sub-problem's own columns (benchmarks/results/memory_stages.md).
BLOCK_SAMPLES = rc.REGRESSION_BLOCK


def affine_accelerations(flight: Flight, states: np.ndarray | None = None,
                         wind: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Return ``c (n, 9)`` and ``A (n, 9, 9)`` with ``[a1, a2, pdot, qdot, rdot] = c + A theta``.

    From :func:`aeroid.model.accelerometers` and :func:`aeroid.model.state_derivative` evaluated at
    ``theta = 0`` and at the nine unit vectors (both are affine in the coefficients).
    ``wind`` (n, 3) [m/s] NED per sample replaces the constants' wind
    (:func:`aeroid.estimation.air_data_wind`).
    """
    const = aeroid.flights.sample_constants(flight)
    if wind is not None:
        const = const._replace(wind_n=wind[:, 0], wind_e=wind[:, 1], wind_d=wind[:, 2])
    const = aeroid.model.Constants(*(np.asarray(v, dtype=float)[:, None] if np.ndim(v) else v
                                     for v in const))
    states = flight.states() if states is None else states
    delta = flight["delta"]
    n_c = aeroid.model.N_COEFFICIENTS
    basis = np.vstack([np.zeros(n_c), np.eye(n_c)])  # (1 + n_c, n_c)
    acc = aeroid.model.accelerometers(states[:, None, :], delta[:, None], basis[None], const,
                                      flight.airframe.accel_positions
                                      ).reshape(len(states), 1 + n_c, -1)
    wdot = aeroid.model.state_derivative(states[:, None, :], delta[:, None], basis[None],
                                         const)[..., aeroid.model.P:aeroid.model.R + 1]
    out = np.concatenate([acc, wdot], axis=2)  # (n, 1 + n_c, 9)
    c = out[:, 0, :]
    A = np.swapaxes(out[:, 1:, :] - c[:, None, :], 1, 2)  # (n, 9 outputs, n_c coefs)
    return c, A


def roll_floor(flight: Flight, theta: np.ndarray) -> dict[str, float]:
    """Return the gyro-only floor of Cl0, Clp at ``theta`` with the data's p noise.

    ``{"Cl0": sd, "Clp": sd, "p_noise_sd": sd of p [rad/s]}``
    (:func:`aeroid.estimation.gyro_only_floor`).
    """
    p_sd = float(rc.estimate_noise_sd(flight["p"], use=rc.switch_free_samples(flight["delta"])))
    floor = rc.gyro_only_floor(flight, theta, noise_sd=p_sd)
    out = {name: float(v) for name, v in zip(rc.GYRO_FLOOR_NAMES, floor, strict=True)}
    out["p_noise_sd"] = p_sd
    return out


@dataclass(frozen=True, kw_only=True)
class EquationErrorEstimator(_tables_fit.FitsTables, Estimator):
    """Closed-form equation-error least squares (EBM step 2 or one step on the sensors).

    Attributes
    ----------
    one_step : bool
        Regress the accelerations and rate derivatives directly (default False: the
        two-step EBM regression).
    smoothing : {"both", "forces", "none"}
        As in EBM (:func:`aeroid.estimation.ebm_regression`; default "none", chosen by
        measurement: module docstring). In the one-step form "forces" smooths the
        targets only and "both" also the regressors.
    lateral_rows : bool
        Add the F_AY and M_Z rows with the symmetry ties (default False, the paper's
        four sub-problems).
    covariance : {"hac", "ols"}
        Standard errors: "hac" (default) the Newey-West covariance (the roll pair's from
        its noise's known structure, :mod:`baselines._ee_roll`), as step 1 and the SG
        derivatives correlate the residuals over ~100 samples; "ols" ``sigma^2 (X^T
        X)^-1``, which assumes white residuals: 95 % intervals held the truth in 59 % of
        coefficient-runs (two-step), 80 % (one-step; tests/statistical/test_coverage.py).
    positions : {"consider", "known"}
        Accelerometer-position components the airframe calls uncertain (sd > 0): their
        effect on the estimate is added to the covariance (default ``consider``; module
        docstring; ``info["position_sensitivity"]`` holds ``G``), or they are taken as
        known. The estimate is the same either way.
    air_data : {"auto", "inertial", "measured", "reconstruction"}
        Aerodynamic angles: the flight's logged alpha and beta where it has them
        (default ``auto``; said in one line; else the reconstruction's steady wind where
        the flight carries one), those from u, v, w (``inertial``), the logged ones or a
        refusal (``measured``), or the reconstruction's steady wind or a refusal
        (``reconstruction``); :mod:`aeroid.estimation._air_data`.
    air_data_window_s : float or None
        Smoothing of the wind the logged angles imply, in north-east-down axes: None
        (default) a Kalman smoother whose gust intensity the data choose by maximum
        likelihood (:mod:`aeroid.estimation._air_smoother`; measured against the fixed
        window in benchmarks/bench_air_data.py), or a Savitzky-Golay window of that many
        seconds (0.1 the former default, :mod:`aeroid.estimation._air_data`; 0: none).
        With the Kalman smoother the record-mean wind's uncertainty is a consider term of
        the covariance (:mod:`baselines._ee_air`).
    air_data_smoother : {"random-walk", "dryden"}
        The Kalman smoother's wind: a random walk in NED (default) or a steady wind plus
        Dryden gusts (:mod:`aeroid.estimation._air_dryden`; benchmarks/bench_air_data.py).
    along_path_wind_sd_mps : float or None
        Logged angles without an airspeed channel: the sd [m/s] of the unseen steady wind
        along the path that the covariance considers (default: the steady wind the air
        data measure across the path; said in a warning; :mod:`baselines._ee_air`).

    Notes
    -----
    ``info`` holds ``correlation`` (9, 9): the regressor correlation within each
    sub-problem (NaN across sub-problems; the full matrix in the one-step form),
    ``collinear`` (pairs of names with ``|r| > 0.99``), ``sigma2`` per sub-problem,
    ``subproblems`` and ``gyro_only_floor``: the Cramér-Rao floor of Cl0 and Clp from
    the p gyro alone (module docstring), name -> sd in coefficient units, and
    ``p_noise_sd`` [rad/s], linearised at the estimates; ``hac_bandwidth`` per
    sub-problem, the Newey-West bandwidth ``{"lags", "capped"}`` (a capped one is also a
    warning); with the Kalman-smoothed air data ``air_data_wind_intensity`` [(m/s)^2/s]
    and ``air_data_wind_consider`` (:mod:`baselines._ee_air`). ``cost`` is the total
    weighted residual sum of squares. Nothing is random:
    ``rng`` is unused.
    """

    name: ClassVar[str] = "equation-error"
    supports_windows: ClassVar[bool] = True  # run_windows: baselines._ee_windows
    supports_holds: ClassVar[bool] = True  # held to the left side, priors combined
    uses_air_data: ClassVar[bool] = True  # option air_data
    description: ClassVar[str] = (
        "equation-error least squares (closed-form EBM step 2 or one step on the sensors)")

    one_step: bool = False
    smoothing: Literal["both", "forces", "none"] = "none"
    lateral_rows: bool = False
    covariance: Literal["hac", "ols"] = "hac"
    positions: Literal["consider", "known"] = "consider"
    air_data: Literal["auto", "inertial", "measured", "reconstruction"] = "auto"
    air_data_window_s: float | None = None
    along_path_wind_sd_mps: float | None = None
    air_data_smoother: Literal["random-walk", "dryden"] = "random-walk"

    def __post_init__(self) -> None:
        if self.smoothing not in rc.SMOOTHING_CHOICES:
            raise ValueError(f"smoothing must be one of {', '.join(rc.SMOOTHING_CHOICES)}, "
                             f"got {self.smoothing!r}")
        if self.positions not in ("consider", "known"):
            raise ValueError(f"positions must be 'consider' or 'known', got {self.positions!r}")
        if self.air_data not in rc.AIR_DATA_CHOICES:
            raise ValueError(f"air_data must be one of {', '.join(rc.AIR_DATA_CHOICES)}, "
                             f"got {self.air_data!r}")
        if self.air_data_window_s is not None and not (
                np.isfinite(self.air_data_window_s) and self.air_data_window_s >= 0):
            raise ValueError(f"air_data_window_s must be >= 0 [s], got {self.air_data_window_s}")
        if self.along_path_wind_sd_mps is not None and not (
                np.isfinite(self.along_path_wind_sd_mps) and self.along_path_wind_sd_mps >= 0):
            raise ValueError("along_path_wind_sd_mps must be >= 0 [m/s], got "
                             f"{self.along_path_wind_sd_mps}")
        if self.air_data_smoother not in rc.SMOOTHER_MODELS:
            raise ValueError(f"air_data_smoother must be one of {', '.join(rc.SMOOTHER_MODELS)}"
                             f", got {self.air_data_smoother!r}")

    def run(self, flight: Flight, rng: np.random.Generator, holds: Any = None
            ) -> EstimationResult:
        """Solve the least-squares problems (deterministic; ``holds``: held terms moved to
        the left side, priors as pseudo-observations, :func:`baselines._held.ee_prior_rows`)."""
        air = rc.resolve_air_data(flight, self.air_data, self.name,
                                     self.air_data_window_s, self.air_data_smoother)
        tables = _tables_fit.flight_tables(flight)
        if tables is not None:  # the airframe's [tables]: baselines/_tables_fit.py
            if air.source != "inertial":
                raise aeroid.errors.EstimatorError(
                    f"{self.name}: logged air-data angles with [tables] are not built; "
                    "give air_data = 'inertial' to fit the angles from u, v, w")
            return _tables_fit.equation_error_tables(self, flight, tables, holds)
        logging.getLogger("aeroid").info(air.note)
        result = self._solve(flight, holds=holds, wind=air.wind)
        if holds is not None and holds.held:  # the data against the held values
            result = _held.ee_held_check(result, self._solve(flight, wind=air.wind), holds)
        result = dataclasses.replace(
            result, info={**result.info, "air_data": air.source, "air_data_note": air.note,
                          **({} if air.smoothed is None else {
                              "air_data_wind_intensity": air.smoothed.intensity})},
            warnings=tuple(result.warnings) + ((air.warning,) if air.warning else ()))
        if air.source == "measured":  # wind or turbulence: aeroid/estimation/_air_verdict.py
            result = refuse_unseen_gusts(rc.with_air_verdict(
                result, rc.air_data_verdict(flight, self.name)), flight, self.name)
        if self.along_path_wind_sd_mps is not None and (air.smoothed is None
                                                        or rc.has_airspeed(flight)):
            raise aeroid.errors.EstimatorError(
                f"{self.name}: along_path_wind_sd_mps is for logged angles without an "
                "airspeed channel, Kalman-smoothed (air_data_window_s = None); this fit "
                f"takes {air.source} air data" + (" with an airspeed channel"
                                                  if rc.has_airspeed(flight) else ""))
        result = with_wind_consider(  # the smoothed wind's uncertainty: baselines/_ee_air.py
            result, flight, air, lambda wind: self._solve(
                flight, theta_only=True, holds=holds, wind=wind).theta, self.name,
            self.along_path_wind_sd_mps)
        sd = flight.airframe.accel_position_sd.ravel()
        free = np.flatnonzero(sd)
        if self.positions == "known" or free.size == 0 or not result.success:
            return result
        return with_position_consider(
            result, flight.airframe.accel_positions.ravel(), sd,
            lambda pos: self._solve(
                dataclasses.replace(flight, airframe=moved_positions(flight.airframe, pos)),
                theta_only=True, holds=holds, wind=air.wind).theta)

    def run_windows(self, windows: aeroid.flights.Windows, rng: np.random.Generator,
                    holds: Any = None) -> EstimationResult:
        """Several windows: their regressions stacked (:mod:`baselines._ee_windows`)."""
        from baselines._ee_windows import run_windows

        if self.air_data != "inertial" and any(rc.has_air_data(w) or rc.reconstruction_wind(w)
                                               is not None for w in windows.flights):
            raise aeroid.errors.EstimatorError(
                f"{self.name}: logged air-data angles with several windows are not built; "
                "give air_data = 'inertial' to fit the angles from u, v, w")
        return run_windows(self, windows, rng, affine_accelerations=affine_accelerations,
                           roll_floor=roll_floor, holds=holds)

    def point(self, flight: Flight) -> np.ndarray:
        """Return the estimate alone, shape (N_COEFFICIENTS,): the positions as given, no
        covariance beyond plain least squares, no fit check, no floor (a start for another
        method; the same point as :meth:`run` with ``positions = "known"``)."""
        air = rc.resolve_air_data(flight, self.air_data, self.name,
                                     self.air_data_window_s, self.air_data_smoother)
        return self._solve(flight, theta_only=True, wind=air.wind).theta

    def _solve(self, flight: Flight, *, theta_only: bool = False,
               holds: Any = None, wind: np.ndarray | None = None) -> EstimationResult:
        """One solve at the airframe's positions (``theta_only``: the estimate alone, its
        covariance plain least squares and no gyro-only floor, for the sensitivities)."""
        covariance = "ols" if theta_only else self.covariance
        if self.one_step:
            return self._one_step(flight, covariance, theta_only, holds, wind)
        rec = rc.reconstruct(flight)
        y = rc.regression_target(rec, smoothing=self.smoothing)
        window = rec.smoothing_window

        blocks = roll_window_blocks(flight, wind, lambda: rc.regressor_blocks(  # _ee_roll.py
            flight, smoothing=self.smoothing, window=window, block=BLOCK_SAMPLES, wind=wind))

        theta, cov, corr, sigma2, cost, bandwidth = solve_subproblems(
            blocks(), y, rc.estimate_noise_sd(rec.fm), lateral_rows=self.lateral_rows,
            covariance=covariance, held=_held.held_dict(holds), holds=holds)
        cov = with_roll_covariance(flight, blocks, y, theta, cov, covariance, holds, self.smoothing)
        info = {"sigma2": sigma2, "subproblems": [s[0] for s in SUBPROBLEMS],
                "reconstruction_rank": rec.rank, "hac_bandwidth": bandwidth}
        rows = tuple(row for _, row, _ in SUBPROBLEMS)
        if self.lateral_rows:
            rows = tuple(sorted(rows + tuple(LATERAL.values())))
        if not theta_only:
            info.update(rc.regression_fit(rec, blocks(), y, theta, rows))
        del rec, y  # step 1's arrays (all but the loads in the fit check) before the floor
        return self._result(flight, theta, cov, corr, cost, info, floor=not theta_only)

    def _one_step(self, flight: Flight, covariance: str, theta_only: bool,
                  holds: Any = None, wind: np.ndarray | None = None) -> EstimationResult:
        c, A = affine_accelerations(flight, wind=wind)
        c, A, free = _held.ee_one_step(c, A, holds)  # held terms into c
        n = flight.n_samples
        meas, target, A = one_step_target(flight, c, A, self.smoothing)
        sd = rc.estimate_noise_sd(meas)
        theta = cov = None
        for _ in range(2):  # pass 1: a priori channel sds; pass 2: residual sds
            Aw = (A / sd[None, :, None]).reshape(-1, A.shape[-1])
            bw = (target / sd[None, :]).reshape(-1)
            theta, cov, s2, bandwidth = _lstsq(Aw, bw, n_time=n, covariance=covariance)
            resid = target - np.einsum("noc,c->no", A, theta)
            sd = np.sqrt(np.mean(resid * resid, axis=0))
            sd = np.maximum(sd, 1e-12 * np.sqrt(np.mean(meas * meas, axis=0)) + 1e-300)
        theta, cov = _held.ee_full(*_held.ee_prior_rows(Aw, bw, theta, cov, s2, free, holds),
                                   free, holds)
        corr = _held.ee_full_matrix(_correlation(Aw), free, np.nan)
        info = {"sigma2": {"one_step": s2}, "channel_sd": sd, "subproblems": ["one_step"],
                "hac_bandwidth": {"one_step": bandwidth}}
        names = aeroid.model.ACCEL_CHANNELS  # the rate-derivative rows are no flight channels
        info["fit_residuals"] = {name: resid[:, j] for j, name in enumerate(names)}
        return self._result(flight, theta, cov, corr, s2 * max(Aw.shape[0] - Aw.shape[1], 1),
                            info,
                            floor=not theta_only)

    def _result(self, flight: Flight, theta: np.ndarray, cov: np.ndarray, corr: np.ndarray,
                cost: float, info: dict, *, floor: bool = True) -> EstimationResult:
        names = aeroid.NAMES
        collinear = [(names[i], names[j], float(corr[i, j])) for i in range(len(names))
                     for j in range(i + 1, len(names))
                     if np.isfinite(corr[i, j]) and abs(corr[i, j]) > COLLINEAR_R]
        info.update(correlation=corr, collinear=collinear)
        if floor and np.all(np.isfinite(theta)):
            info["gyro_only_floor"] = roll_floor(flight, theta)
        capped = [label for label, bw in info["hac_bandwidth"].items() if bw["capped"]]
        warnings = tuple(
            f"residuals of {label} stay correlated beyond the Newey-West cap "
            f"({info['hac_bandwidth'][label]['lags'] // 2} samples; model misfit?): its "
            "standard errors are not reliable" for label in capped)
        return EstimationResult(
            estimator=self.name, theta=theta, stderr=np.sqrt(np.abs(np.diag(cov))),
            covariance=cov, cost=float(cost), success=True, message="", n_evaluations=1,
            n_iterations=1, info=info, warnings=warnings)
