"""Output-error's steady wind: its option, parameters' names and scales, report (issue 26).

With ``estimate_wind`` the three components of a steady wind (north, east, down [m/s],
the air's velocity over the ground) are parameters of the output-error model after the
free positions (:func:`aeroid.model.symbolic_record` with ``wind_free``): the loads see
the air-relative velocity, and the sensitivities to the wind are exact (CasADi AD
through the same record). They start at zero (still air), have no prior, and are scaled
by :data:`WIND_SCALE_MPS`. The default ``"auto"`` estimates it unless the log says still
air (:mod:`baselines._wind_auto`; :func:`blocked` names what the method cannot combine
with a wind: still air is assumed there, said in one line).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from aeroid.flights import Flight, Windows
from baselines._wind_auto import choose, is_auto

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
    estimate_wind : bool or "auto"
        Also estimate a steady wind (north, east, down [m/s]); default ``"auto"``: unless
        the log says still air (its metadata declares it, as the simulators' flights do,
        or its alpha, beta and airspeed say so: :func:`aeroid.estimation.log_air`), said
        in one line with why (``info['estimate_wind']``). Where output-error cannot
        estimate a wind (coefficient tables, aiding, ``attitude_prior = flight``) ``auto``
        assumes still air there, said in one line; ``false``: still air. Reported in
        ``info['wind_ned_mps']`` and ``info['wind_stderr_mps']`` with a one-line notice
        (:mod:`baselines._oe_wind`).
    """

    estimate_wind: bool | Literal["auto"] = "auto"


def wind_names(est: Any) -> list[str]:
    """Return the names of the wind parameters ``est`` estimates (none without the option)."""
    return list(WIND_NAMES) if est.estimate_wind is True else []  # "auto": resolved in run


def wind_scales(est: Any, data: Flight | Windows | None = None) -> list[float]:
    """Return the scales of the wind parameters ``est`` estimates [m/s] (on ``data``:
    ``auto`` resolved there, :func:`wind_free`)."""
    free = est.estimate_wind is True if data is None else wind_free(est, data)
    return [WIND_SCALE_MPS] * (len(WIND_NAMES) if free else 0)


def resolved(est: Any, data: Flight | Windows) -> Any:
    """``est`` with ``estimate_wind = auto`` resolved on ``data`` as its fit resolves it
    (:func:`baselines._wind_auto.choose`; the fit says it in one line, this does not):
    for a problem built outside a fit (``est.problem(flight)``)."""
    if not is_auto(est):
        return est
    return dataclasses.replace(est, estimate_wind=choose(est.name, data,
                                                         blocked(est, data)).used)


def wind_free(est: Any, data: Flight | Windows) -> bool:
    """Whether ``est``'s fit of ``data`` estimates the wind (``auto`` resolved there)."""
    return resolved(est, data).estimate_wind is True


def wind_report(est: Any, position_free: tuple[int, ...], phys: np.ndarray,
                stderr: np.ndarray, info: dict[str, Any]) -> list[str]:
    """Put the estimated wind in ``info`` and return the fit's one-line notice (or nothing).

    ``info['wind_ned_mps']`` and ``info['wind_stderr_mps']`` (north, east, down).
    """
    if est.estimate_wind is not True:
        return []
    first = est.parameter_names(position_free).index(WIND_NAMES[0])
    wind = phys[first:first + len(WIND_NAMES)]
    sd = stderr[first:first + len(WIND_NAMES)]
    shown = ", ".join(f"{axis} {w:+.2f} +- {s:.2f}" for axis, w, s
                      in zip(("north", "east", "down"), wind, sd, strict=True))
    info.update(wind_ned_mps=wind.tolist(), wind_stderr_mps=sd.tolist())
    return [f"estimate_wind: a steady wind was estimated with the coefficients (the loads "
            f"see the air-relative velocity): {shown} m/s"]


def blocked(est: Any, data: Flight | Windows) -> str:
    """Why output-error cannot estimate a wind with ``est``'s options on ``data`` ("" when
    it can): the combinations it refuses with ``estimate_wind = true``."""
    if getattr(data.airframe, "tables", None) is not None:
        return ("output-error does not estimate a wind with coefficient tables ([tables]: "
                "Mach needs the airspeed)")
    if getattr(est, "aiding", "none") != "none":
        return (f"output-error does not estimate a wind with aiding = {est.aiding} (the "
                "aiding outputs integrate the coefficients in still air)")
    if getattr(est, "attitude_prior", "none") == "flight":
        return ("output-error does not estimate a wind with attitude_prior = flight (the "
                "heading then matters and is not freed)")
    return ""
