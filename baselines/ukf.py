"""Augmented-state unscented Kalman filter baseline (same model and measurements as the EKF).

Runs on :class:`filterpy.kalman.UnscentedKalmanFilter` with
:class:`filterpy.kalman.MerweScaledSigmaPoints`. filterpy propagates sigma points one by
one (``compute_process_sigmas`` loops over them with ``fx``); here that method is
overridden so all 37 sigma points (45 with four uncertain position components) go
through ONE batched call of :func:`aeroid.model.propagate` (numba's serial kernel), and
the measurements of all sigma points are computed in one call of
:func:`aeroid.model.accelerometers` and handed to filterpy's ``update`` in its iteration
order; the sigma points and the cross-covariance are array operations instead of
filterpy's loops (see :mod:`baselines._kalman`).
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
    _kalman_wind,
)
from baselines._imu_states import ImuFilterOptions
from baselines._kalman_tables import refuse_windows, run_table_passes
from baselines._kalman_ukf_smoother import run_ipls
from baselines._tables_fit import flight_tables
from baselines._wind_auto import is_auto, run_auto


@dataclass(frozen=True, kw_only=True)
class UnscentedKalmanEstimator(ImuFilterOptions):
    """Augmented-state UKF (filterpy, Merwe scaled sigma points, batched propagation).

    Options are those of :class:`baselines._common.AugmentedFilterOptions` plus the
    sigma-point parameters below. Result and failure handling as for the EKF, and its
    IMU-error states (``imu_errors``, :class:`baselines._imu_states.ImuFilterOptions`)
    and its held and prior coefficients (as the EKF's).

    Attributes
    ----------
    alpha : float
        Spread of the sigma points (default 0.5: about ``0.5 sqrt(18) = 2.1`` standard
        deviations from the mean).
    beta : float
        Prior knowledge of the distribution (default 2, optimal for a Gaussian).
    kappa : float
        Secondary scaling of the sigma points (default 0).
    passes : {"auto", "carried", "smoothed"}
        ``"carried"``: each pass starts where the last ended (the constant states with
        ``PASS_INFLATION`` times their sd), its sigma points around its own running
        estimate. ``"smoothed"``: each pass after the first starts from the original
        prior with the transition and measurement replaced by their statistical linear
        regressions on the previous pass's RTS-smoothed posterior (the iterated
        posterior linearisation smoother, the EKF's smoothed passes' counterpart:
        :mod:`baselines._kalman_ukf_smoother`). ``"auto"`` (default): ``smoothed`` with
        ``estimate_wind`` and no gust states (said in a one-line notice), else
        ``carried`` (still air: unchanged).
    gust_stderr : {"auto", "filtered", "innovations", "one-step"}
        As the EKF's (:class:`baselines.ekf.ExtendedKalmanEstimator`): with gust states the
        standard errors from the innovations' information at the estimate (filter-error's
        EKF likelihood, :mod:`baselines._kalman_information`) where built, with
        ``one-step`` (the default, ``auto``, where built) also one Fisher-scoring step of
        that likelihood from the estimate, judged at the moved estimate; holds and priors
        tested by filter-error's likelihood ratio (:mod:`baselines._kalman_holds`).
    """

    supports_holds: ClassVar[bool] = True  # held states leave the filter: baselines._held
    name: ClassVar[str] = "ukf"
    supports_windows: ClassVar[bool] = True  # run_windows: baselines._kalman_windows
    fits_tables: ClassVar[bool] = True  # [tables]: the points as states, baselines._kalman_tables
    description: ClassVar[str] = (
        "augmented-state unscented Kalman filter (filterpy, batched sigma-point RK4)")

    alpha: float = 0.5
    beta: float = 2.0
    kappa: float = 0.0
    passes: Literal["auto", "carried", "smoothed"] = "auto"
    gust_stderr: Literal["auto", "filtered", "innovations", "one-step"] = "auto"

    def __post_init__(self) -> None:
        super().__post_init__()
        _kalman_information.check_gust_stderr(self)
        if not 0 < self.alpha <= 1:
            raise ValueError(f"alpha must be in (0, 1], got {self.alpha}")
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
        smoothed: list[Any] = []  # "smoothed": the first pass's prior, the last posterior

        def filter_pass(model: _kalman.DiscreteModel, setup: _common.FilterSetup
                        ) -> _kalman.FilterOutput:
            if self.passes_used() == "carried":
                return _kalman.run_ukf(model, setup.x0, setup.P0, setup.Q, setup.R, setup.zs,
                                       alpha=self.alpha, beta=self.beta, kappa=self.kappa,
                                       R_of=setup.R_of)
            if not smoothed:
                smoothed[:] = [setup.x0, setup.P0, None]
            x0, P0, nominal = smoothed
            out = run_ipls(model, x0, P0, setup.Q, setup.R, setup.zs, nominal,
                           R_of=setup.R_of, alpha=self.alpha, beta=self.beta, kappa=self.kappa)
            if out.smoothed is not None:
                smoothed[2] = (out.smoothed, out.smoothed_cov)
            return out

        def one_pass(model: _kalman.DiscreteModel, setup: _common.FilterSetup
                     ) -> _kalman.FilterOutput:
            return _held.held_pass(model, setup, holds, filter_pass)

        tables = flight_tables(flight)
        if tables is not None:  # [tables]: the points as states (baselines._kalman_tables)
            return run_table_passes(self, flight, tables, one_pass,
                                    lambda model: (2 * model.dim_x + 1) * flight.n_samples,
                                    holds)
        result = self.run_imu_passes(
            flight, one_pass, lambda model: (2 * model.dim_x + 1) * flight.n_samples)
        result = _kalman_information.with_gust_stderr(self, flight, result, holds)
        if self.passes == "auto" and self.passes_used() == "smoothed":
            notice = ("ukf: passes = smoothed (auto, with estimate_wind): each pass after the "
                      "first starts from the original prior, its sigma-point regressions on "
                      "the last one's smoothed posterior (the carried passes walk along the "
                      "wind)")
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
            return _kalman.run_ukf(model, setup.x0, setup.P0, setup.Q, setup.R, setup.zs,
                                   alpha=self.alpha, beta=self.beta, kappa=self.kappa,
                                   R_of=setup.R_of)

        return run_windows(self, windows, one_pass,
                           lambda model, n: (2 * model.dim_x + 1) * n, holds)
