"""A fitted drag against a reference curve (a design tool's Cd against Mach).

A user's curve (OpenRocket, RASAero, a wind tunnel) is a CSV of ``Mach`` and ``Cd``
columns with the curve's own reference area. aeroid's ``Cx`` is the body-axis axial
force coefficient on the airframe's reference area ``S = pi D^2 / 4``, negative for
drag, so at zero incidence (where the axial force is the drag)::

    Cd = -Cx * S_aeroid / S_ref

(:func:`cd_from_cx`; an interval's ends swap with the sign). :func:`conversion_note`
says it in one line; :func:`reference_curve_figure` draws the fitted values, with their
intervals, beside the curve: a constant Cx over the flight's Mach range (a band) or a
table of Cx against Mach (points with error bars) take the same ``(mach, value, lo,
hi)`` arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from aeroid.errors import UsageError
from aeroid.flights import Flight
from aeroid.model import GAMMA, R_AIR, isa_temperature

__all__ = ["ReferenceCurve", "cd_from_cx", "conversion_note", "flight_mach",
           "read_reference_curve", "reference_curve_figure"]

#: Column names of a reference curve file (matched without case and surrounding blanks).
CURVE_COLUMNS = ("mach", "cd")
#: Largest Mach a curve may reach: beyond it the file's first column is not a Mach number
#: (a speed in m/s?); sounding rockets fly below Mach 10.
MAX_MACH = 30.0


@dataclass(frozen=True)
class ReferenceCurve:
    """A reference drag curve.

    Attributes
    ----------
    mach : ndarray, shape (n,)
        Mach numbers [-], strictly increasing, >= 0.
    cd : ndarray, shape (n,)
        Drag coefficient on ``area_m2`` [-].
    area_m2 : float
        The curve's reference area [m^2], > 0.
    source : str
        Where it came from (the file), for messages and the legend.
    """

    mach: np.ndarray
    cd: np.ndarray
    area_m2: float
    source: str = "reference"


def read_reference_curve(path: str | Path, *, area_m2: float) -> ReferenceCurve:
    """Read a CSV with columns ``Mach`` and ``Cd`` (other columns are refused).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    area_m2 : float
        The curve's reference area [m^2] (stated: a design tool's differs from aeroid's
        when its reference diameter does).

    Raises
    ------
    UsageError
        One line naming the file and what is wrong (missing or extra column, a value
        that is not a finite number, Mach not increasing or negative, a bad area).
    """
    where = str(path)
    if not (isinstance(area_m2, int | float) and not isinstance(area_m2, bool)
            and math.isfinite(area_m2) and area_m2 > 0):
        raise UsageError(f"{where}: the reference area must be a positive number [m^2], "
                         f"got {area_m2!r}")
    try:
        frame = pd.read_csv(path)
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise UsageError(f"{where}: cannot read the reference curve: "
                         f"{' '.join(str(exc).split())}") from None
    names = {str(c).strip().lower(): c for c in frame.columns}
    missing = [c for c in CURVE_COLUMNS if c not in names]
    extra = sorted(str(c) for k, c in names.items() if k not in CURVE_COLUMNS)
    if missing or extra:
        raise UsageError(f"{where}: a reference curve has exactly the columns Mach and Cd "
                         f"(missing: {', '.join(missing) or 'none'}; not used: "
                         f"{', '.join(extra) or 'none'})")
    values = {}
    for key in CURVE_COLUMNS:
        column = pd.to_numeric(frame[names[key]], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(column))
        if bad.size:
            raise UsageError(f"{where}: column {names[key]} row {int(bad[0]) + 2} is not a "
                             f"finite number ({frame[names[key]].iloc[bad[0]]!r})")
        values[key] = column
    mach = values["mach"]
    if mach.size < 1:
        raise UsageError(f"{where}: the reference curve has no rows")
    if np.any(mach < 0) or np.any(np.diff(mach) <= 0) or mach[-1] > MAX_MACH:
        raise UsageError(f"{where}: Mach must increase strictly from >= 0 to at most "
                         f"{MAX_MACH:g} (got {mach.min():g} .. {mach.max():g}"
                         f"{', not increasing' if np.any(np.diff(mach) <= 0) else ''})")
    return ReferenceCurve(mach=mach, cd=values["cd"], area_m2=float(area_m2),
                          source=Path(path).name)


def cd_from_cx(value: np.ndarray, lo: np.ndarray, hi: np.ndarray, *, area_m2: float,
               reference_area_m2: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return ``(cd, cd_lo, cd_hi)`` of aeroid's ``Cx`` with its interval ``[lo, hi]``.

    ``Cd = -Cx * area_m2 / reference_area_m2`` (module docstring); the interval's ends
    swap with the sign, so ``cd_lo <= cd <= cd_hi`` when ``lo <= value <= hi``.
    """
    factor = -float(area_m2) / float(reference_area_m2)
    value, lo, hi = (np.asarray(a, dtype=float) * factor for a in (value, lo, hi))
    return value, np.minimum(lo, hi), np.maximum(lo, hi)


def conversion_note(area_m2: float, reference_area_m2: float) -> str:
    """Return the one line that says how aeroid's Cx became the curve's Cd."""
    return (f"Cd = -Cx x S_aeroid / S_ref = -Cx x {area_m2:.6g} / {reference_area_m2:.6g} "
            f"m^2 (aeroid's Cx is the body axial force coefficient, negative for drag; "
            f"equal to the drag at zero incidence)")


def flight_mach(flight: Flight) -> np.ndarray:
    """Return the flight's Mach number per sample, ``|(u, v, w)| / a`` [-].

    ``a`` is the ISA speed of sound at the airframe's ``[atmosphere] altitude_m``, or at
    the flight's ``altitude`` channel when the atmosphere is per sample.

    Raises
    ------
    UsageError
        For an atmosphere given as a density (``density_kgm3``, ``rho`` or ``qbar``): it
        tells no temperature, so no speed of sound.
    """
    airframe = flight.airframe
    if airframe.altitude_m is not None:
        altitude = np.full(flight.n_samples, airframe.altitude_m)
    elif airframe.atmosphere_channel == "altitude":
        altitude = flight["altitude"]
    else:
        raise UsageError("Mach of the flight: its atmosphere is a density, which gives no "
                         "speed of sound; give [atmosphere] altitude_m or an altitude "
                         "channel")
    speed = np.sqrt(flight["u"] ** 2 + flight["v"] ** 2 + flight["w"] ** 2)
    return speed / np.sqrt(GAMMA * R_AIR * isa_temperature(altitude))


def reference_curve_figure(mach: np.ndarray, value: np.ndarray, lo: np.ndarray,
                           hi: np.ndarray, curve: ReferenceCurve, *, area_m2: float,
                           label: str = "fitted") -> Figure:
    """Draw the fitted Cd (from Cx, with its interval) beside the reference curve.

    Parameters
    ----------
    mach : ndarray, shape (k,)
        Mach of each fitted value: a table's break points, or the two ends of the
        flight's Mach range for a constant Cx (then ``value``, ``lo``, ``hi`` repeat it).
    value, lo, hi : ndarray, shape (k,)
        aeroid's Cx and its interval (e.g. estimate +- 2 se) [-].
    curve : ReferenceCurve
        The reference, on its own area.
    area_m2 : float
        aeroid's reference area (``Airframe.area_m2``) [m^2].
    label : str
        Legend of the fitted values (the method, the interval).

    Raises
    ------
    UsageError
        When the arrays differ in length or are not finite.
    """
    arrays = [np.asarray(a, dtype=float).reshape(-1) for a in (mach, value, lo, hi)]
    if len({a.size for a in arrays}) != 1 or arrays[0].size < 1 or not all(
            np.all(np.isfinite(a)) for a in arrays):
        raise UsageError("reference curve figure: mach, value, lo and hi must be finite "
                         f"arrays of one length, got lengths {[a.size for a in arrays]}")
    mach, value, lo, hi = arrays
    cd, cd_lo, cd_hi = cd_from_cx(value, lo, hi, area_m2=area_m2,
                                  reference_area_m2=curve.area_m2)
    fig = Figure(figsize=(7.0, 4.5))
    fig.subplots_adjust(left=0.12, right=0.97, top=0.86, bottom=0.12)
    ax = fig.subplots()
    ax.plot(curve.mach, curve.cd, "-", color="0.3", lw=1.5, label=f"{curve.source} (Cd)")
    constant = np.ptp(value) == 0 and np.ptp(lo) == 0 and np.ptp(hi) == 0
    if constant:  # one coefficient over the flight's Mach range: a band
        ax.fill_between(mach, cd_lo, cd_hi, color="C0", alpha=0.25)
        ax.plot(mach, cd, "-", color="C0", lw=2.0, label=label)
    else:
        ax.errorbar(mach, cd, yerr=[cd - cd_lo, cd_hi - cd], fmt="o-", color="C0",
                    ms=4, capsize=3, label=label)
    ax.set_xlabel("Mach [-]")
    ax.set_ylabel(f"Cd on S_ref = {curve.area_m2:.4g} m^2 [-]")
    ax.set_title("drag: fitted (aeroid's Cx converted) and reference\n"
                 + conversion_note(area_m2, curve.area_m2).split(" (")[0], fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return fig
