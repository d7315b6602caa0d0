"""Attitude helpers of the sensor suite: the body-to-NED rotation and wrapped angles."""

from __future__ import annotations

import math

import numpy as np


def body_to_ned(phi: np.ndarray, theta: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """Return the rotation matrices ``C_nb`` (..., 3, 3) of 3-2-1 Euler angles [rad]."""
    sf, cf, st, ct, ss, cs = (np.sin(phi), np.cos(phi), np.sin(theta), np.cos(theta),
                              np.sin(psi), np.cos(psi))
    return np.stack([
        np.stack([ct * cs, sf * st * cs - cf * ss, cf * st * cs + sf * ss], -1),
        np.stack([ct * ss, sf * st * ss + cf * cs, cf * st * ss - sf * cs], -1),
        np.stack([-st, sf * ct, cf * ct], -1)], -2)


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Return ``angle`` [rad] wrapped to (-pi, pi]."""
    return math.pi - np.mod(math.pi - np.asarray(angle, dtype=float), 2.0 * math.pi)


__all__ = ["body_to_ned", "wrap_angle"]
