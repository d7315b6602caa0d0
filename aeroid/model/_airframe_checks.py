"""An airframe's checks of its atmosphere and of its values' physical ranges.

Called by :class:`aeroid.model.Airframe` when it is made; ``self`` is the airframe.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from aeroid.errors import AeroidWarning, AirframeError
from aeroid.model._airframe_form import (
    ATMOSPHERE_CHANNELS,
    ATMOSPHERE_KEYS,
    DELTA_MAX_WARN_DEG,
    LIMITS,
    MIN_SENSOR_SEPARATION_M,
)
from aeroid.model._fileform import is_number


def check_atmosphere(self: Any) -> None:
    """Raise AirframeError (one line) unless exactly one valid atmosphere is stated."""
    stated = [k for k, a in ATMOSPHERE_KEYS.items() if getattr(self, a) is not None]
    if len(stated) != 1:
        raise AirframeError(
            "airframe: state the atmosphere with exactly one of altitude_m, density_kgm3 "
            f"or per_sample (got {', '.join(stated) or 'none'})")
    for key in ("altitude_m", "density_kgm3"):
        value = getattr(self, ATMOSPHERE_KEYS[key])
        if value is None:
            continue
        if not (is_number(value) and math.isfinite(value)):
            raise AirframeError(f"airframe: {key} must be a finite number, got {value!r}")
        low, high = LIMITS[key]
        if not low <= value <= high:
            raise AirframeError(f"airframe: {key} {value:g} is outside {low:g}..{high:g}"
                                + (" (give density_kgm3 above 20 km)"
                                   if key == "altitude_m" else ""))
        object.__setattr__(self, ATMOSPHERE_KEYS[key], float(value))
    channel = self.atmosphere_channel
    if channel is not None and channel not in ATMOSPHERE_CHANNELS:
        raise AirframeError(f"airframe: per_sample must be one of "
                            f"{', '.join(map(repr, ATMOSPHERE_CHANNELS))}, got {channel!r}")

def check_ranges(self: Any) -> None:
    """Raise AirframeError (one line) for a value outside its physical range (:data:`LIMITS`)."""
    for name in ("diameter_m", "length_m"):
        value = getattr(self, name)
        low, high = LIMITS[name]
        if value is not None and not low <= value <= high:
            raise AirframeError(f"airframe: {name} {value:g} is outside {low:g}..{high:g} "
                                "(metres?)")
    if self.thrust_n < 0:
        raise AirframeError(f"airframe: thrust_n must be >= 0 (thrust acts along body +x; "
                            f"a coasting airframe has 0), got {self.thrust_n:g}")
    low, high = LIMITS["delta_max_deg"]
    if self.delta_max_deg is None:
        pass  # a passive fin (_check_fin)
    elif not low < self.delta_max_deg <= high:
        raise AirframeError(f"airframe: delta_max_deg must be in ({low:g}, {high:g}] deg, "
                            f"got {self.delta_max_deg:g}")
    if self.delta_max_deg is not None and self.delta_max_deg < DELTA_MAX_WARN_DEG:
        warnings.warn(f"airframe: delta_max_deg {self.delta_max_deg:g} deg is very small "
                      f"(radians? {self.delta_max_deg:g} rad = "
                      f"{math.degrees(self.delta_max_deg):.3g} deg)",
                      AeroidWarning, stacklevel=4)
    gap = float(np.linalg.norm(np.subtract(self.accel1_position_m, self.accel2_position_m)))
    if gap < MIN_SENSOR_SEPARATION_M:
        raise AirframeError(
            f"airframe: accelerometer triads {gap:.3g} m apart (need at least "
            f"{MIN_SENSOR_SEPARATION_M:g} m: at one point the angular acceleration of "
            f"eq. 29 is rank-deficient)")
    if self.length_m is not None:
        for name in ("accel1_position_m", "accel2_position_m"):
            if float(np.linalg.norm(getattr(self, name))) > self.length_m:
                raise AirframeError(f"airframe: {name} {list(getattr(self, name))} is "
                                    f"farther from the c.g. than length_m {self.length_m:g}")


__all__ = ["check_atmosphere", "check_ranges"]
