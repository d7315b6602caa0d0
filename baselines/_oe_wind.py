"""Output-error's steady wind: its parameters' names, scales and report (issue 26).

With ``estimate_wind`` the three components of a steady wind (north, east, down [m/s],
the air's velocity over the ground) are parameters of the output-error model after the
free positions (:func:`aeroid.model.symbolic_record` with ``wind_free``): the loads see
the air-relative velocity, and the sensitivities to the wind are exact (CasADi AD
through the same record). They start at zero (still air), have no prior, and are scaled
by :data:`WIND_SCALE_MPS`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: Names of the wind parameters in ``info['parameter_names']``.
WIND_NAMES = ("wind_n", "wind_e", "wind_d")
#: Scale of each wind parameter [m/s]: Gauss-Newton works on ``wind / scale``, order one
#: for the few m/s of a steady wind.
WIND_SCALE_MPS = 1.0


def wind_scales() -> np.ndarray:
    """Return the scales of the wind parameters, shape (3,) [m/s]."""
    return np.full(len(WIND_NAMES), WIND_SCALE_MPS)


def wind_report(names: tuple[str, ...], phys: np.ndarray, stderr: np.ndarray,
                info: dict[str, Any]) -> str:
    """Put the estimated wind in ``info`` and return the fit's one-line notice.

    ``info['wind_ned_mps']`` and ``info['wind_stderr_mps']`` (north, east, down).
    """
    first = names.index(WIND_NAMES[0])
    wind = phys[first:first + len(WIND_NAMES)]
    sd = stderr[first:first + len(WIND_NAMES)]
    shown = ", ".join(f"{axis} {w:+.2f} +- {s:.2f}" for axis, w, s
                      in zip(("north", "east", "down"), wind, sd, strict=True))
    notice = (f"estimate_wind: a steady wind was estimated with the coefficients "
              f"(the loads see the air-relative velocity): {shown} m/s")
    info.update(wind_ned_mps=wind.tolist(), wind_stderr_mps=sd.tolist())
    return notice
