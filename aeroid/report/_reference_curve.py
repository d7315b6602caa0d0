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
hi)`` arrays. :func:`reference_lines` writes the figure and its plotted data into a
report folder and returns the report's lines (``aeroid estimate --report DIR
--reference-curve CD.csv --reference-area M2``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from aeroid.errors import UsageError
from aeroid.flights import Flight, air_temperature, flight_mach_tables
from aeroid.model import isa_temperature, read_curve_csv, speed_of_sound_at
from aeroid.report._files import write_figure_atomic, write_text_atomic
from aeroid.report._tables import DIGITS, DPI, POINT_SEPARATOR, Z95

__all__ = ["REFERENCE_FILES", "ReferenceCurve", "cd_from_cx", "conversion_note",
           "fitted_cx", "flight_mach", "mach_range", "overlap_note", "read_reference_curve",
           "reference_curve_figure", "reference_lines"]

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
    values = read_curve_csv(path, required=CURVE_COLUMNS, kind="reference curve",
                            columns_text="exactly the columns Mach and Cd", row_word="row",
                            error=UsageError)
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
    return speed / speed_of_sound_at(isa_temperature(altitude))


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


#: Files :func:`reference_lines` writes into a report folder: the figure and its data.
REFERENCE_FILES = {"figure": "drag_vs_reference.png", "data": "drag_vs_reference.csv"}


def mach_range(flight: Flight) -> tuple[float, float]:
    """Return the flight's lowest and highest Mach number.

    The model's own Mach (:meth:`aeroid.model.MachTables.mach`: the ``[tables]`` speed of
    sound) for an airframe with ``[tables]``, else :func:`flight_mach`.

    Raises
    ------
    UsageError
        As :func:`flight_mach` (an atmosphere given as a density).
    """
    tables = flight_mach_tables(flight)  # Mach per sample from a logged air temperature
    mach = (flight_mach(flight) if tables is None
            else tables.mach(flight.states(), air_temperature(flight)))
    return float(np.min(mach)), float(np.max(mach))


def overlap_note(flight_range: tuple[float, float], curve: ReferenceCurve) -> str | None:
    """Return one line when the flight's Mach range and the curve's do not overlap."""
    low, high = flight_range
    if high >= curve.mach[0] and low <= curve.mach[-1]:
        return None
    return (f"reference curve {curve.source}: its Mach range {curve.mach[0]:g} .. "
            f"{curve.mach[-1]:g} and the flight's {low:.3g} .. {high:.3g} do not overlap; "
            f"the figure shows them side by side, nothing is compared at one Mach")


def fitted_cx(result: Any, flight_range: tuple[float, float]
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, str]:
    """Return ``(mach, value, lo, hi, label)`` of a result's Cx for the figure.

    A Cx table (``Cx@M...`` names): its points at their knots; a constant Cx: its value
    at the two ends of ``flight_range``. The interval is +- ``Z95`` standard errors
    (95 %); a held Cx or one without a standard error has none (``lo = hi = value``),
    and ``label`` says which.

    Raises
    ------
    UsageError
        When the result has no Cx (neither a constant nor a table) or it is not finite.
    """
    names = list(result.names)
    stderr = (np.full(len(names), np.nan) if result.stderr is None
              else np.asarray(result.stderr, dtype=float))
    theta = np.asarray(result.theta, dtype=float)
    points = [i for i, n in enumerate(names) if n.split(POINT_SEPARATOR)[0] == "Cx"]
    if not points or not np.all(np.isfinite(theta[points])):
        raise UsageError(f"reference curve: the {result.estimator} fit has no finite Cx "
                         "to draw")
    if names[points[0]] == "Cx":
        mach = np.array(flight_range, dtype=float)
        value, se = np.full(2, theta[points[0]]), np.full(2, stderr[points[0]])
        held = "Cx" in result.held
    else:
        mach = np.array([float(names[i].split(POINT_SEPARATOR)[1]) for i in points])
        order = np.argsort(mach)
        mach, value, se = mach[order], theta[points][order], stderr[points][order]
        held = all(names[i] in result.held or "Cx" in result.held for i in points)
    if held or not np.all(np.isfinite(se)):
        why = "held" if held else "no standard error"
        return mach, value, value.copy(), value.copy(), f"{result.estimator} ({why}: no interval)"
    return (mach, value, value - Z95 * se, value + Z95 * se,
            f"{result.estimator}, +- {Z95:g} se (95 %)")


def reference_lines(result: Any, flight: Any, curve: ReferenceCurve,
                    folder: Path, *, flight_range: tuple[float, float] | None = None
                    ) -> list[str]:
    """Write :data:`REFERENCE_FILES` into ``folder``; return the report's markdown lines.

    The figure is :func:`reference_curve_figure` of :func:`fitted_cx`; the CSV holds the
    same arrays (``mach, cx, cx_lo, cx_hi, cd, cd_lo, cd_hi``) and the curve is not
    repeated in it. The lines: a heading, the conversion, the overlap (when there is
    none), the figure and the CSV; for a fit without a finite Cx (a failed method), no
    files and a line saying so. ``flight_range``: the record's Mach range when it is not
    a :class:`Flight` (a suite log fitted by axial-drag: its fitted track's,
    ``info["mach_range"]``); ``flight`` then needs only its ``airframe``. Default: the
    flight's (:func:`mach_range`).
    """
    area = flight.airframe.area_m2
    flight_range = mach_range(flight) if flight_range is None else flight_range
    lines = ["## Drag against a reference curve", "",
             f"Reference: `{curve.source}` (Mach {curve.mach[0]:g} .. {curve.mach[-1]:g}) "
             f"on S_ref = {curve.area_m2:.6g} m^2; the flight's Mach {flight_range[0]:.3g} "
             f".. {flight_range[1]:.3g}.", "", f"- {conversion_note(area, curve.area_m2)}"]
    note = overlap_note(flight_range, curve)
    lines += [f"- warning: {note}"] if note else []
    try:
        mach, value, lo, hi, label = fitted_cx(result, flight_range)
    except UsageError as exc:  # a failed fit: its report is still written
        return [*lines, f"- no figure: {exc}", ""]
    fig = reference_curve_figure(mach, value, lo, hi, curve, area_m2=area, label=label)
    write_figure_atomic(fig, folder / REFERENCE_FILES["figure"], DPI)
    cd, cd_lo, cd_hi = cd_from_cx(value, lo, hi, area_m2=area, reference_area_m2=curve.area_m2)
    frame = pd.DataFrame({"mach": mach, "cx": value, "cx_lo": lo, "cx_hi": hi, "cd": cd,
                          "cd_lo": cd_lo, "cd_hi": cd_hi})
    write_text_atomic(folder / REFERENCE_FILES["data"],
                      frame.to_csv(index=False, float_format=f"%.{DIGITS}g"))
    return lines + [
        "", f"![drag against the reference curve]({REFERENCE_FILES['figure']})", "",
        f"The plotted values: `{REFERENCE_FILES['data']}`.", ""]
