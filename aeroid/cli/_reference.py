"""``aeroid estimate --reference-curve CD.csv --reference-area M2`` (issue 25).

The curve is read before the log (a bad file or area, a missing ``--report``, several
files or windows are said at once); once the log is read, the conversion is said in one
line and, when the flight's Mach range and the curve's do not overlap, a warning says
so, all before the fits. The figure is drawn into the ``--report`` folder by
:func:`aeroid.report.write_report`.
"""

from __future__ import annotations

import argparse
import logging
import warnings
from typing import Any

from aeroid.errors import AeroidWarning, UsageError

__all__ = ["check_reference", "reference_from_args"]


def reference_from_args(args: argparse.Namespace) -> Any:
    """Return the ``ReferenceCurve`` of ``--reference-curve`` (None without it).

    Raises
    ------
    UsageError
        One line: the curve without ``--reference-area`` or without ``--report`` (the
        figure goes into the report folder), the area without the curve, several files
        or ``--windows`` (their Mach ranges are several), a bad file or area
        (:func:`aeroid.report.read_reference_curve`).
    """
    path = getattr(args, "reference_curve", None)
    area = getattr(args, "reference_area", None)
    if path is None:
        if area is not None:
            raise UsageError("--reference-area is the area of --reference-curve: give the "
                             "curve too")
        return None
    if area is None:
        raise UsageError(f"--reference-curve {path}: state the curve's reference area with "
                         "--reference-area M2 (a design tool's area is its own)")
    if getattr(args, "report", None) is None:
        raise UsageError("--reference-curve draws into the report folder: give --report DIR")
    if getattr(args, "windows", None) or len(getattr(args, "flight", ())) > 1:
        raise UsageError("--reference-curve takes one log of one window: not with several "
                         "files or --windows")
    from aeroid.report import read_reference_curve

    return read_reference_curve(path, area_m2=area)


def check_reference(curve: Any, flight: Any) -> None:
    """Say the conversion (a notice) and a missing overlap (a warning), once, before the fits.

    Raises
    ------
    UsageError
        For a flight whose Mach is unknown (its atmosphere a density).
    """
    if curve is None:
        return
    from aeroid.report import conversion_note, mach_range, overlap_note

    flight_range = mach_range(flight)  # a flight without a speed of sound: refused first
    logging.getLogger("aeroid").info(conversion_note(flight.airframe.area_m2, curve.area_m2))
    note = overlap_note(flight_range, curve)
    if note:
        warnings.warn(note, AeroidWarning, stacklevel=2)
