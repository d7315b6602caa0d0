"""Output-error's options checked when the estimator is made (one ValueError each)."""

from __future__ import annotations

import math
from typing import Any

from aeroid.flights import IMU_ERROR_KINDS, INPUTS
from baselines._gauss_newton import NOISE_MODELS
from baselines._oe_aiding import OE_AIDING
from baselines._oe_attitude import check_attitude_option
from baselines._oe_constants import MAX_DELAY_S
from baselines._oe_skew import check_skew_option


def check_options(self: Any) -> None:
    """Raise ValueError (one line) for the first option of ``self`` out of its range."""
    for name in ("substeps", "max_iterations", "n_starts", "pso_particles"):
        if getattr(self, name) < 1:
            raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
    if self.pso_iterations < 0:
        raise ValueError(f"pso_iterations must be >= 0, got {self.pso_iterations}")
    if not self.tol > 0:
        raise ValueError(f"tol must be > 0, got {self.tol}")
    if self.input not in INPUTS:
        raise ValueError(f"input must be one of {', '.join(INPUTS)}, got {self.input!r}")
    if self.imu_errors not in IMU_ERROR_KINDS:
        raise ValueError(f"imu_errors must be one of {', '.join(IMU_ERROR_KINDS)}, got "
                         f"{self.imu_errors!r}")
    if self.initial_velocity_prior not in ("none", "flight"):
        raise ValueError("initial_velocity_prior must be none or flight, got "
                         f"{self.initial_velocity_prior!r}")
    if self.initial_velocity_prior == "flight" and not self.estimate_initial_velocity:
        raise ValueError("initial_velocity_prior = flight needs "
                         "estimate_initial_velocity = true")
    if self.aiding not in OE_AIDING:
        raise ValueError(f"aiding must be one of {', '.join(OE_AIDING)}, got {self.aiding!r}")
    check_skew_option(self.aiding, self.estimate_skew)
    check_attitude_option(self)
    if self.noise_model not in NOISE_MODELS:
        raise ValueError(f"noise_model must be one of {', '.join(NOISE_MODELS)}, "
                         f"got {self.noise_model!r}")
    if not (math.isfinite(self.delay_s) and abs(self.delay_s) < MAX_DELAY_S):
        raise ValueError(f"delay_s must be a number of seconds below {MAX_DELAY_S:g} in "
                         f"magnitude, got {self.delay_s}")


__all__ = ["check_options"]
