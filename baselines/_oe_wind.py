"""Output-error's steady wind: its option, parameters' names and scales, report (issue 26).

With ``estimate_wind`` the three components of a steady wind (north, east, down [m/s],
the air's velocity over the ground) are parameters of the output-error model after the
free positions (:func:`aeroid.model.symbolic_record` with ``wind_free``): the loads see
the air-relative velocity, and the sensitivities to the wind are exact (CasADi AD
through the same record). They start at zero (still air), have no prior, and are scaled
by :data:`WIND_SCALE_MPS`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

#: Names of the wind parameters in ``info['parameter_names']``.
WIND_NAMES = ("wind_n", "wind_e", "wind_d")
#: Scale of each wind parameter [m/s]: Gauss-Newton works on ``wind / scale``, order one
#: for the few m/s of a steady wind.
WIND_SCALE_MPS = 1.0


@dataclass(frozen=True, kw_only=True)
class WindOption:
    """Output-error's wind option (a base of :class:`baselines.output_error.
    OutputErrorEstimator`: ``aeroid methods --options output-error`` lists it).

    Attributes
    ----------
    estimate_wind : bool
        Also estimate a steady wind (north, east, down [m/s]; default False: still air),
        reported in ``info['wind_ned_mps']`` and ``info['wind_stderr_mps']`` with a
        one-line notice (:mod:`baselines._oe_wind`).
    """

    estimate_wind: bool = False


def wind_names(est: Any) -> list[str]:
    """Return the names of the wind parameters ``est`` estimates (none without the option)."""
    return list(WIND_NAMES) if est.estimate_wind else []


def wind_scales(est: Any) -> list[float]:
    """Return the scales of the wind parameters ``est`` estimates [m/s]."""
    return [WIND_SCALE_MPS] * len(wind_names(est))


def wind_report(est: Any, position_free: tuple[int, ...], phys: np.ndarray,
                stderr: np.ndarray, info: dict[str, Any]) -> list[str]:
    """Put the estimated wind in ``info`` and return the fit's one-line notice (or nothing).

    ``info['wind_ned_mps']`` and ``info['wind_stderr_mps']`` (north, east, down).
    """
    if not est.estimate_wind:
        return []
    first = est.parameter_names(position_free).index(WIND_NAMES[0])
    wind = phys[first:first + len(WIND_NAMES)]
    sd = stderr[first:first + len(WIND_NAMES)]
    shown = ", ".join(f"{axis} {w:+.2f} +- {s:.2f}" for axis, w, s
                      in zip(("north", "east", "down"), wind, sd, strict=True))
    info.update(wind_ned_mps=wind.tolist(), wind_stderr_mps=sd.tolist())
    return [f"estimate_wind: a steady wind was estimated with the coefficients (the loads "
            f"see the air-relative velocity): {shown} m/s"]
