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

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from aeroid.estimation import EstimationResult
from aeroid.flights import Flight, Windows
from baselines import _common, _held, _kalman, _kalman_gust, _kalman_wind
from baselines._imu_states import ImuFilterOptions
from baselines._kalman_tables import refuse_windows, run_table_passes
from baselines._tables_fit import flight_tables


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

    def __post_init__(self) -> None:
        super().__post_init__()
        if not 0 < self.alpha <= 1:
            raise ValueError(f"alpha must be in (0, 1], got {self.alpha}")

    def run(self, flight: Flight, rng: np.random.Generator, holds: Any = None
            ) -> EstimationResult:
        """Filter the flight forward in ``max_passes`` passes at most (no random draws:
        ``rng`` is unused; ``holds``: :func:`baselines._held.held_pass`)."""

        def filter_pass(model: _kalman.DiscreteModel, setup: _common.FilterSetup
                        ) -> _kalman.FilterOutput:
            return _kalman.run_ukf(model, setup.x0, setup.P0, setup.Q, setup.R, setup.zs,
                                   alpha=self.alpha, beta=self.beta, kappa=self.kappa,
                                   R_of=setup.R_of)

        def one_pass(model: _kalman.DiscreteModel, setup: _common.FilterSetup
                     ) -> _kalman.FilterOutput:
            return _held.held_pass(model, setup, holds, filter_pass)

        tables = flight_tables(flight)
        if tables is not None:  # [tables]: the points as states (baselines._kalman_tables)
            return run_table_passes(self, flight, tables, one_pass,
                                    lambda model: (2 * model.dim_x + 1) * flight.n_samples,
                                    holds)
        return self.run_imu_passes(
            flight, one_pass, lambda model: (2 * model.dim_x + 1) * flight.n_samples)

    def run_windows(self, windows: Windows, rng: np.random.Generator, holds: Any = None
                    ) -> EstimationResult:
        """Filter the windows in turn, carrying the coefficients (:mod:`baselines.
        _kalman_windows`; no random draws)."""
        from baselines._kalman_windows import run_windows

        refuse_windows(self, windows)  # [tables]: not built for the filters
        _kalman_wind.refuse_with(self, "several windows")
        _kalman_gust.refuse_with(self, "several windows")
        def one_pass(model: _kalman.DiscreteModel, setup: _common.FilterSetup
                     ) -> _kalman.FilterOutput:
            return _kalman.run_ukf(model, setup.x0, setup.P0, setup.Q, setup.R, setup.zs,
                                   alpha=self.alpha, beta=self.beta, kappa=self.kappa,
                                   R_of=setup.R_of)

        return run_windows(self, windows, one_pass,
                           lambda model, n: (2 * model.dim_x + 1) * n, holds)
