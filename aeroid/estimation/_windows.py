"""Several windows in one fit: what :meth:`Estimator.fit` does differently with a :class:`Windows`.

:meth:`Estimator.fit` takes one path for a flight and for windows. Each window is
validated, checked for its input, its consider constants, its air data and what its
record cannot determine as a single flight is; the method's
:meth:`Estimator.run_windows` fits the windows with shared
coefficients; the fit check then judges the stacked residuals against the windows'
noise levels (each window's levels from its own samples, pooled as a mean square
weighted by the samples) on the windows joined one after the other
(:meth:`aeroid.flights.Windows.joined`). The Cramér-Rao floor warning of a single flight
(:func:`floor_warnings`) is not computed for windows: its record would integrate across
the joins; a result says so in ``info['floor_check']``.

A method that cannot fit several windows (``supports_windows`` False: the paper's PSO
methods, pyswarms) refuses in one line.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from aeroid.errors import EstimatorError
from aeroid.estimation._fitcheck import data_noise_levels
from aeroid.estimation._identifiability import RecordFinding
from aeroid.flights import Windows

__all__ = ["FLOOR_CHECK_NOTE", "check_windows", "common_findings", "pooled_noise_levels",
           "windows_info"]

#: What ``info['floor_check']`` says of a fit of several windows.
FLOOR_CHECK_NOTE = ("not computed for several windows (the floor's record would integrate "
                    "across the joins)")


def pooled_noise_levels(windows: Windows) -> dict[str, float]:
    """Each channel's noise level over the windows: ``sqrt(sum n_w s_w^2 / sum n_w)``.

    ``s_w`` is the level of window ``w`` from its own samples
    (:func:`aeroid.estimation.data_floor`'s yardstick, :func:`data_noise_levels`).
    """
    totals: dict[str, float] = {}
    counts: dict[str, int] = {}
    for flight in windows:
        for name, level in data_noise_levels(flight).items():
            totals[name] = totals.get(name, 0.0) + flight.n_samples * level * level
            counts[name] = counts.get(name, 0) + flight.n_samples
    return {name: float(np.sqrt(totals[name] / counts[name])) for name in totals}


def check_windows(estimator: Any, windows: Windows, holds: Any, tables: bool) -> None:
    """Refuse, in one line, what :meth:`Estimator.fit` cannot do with several windows.

    A method without ``supports_windows``; windows whose airframes state different
    mass uncertainties (the consider re-fits move each window's constant by one sd).
    Held coefficients and priors (``holds``) with coefficient tables (``tables``) name
    the windows' shared points (:func:`aeroid.estimation.fit_tables`).

    Raises
    ------
    EstimatorError
    """
    owner = estimator.name or type(estimator).__name__
    if not getattr(estimator, "supports_windows", False):
        raise EstimatorError(f"{owner}: fits one flight at a time; it cannot fit several "
                             "windows (methods that can: output-error, ekf, ukf, "
                             "equation-error)")
    def said(sd: Mapping[str, float]) -> str:
        return ", ".join(f"{k} sd {v:g}" for k, v in sd.items()) or "none"

    first = windows.airframe.mass_sd
    for name, flight in windows.items():
        if flight.airframe.mass_sd != first:
            raise EstimatorError(
                f"{owner}: window {name!r} states another mass uncertainty "
                f"({said(flight.airframe.mass_sd)}) than {windows.names[0]!r} "
                f"({said(first)}); give the windows the same sd")


def common_findings(findings: Sequence[Sequence[RecordFinding]]) -> tuple[RecordFinding, ...]:
    """Return the findings of the first record whose coefficients every record leaves undetermined.

    One flight: its own findings. Several windows: a coefficient is not identifiable only
    when no window determines it (a window with fin motion determines the fin terms for
    all, since they are shared).
    """
    first, *others = findings
    kept = []
    for finding in first:
        if all(any(set(finding.names) <= set(o.names) for o in other) for other in others):
            kept.append(finding)
    return tuple(kept)


def windows_info(windows: Windows, choices: Mapping[str, Any]) -> dict[str, Any]:
    """The result's ``info`` entries of a fit of several windows (module docstring)."""
    info: dict[str, Any] = {"windows": list(windows.names),
                            "window_bounds": windows.bounds(),
                            "floor_check": FLOOR_CHECK_NOTE}
    inputs = {name: c.as_info() for name, c in choices.items() if c is not None}
    if inputs:
        info["window_input"] = inputs
    return info
