"""The report of a fit of a sensor-suite log itself (no flight): axial-drag's.

``aeroid estimate LOG.toml --method axial-drag --report DIR`` fits the flight computer's
files directly (an axial accelerometer and a GNSS track: there is no :class:`Flight`,
so no model-against-data panels of the nine outputs). The page holds what every report
holds that such a fit has: the status, every warning and note, the Cx table against Mach
with its 95 % intervals (``tables.csv``, the JSBSim fragment and ``tables.png``, as a
flight's table fit) or the constant Cx, the mass as consider parameter or as an
assumption, the fit's other parameters (the track's start, the trim factor, the
barometer's origin, the accelerometer's bias and scale factor), the fit check per
channel and, with a reference curve, the drag against it over the fitted track's Mach
range (``info["mach_range"]``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from aeroid.estimation import EstimationResult, exact_mass_note
from aeroid.report._files import make_directory, write_figure_atomic, write_text_atomic
from aeroid.report._html import html_page, report_name
from aeroid.report._reference_curve import ReferenceCurve, reference_lines
from aeroid.report._tables import (
    DPI,
    TABLE_FILES,
    Z95,
    fitted_tables,
    has_tables,
    jsbsim_fragment,
    tables_csv,
    tables_figure,
)

__all__ = ["write_log_report"]


def _number(value: Any) -> str:
    if isinstance(value, float | np.floating):
        return "n/a" if not np.isfinite(value) else f"{value:.6g}"
    return " ".join(str(value).split()).replace("|", "\\|")


def _cx_lines(result: EstimationResult, folder: Path) -> list[str]:
    """The Cx table (its files written) or the constant Cx, with 95 % intervals."""
    stderr = (np.full(len(result.names), np.nan) if result.stderr is None
              else np.asarray(result.stderr, dtype=float))
    lines = ["## Cx against Mach", ""]
    if has_tables(result.names):
        tables = fitted_tables(result.names, result.theta, stderr)
        write_text_atomic(folder / TABLE_FILES["csv"], tables_csv(tables))
        write_text_atomic(folder / TABLE_FILES["jsbsim"],
                          jsbsim_fragment(tables, f"aeroid {result.estimator}"))
        write_figure_atomic(tables_figure(tables), folder / TABLE_FILES["figure"], DPI)
        lines += [f"![tables]({TABLE_FILES['figure']})", ""]
        rows = [(f"{t.name} at Mach {m:g}", v, s) for t in tables
                for m, v, s in zip(t.mach, t.value, t.stderr, strict=True)]
    else:
        rows = list(zip(result.names, result.theta, stderr, strict=True))
    lines += ["| coefficient | estimate | std err | 95 % interval |", "|---|---|---|---|"]
    lines += [f"| {n} | {v:.6g} | {_number(s)} | {v - Z95 * s:.6g} .. {v + Z95 * s:.6g} |"
              for n, v, s in rows]
    if has_tables(result.names):
        lines += ["", f"Files: `{TABLE_FILES['csv']}` (every point, its standard error and "
                  f"95 % interval), `{TABLE_FILES['jsbsim']}` (a JSBSim aerodynamics "
                  "fragment indexed by `velocities/mach`)."]
    return [*lines, ""]


def _mass_lines(result: EstimationResult, airframe: Any) -> list[str]:
    consider = result.consider
    if consider is None:
        exact = exact_mass_note(airframe)
        return [f"- assumption: {_number(exact)}"] if exact else []
    line = f"- {_number(consider.describe())}"
    if consider.stderr_without is not None:
        line += "; std err without them: " + ", ".join(
            f"{n} {_number(v)}" for n, v in zip(result.names, consider.stderr_without,
                                                 strict=True))
    return [line]


def _other_lines(info: Mapping[str, Any]) -> list[str]:
    """The fit's other parameters (nuisance, the accelerometer's errors) with their se."""
    rows = [(n, v, s) for n, (v, s) in (info.get("nuisance") or {}).items()]
    errors = info.get("imu_errors") or {}
    stderr = info.get("imu_error_stderr") or {}
    shown = {n for n, _, _ in rows}  # axial-drag lists its IMU errors among the nuisance
    rows += [(n, v, stderr.get(n, float("nan"))) for n, v in errors.items() if n not in shown]
    if not rows:
        return []
    return (["## Other parameters of the fit", "",
             "The track's start (NED position [m] and velocity [m/s]), the trim factor, "
             "the barometer's origin altitude [m], the accelerometer's bias [m/s^2] and "
             "scale factor (reading = (1 + s) model + b); their standard errors without "
             "the mass sd.", "", "| parameter | estimate | std err |", "|---|---|---|"]
            + [f"| {n} | {_number(float(v))} | {_number(float(s))} |" for n, v, s in rows]
            + [""])


def _check_lines(check: Any) -> list[str]:
    if not isinstance(check, Mapping) or not check.get("ratio"):
        return ["The method reports no residuals: no fit check.", ""]
    lines = [f"Each channel's residual RMS over its stated noise sd (limit "
             f"{_number(check.get('limit', float('nan')))}; about 1 when the model fits).",
             "", "| channel | residual RMS / noise sd |", "|---|---|"]
    lines += [f"| {c} | {r:.3g} |" for c, r in check["ratio"].items()]
    priors = check.get("priors") or {}
    if priors:
        lines += ["", f"Priors (|estimate - mean| / sd, limit "
                  f"{_number(check.get('prior_limit', float('nan')))}): "
                  + ", ".join(f"{n} {v:.3g}" for n, v in priors.items())]
    return [*lines, ""]


def write_log_report(result: EstimationResult, log: Any, directory: str | Path, *,
                     notes: Sequence[str] = (), fmt: str = "md",
                     reference: ReferenceCurve | None = None) -> Path:
    """Write the report of a suite log's fit (module docstring); return the page's path.

    Parameters
    ----------
    result : EstimationResult
        A fit of the log (axial-drag's: ``info["mach_range"]``, ``info["span_s"]``).
    log : SuiteLog
        The log as fitted (its ``airframe`` the one the fit used, ``source`` its file).
    directory : str or Path
        The report folder (made when missing).
    notes : sequence of str
        One-line notes listed with the warnings (what reading the log did).
    fmt : str
        ``md`` or ``html`` (:func:`aeroid.report.html_page`).
    reference : ReferenceCurve, optional
        A design tool's drag curve, drawn beside the fitted Cx over ``info["mach_range"]``.

    Raises
    ------
    UsageError
        One line naming the path when the folder or a file cannot be written.
    """
    folder = make_directory(directory)
    info = result.info
    status = "ok" if result.success else "FAILED"
    span = info.get("span_s")
    lines = [f"# {result.estimator} on {log.source}", "",
             f"**{status}**" + (f": {_number(result.message)}" if result.message else ""), "",
             "A sensor-suite log fitted as it is (no flight-path reconstruction)"
             + (f", t = {span[0]:g} .. {span[1]:g} s" if span else "")
             + f"; {result.n_evaluations} evaluations, {result.wall_time_s:.3g} s.", "",
             "## Warnings and notes", ""]
    found = [f"- warning: {_number(w)}" for w in result.warnings]
    found += [f"- {_number(n)}" for n in (*notes, *info.get("notes", ()))]
    lines += [*found, *_mass_lines(result, log.airframe), ""]
    finite = bool(np.all(np.isfinite(result.theta)))
    lines += _cx_lines(result, folder) if finite else [
        "## Cx against Mach", "", "No estimate: the fit failed.", ""]
    lines += _other_lines(info)
    lines += ["## Fit check", "", *_check_lines(info.get("fit_check"))]
    if reference is not None:
        given = info.get("mach_range")
        if given is None:
            lines += ["## Drag against a reference curve", "",
                      "- no figure: the fit gives no Mach range of its track", ""]
        else:
            lines += reference_lines(result, log, reference, folder,
                                     flight_range=(float(given[0]), float(given[1])))
    options = info.get("options")
    if isinstance(options, Mapping):
        lines += ["## Method details", "", "- options: " + ", ".join(
            f"{k} = {_number(v)}" for k, v in options.items()), ""]
    text = "\n".join(lines).rstrip() + "\n"
    if fmt == "html":
        text = html_page(text, f"{result.estimator} on {log.source}")
    return write_text_atomic(folder / report_name("report", fmt), text)
