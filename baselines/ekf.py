"""Augmented-state extended Kalman filter baseline (paper section 4.3 measurements).

The filter state is ``[u, v, w, p, q, r, phi, theta, psi, Cx, ..., Cmq]`` (18); the
measurements are both accelerometer triads (eq. 28 at the estimator's sensor positions)
and the body rates, ``[ax1, ay1, az1, ax2, ay2, az2, p, q, r]``.

It runs on :class:`filterpy.kalman.ExtendedKalmanFilter`, whose ``predict`` is linear
(``x = F x``): the state prediction is replaced by the nonlinear RK4 step of the
airframe model (``predict_x`` overridden; ``F`` set to the exact Jacobian of that step
before each ``predict``), see :mod:`baselines._kalman`. Both Jacobians are exact:
CasADi algorithmic differentiation of the RK4 step and of the measurement function,
written once in :mod:`aeroid.model` from the same equations as :mod:`aeroid.model`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np

from aeroid.errors import EstimatorError
from aeroid.estimation import EstimationResult
from aeroid.flights import Flight, Windows
from baselines import (
    _common,
    _held,
    _kalman,
    _kalman_air,
    _kalman_gust,
    _kalman_information,
    _kalman_smoother,
    _kalman_wind,
)
from baselines._imu_states import ImuFilterOptions
from baselines._kalman_tables import refuse_windows, run_table_passes
from baselines._tables_fit import flight_tables
from baselines._wind_auto import is_auto, run_auto


@dataclass(frozen=True, kw_only=True)
class ExtendedKalmanEstimator(ImuFilterOptions):
    """Augmented-state EKF (filterpy) with an RK4 prediction and exact CasADi Jacobians.

    Starts from the airframe's prior coefficients and the first measured sample; the
    options and their defaults are those of
    :class:`baselines._common.AugmentedFilterOptions`. The result is the filtered
    estimate at the last sample, the 9x9 coefficient block of the final covariance and
    its square-root diagonal as ``stderr``; ``history`` (axis ``"time"``) holds the
    coefficient estimates and sds at every sample. A covariance that stops being
    positive definite gives ``success=False`` with the time at which it happened. With
    ``imu_errors`` the IMU's biases (and scale factors) are states too
    (:class:`baselines._imu_states.ImuFilterOptions`). Held coefficients (``fit(...,
    holds=...)``) leave the state; a coefficient with a prior starts at its mean with its
    sd, a free one at the airframe's ``[prior]`` with ``initial_coefficient_sd_rel`` (0.3)
    of it as sd (:func:`baselines._held.held_pass`).

    Attributes
    ----------
    passes : {"auto", "carried", "smoothed"}
        ``"carried"``: each pass starts where the last ended (the constant states with
        ``PASS_INFLATION`` times their sd) and linearises at its own running estimate.
        ``"smoothed"``: each pass after the first starts from the original prior and
        linearises along the previous pass's RTS-smoothed trajectory (the iterated
        extended Kalman smoother, Gauss-Newton on the record's MAP:
        :mod:`baselines._kalman_smoother`); measured: the carried passes walk along the
        along-path wind's ridge, the smoothed ones settle in 3 passes at output-error's
        estimate (``benchmarks/results/wind_filters.md``); with gust states (process
        noise) it is the joint MAP of the gust path and the coefficients, which was
        measured worse in turbulence (55 % against 14-48 %, 2 seeds). ``"auto"``
        (default): ``smoothed`` with ``estimate_wind`` and no gust states (said in a
        one-line notice), else ``carried`` (still air: unchanged).
    gust_stderr : {"auto", "filtered", "innovations", "one-step"}
        With gust states, where the standard errors come from
        (:mod:`baselines._kalman_information`): ``innovations``, the inverse of the
        innovations' information (filter-error's likelihood) at the estimate;
        ``one-step``, the same with the estimate moved by one Fisher-scoring step of that
        likelihood (Le Cam's one-step estimator: calibrated intervals in turbulence,
        measured), its fit check and verdicts at the moved estimate
        (:mod:`baselines._kalman_onestep`); ``filtered``, the final filtered covariance
        (too small in turbulence, measured). ``auto`` (default): ``one-step`` where built
        (gust states without ``estimate_wind``, IMU-error, aiding, air-data or
        sensor-position states; chosen by measurement: coverage and cost side by side,
        README), else ``filtered``; intervals known to undercover in turbulence are said
        so in one line and in ``info['intervals']['calibrated']``. Holds and priors are
        tested by filter-error's likelihood ratio where built
        (:mod:`baselines._kalman_holds`). Without gust states: unused.
    """

    supports_holds: ClassVar[bool] = True  # held states leave the filter: baselines._held
    name: ClassVar[str] = "ekf"
    supports_windows: ClassVar[bool] = True  # run_windows: baselines._kalman_windows
    fits_tables: ClassVar[bool] = True  # [tables]: the points as states, baselines._kalman_tables
    description: ClassVar[str] = (
        "augmented-state extended Kalman filter (filterpy, RK4 model, CasADi Jacobians)")

    passes: Literal["auto", "carried", "smoothed"] = "auto"
    gust_stderr: Literal["auto", "filtered", "innovations", "one-step"] = "auto"

    def __post_init__(self) -> None:
        super().__post_init__()
        _kalman_information.check_gust_stderr(self)
        if self.passes not in ("auto", "carried", "smoothed"):
            raise ValueError(f"passes must be auto, carried or smoothed, got {self.passes!r}")

    def passes_used(self) -> str:
        """``passes`` with ``auto`` resolved: smoothed with a steady wind, no gusts."""
        if self.passes != "auto":
            return self.passes
        return "smoothed" if self.estimate_wind and not self.gusts else "carried"

    def run(self, flight: Flight, rng: np.random.Generator, holds: Any = None
            ) -> EstimationResult:
        """Filter the flight forward in ``max_passes`` passes at most (no random draws:
        ``rng`` is unused; ``holds``: :func:`baselines._held.held_pass`)."""
        if is_auto(self):  # estimate_wind = auto resolved on the log, said
            return run_auto(self, flight, _kalman_wind.blocked(self, flight),
                            lambda est: est.run(flight, rng, holds))
        if self.passes_used() == "smoothed" and self.estimate_gust_sd:  # trials share no pass
            raise EstimatorError(f"{self.name}: passes = smoothed with estimate_gust_sd is not "
                                 "available; give gust_sd_mps or set passes = carried")
        _kalman_information.refuse(self, flight)
        smoothed: list[Any] = []  # "smoothed": the first pass's prior, the last trajectory

        def filter_pass(model: _kalman.DiscreteModel, setup: _common.FilterSetup
                        ) -> _kalman.FilterOutput:
            if self.passes_used() == "carried":
                return _kalman.run_ekf(model, setup.x0, setup.P0, setup.Q, setup.R,
                                       setup.zs, R_of=setup.R_of)
            if not smoothed:
                smoothed[:] = [setup.x0, setup.P0, None]
            x0, P0, nominal = smoothed
            out = _kalman_smoother.run_eks(model, x0, P0, setup.Q, setup.R, setup.zs,
                                           nominal=nominal, R_of=setup.R_of)
            if out.smoothed is not None:
                smoothed[2] = out.smoothed
            return out

        def one_pass(model: _kalman.DiscreteModel, setup: _common.FilterSetup
                     ) -> _kalman.FilterOutput:
            return _held.held_pass(model, setup, holds, filter_pass)

        tables = flight_tables(flight)
        if tables is not None:  # [tables]: the points as states (baselines._kalman_tables)
            return run_table_passes(self, flight, tables, one_pass,
                                    lambda _model: flight.n_samples, holds)
        result = self.run_imu_passes(flight, one_pass, lambda _model: flight.n_samples)
        result = _kalman_information.with_gust_stderr(self, flight, result, holds)
        if self.passes == "auto" and self.passes_used() == "smoothed":
            notice = ("ekf: passes = smoothed (auto, with estimate_wind): each pass "
                      "after the first linearises along the last one's smoothed trajectory "
                      "from the original prior (the carried passes walk along the wind)")
            result = dataclasses.replace(result, warnings=(*result.warnings, notice))
        return result

    def run_windows(self, windows: Windows, rng: np.random.Generator, holds: Any = None
                    ) -> EstimationResult:
        """Filter the windows in turn, carrying the coefficients (:mod:`baselines.
        _kalman_windows`; no random draws)."""
        from baselines._kalman_windows import run_windows

        if is_auto(self):  # estimate_wind = auto: not over several windows, said
            return run_auto(self, windows, _kalman_wind.blocked(self, windows),
                            lambda est: est.run_windows(windows, rng, holds))
        refuse_windows(self, windows)  # [tables]: not built for the filters
        _kalman_wind.refuse_with(self, "several windows")
        _kalman_gust.refuse_with(self, "several windows")
        _kalman_air.refuse_windows(self, windows)
        if self.passes == "smoothed":
            raise EstimatorError(f"{self.name}: passes = {self.passes} with several windows "
                                 "is not available; set passes = carried")
        def one_pass(model: _kalman.DiscreteModel, setup: _common.FilterSetup
                     ) -> _kalman.FilterOutput:
            return _kalman.run_ekf(model, setup.x0, setup.P0, setup.Q, setup.R, setup.zs,
                                   R_of=setup.R_of)

        return run_windows(self, windows, one_pass, lambda _model, n: n, holds)
