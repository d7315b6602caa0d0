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

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from aeroid.estimation import EstimationResult
from aeroid.flights import Flight, Windows
from baselines import _common, _held, _kalman, _kalman_gust, _kalman_wind
from baselines._imu_states import ImuFilterOptions


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
    """

    supports_holds: ClassVar[bool] = True  # held states leave the filter: baselines._held
    name: ClassVar[str] = "ekf"
    supports_windows: ClassVar[bool] = True  # run_windows: baselines._kalman_windows
    description: ClassVar[str] = (
        "augmented-state extended Kalman filter (filterpy, RK4 model, CasADi Jacobians)")

    def run(self, flight: Flight, rng: np.random.Generator, holds: Any = None
            ) -> EstimationResult:
        """Filter the flight forward in ``max_passes`` passes at most (no random draws:
        ``rng`` is unused; ``holds``: :func:`baselines._held.held_pass`)."""

        def filter_pass(model: _kalman.DiscreteModel, setup: _common.FilterSetup
                        ) -> _kalman.FilterOutput:
            return _kalman.run_ekf(model, setup.x0, setup.P0, setup.Q, setup.R, setup.zs,
                                   R_of=setup.R_of)

        def one_pass(model: _kalman.DiscreteModel, setup: _common.FilterSetup
                     ) -> _kalman.FilterOutput:
            return _held.held_pass(model, setup, holds, filter_pass)

        return self.run_imu_passes(flight, one_pass, lambda _model: flight.n_samples)

    def run_windows(self, windows: Windows, rng: np.random.Generator) -> EstimationResult:
        """Filter the windows in turn, carrying the coefficients (:mod:`baselines.
        _kalman_windows`; no random draws)."""
        from baselines._kalman_windows import run_windows

        _kalman_wind.refuse_with(self, "several windows")
        _kalman_gust.refuse_with(self, "several windows")
        def one_pass(model: _kalman.DiscreteModel, setup: _common.FilterSetup
                     ) -> _kalman.FilterOutput:
            return _kalman.run_ekf(model, setup.x0, setup.P0, setup.Q, setup.R, setup.zs,
                                   R_of=setup.R_of)

        return run_windows(self, windows, one_pass, lambda _model, n: n)
