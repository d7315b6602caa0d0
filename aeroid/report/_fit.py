"""The report of one fit: ``report.md`` and its PNG figures in a folder.

What it shows (issue "See the fit"): the status and every warning; the coefficient table
(estimate, standard error, prior, Cramér-Rao floor from the data, and the truth of a
simulated flight); the fit check, every key the method reports; measured against model
for every output channel with the residual and its noise band; the residual
autocorrelation; the deflection the model used; the correlation of the estimates.

The model is :meth:`aeroid.estimation.EstimationResult.predict`: an open-loop simulation
with the fit's input, delay, positions and start, the fit's IMU errors (biases and scale
factors: ``reading = (1 + s) model + b``) when it estimated them, and **in the air the fit
used** (its fitted steady wind, the wind its air data imply, the reconstruction's; the
still-air model then a second, dashed trace: :mod:`aeroid.report._fit_views`), so the
residuals are the ones the fit had. For the filters that is not what they fitted (their
residuals are one-step innovations) and for the equation-error and EBM methods neither
(theirs are forces and moments): the fit check's numbers are the method's own, the
figures the model's outputs; the report says so.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from aeroid.estimation import (
    EstimationResult,
    correlation,
    data_floor,
    estimate_noise_sd,
    exact_mass_note,
    holds_of,
    switch_free_samples,
)
from aeroid.flights import UNITS, Flight, schedule
from aeroid.model import OUTPUT_CHANNELS
from aeroid.report._figures import (
    BAND_SD,
    DPI,
    autocorrelation_figure,
    channel_figure,
    correlation_figure,
    deflection_figure,
    wind_figure,
)
from aeroid.report._files import make_directory, write_figure_atomic, write_text_atomic
from aeroid.report._fit_views import FitView, fit_view, view_lines
from aeroid.report._html import html_page, report_name
from aeroid.report._reference_curve import ReferenceCurve, reference_lines
from aeroid.report._tables import has_tables, write_tables_report

__all__ = ["REPORT_NAME", "report_figures", "report_markdown", "write_report"]

#: The markdown file of a report folder.
REPORT_NAME = "report.md"


def _noise_levels(result: EstimationResult, flight: Flight) -> dict[str, float]:
    """Each output channel's noise level: the fit check's, else from the data alone."""
    check = result.info.get("fit_check") or {}
    given = check.get("noise_sd", {}) if isinstance(check, Mapping) else {}
    use = switch_free_samples(flight["delta"])
    out = {}
    for name in OUTPUT_CHANNELS:
        if name in given:
            out[name] = float(given[name])
        else:
            out[name] = float(estimate_noise_sd(flight[name], statistic="rms", use=use))
    return out


def _schedule_knots(flight: Flight, input_mode: str, delay: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The knots of the deflection the model used, clipped to the log's window."""
    sched = schedule(flight, input_mode)
    if delay:
        sched = sched.shifted(delay)
    t0, t1 = float(flight.t[0]), float(flight.t[-1])
    inside = (sched.times > t0) & (sched.times < t1)
    times = np.concatenate([[t0], sched.times[inside], [t1]])
    values = np.concatenate([np.atleast_1d(sched.at(np.array([t0]))), sched.values[inside],
                             np.atleast_1d(sched.before(np.array([t1])))])
    return times, values


def report_figures(result: EstimationResult, flight: Flight,
                   prediction: Any | None = None, view: FitView | None = None
                   ) -> dict[str, Any]:
    """Return the report's figures by file stem: one per output channel, ``autocorrelation``,
    ``deflection``, ``wind`` (moving air: :mod:`aeroid.report._fit_views`) and, with a
    covariance, ``correlation`` (matplotlib Figures).

    ``prediction``: :meth:`EstimationResult.predict` of the flight, ``view``: its
    :func:`fit_view`, when already made. No model figures when the estimates are not
    finite (a failed method).
    """
    figures: dict[str, Any] = {}
    if np.all(np.isfinite(result.theta)):
        frame = result.predict(flight) if prediction is None else prediction
        levels = _noise_levels(result, flight)
        view = fit_view(result, flight, frame, levels) if view is None else view
        residuals = {}
        for name in OUTPUT_CHANNELS:
            measured, drawn = flight[name], view.channels[name]
            residuals[name] = measured[drawn.index] - drawn.model
            figures[name] = channel_figure(name, UNITS[name], flight.t, measured, drawn.model,
                                           levels[name], model_label=drawn.label,
                                           index=drawn.index, second=drawn.second,
                                           second_label=drawn.second_label)
        figures["autocorrelation"] = autocorrelation_figure(residuals, flight.dt)
        times, values = _schedule_knots(flight, frame.attrs["input"], frame.attrs["delay_s"])
        label = f"model's delta (input {frame.attrs['input']}"
        label += f", delay {frame.attrs['delay_s'] * 1e3:.3g} ms)" if frame.attrs["delay_s"] \
            else ")"
        figures["deflection"] = deflection_figure(flight.t, flight["delta"], times, values,
                                                  label)
        if view.wind is not None:
            figures["wind"] = wind_figure(flight.t, *view.wind)
    matrix = _correlation(result)
    if matrix is not None:
        figures["correlation"] = correlation_figure(matrix, result.names)
    return figures


def _correlation(result: EstimationResult) -> np.ndarray | None:
    given = result.info.get("correlation")
    if given is not None:
        return np.asarray(given, dtype=float)
    return correlation(result.covariance)


def _number(value: Any) -> str:
    if isinstance(value, bool | np.bool_):
        return str(bool(value)).lower()
    if isinstance(value, int | np.integer):
        return str(int(value))
    if isinstance(value, float | np.floating):
        return "n/a" if not np.isfinite(value) else f"{value:.6g}"
    return " ".join(str(value).split()).replace("|", "\\|")


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_number(v) for v in row) + " |" for row in rows]
    return lines


def _per_channel(check: Mapping[str, Any]) -> dict[str, Mapping[str, Any]]:
    """The fit check's per-channel entries as columns: ``{channel: scalar}`` entries as
    they are, ``{channel: {name: scalar}}`` entries one column per name (``key.name``)."""
    columns: dict[str, Mapping[str, Any]] = {}
    for key, value in check.items():
        if not isinstance(value, Mapping) or not value:
            continue
        if all(not isinstance(x, Mapping) for x in value.values()):
            columns[key] = value
        elif all(isinstance(x, Mapping) for x in value.values()):
            names: list[str] = []
            for inner in value.values():
                names += [n for n in inner if n not in names]
            for name in names:
                columns[f"{key}.{name}"] = {c: v.get(name, "") for c, v in value.items()}
    return columns


def _fit_check_lines(check: Mapping[str, Any]) -> list[str]:
    """Every key of the fit check: per-channel entries as columns, the rest as lines."""
    per_channel = _per_channel(check)
    channels: list[str] = []
    for values in per_channel.values():
        channels += [c for c in values if c not in channels]
    lines = []
    if channels:
        header = ["channel", *per_channel]
        rows = [[c, *(per_channel[k].get(c, "") for k in per_channel)] for c in channels]
        lines += _table(header, rows)
        lines.append("")
    shown = {k.split(".")[0] for k in per_channel}
    for key, value in check.items():
        if key not in shown:
            lines.append(f"- {key}: {_number(value)}")
    return lines


def _coefficient_rows(frame: Any) -> tuple[list[str], list[list[Any]]]:
    labels = {"estimate": "estimate", "stderr": "std err", "held_prior": "held / prior",
              "prior": "prior (start)", "floor": "Cramér-Rao floor", "truth": "truth",
              "error_pct": "error %"}
    columns = [c for c in labels if c in frame.columns]
    rows = [[name, *(frame.loc[name, c] for c in columns)] for name in frame.index]
    return ["coefficient", *(labels[c] for c in columns)], rows


def _with_holds(frame: Any, result: EstimationResult) -> Any:
    """Add the column ``held_prior`` (held at a value, a Gaussian prior, or free) to a
    coefficient frame of a result fitted with held or prior coefficients."""
    if not (result.held or result.priors):
        return frame
    frame = frame.copy()
    frame["held_prior"] = [
        f"held at {result.held[n]:g}" if n in result.held else
        "prior N({:g}, {:g}^2)".format(*result.priors[n]) if n in result.priors else "free"
        for n in frame.index]
    return frame


def report_markdown(result: EstimationResult, flight: Flight, figures: Sequence[str],
                    notes: Sequence[str] = (), prediction: Any | None = None,
                    floor: np.ndarray | None = None, view: FitView | None = None) -> str:
    """Return the report's markdown, linking the figure files ``figures`` (stems);
    ``view``: what the channel figures draw (:func:`aeroid.report._fit_views.fit_view`)."""
    source = flight.metadata.get("source", "flight")
    status = "ok" if result.success else "FAILED"
    lines = [f"# {result.estimator} on {source}", "",
             f"**{status}**" + (f": {_number(result.message)}" if result.message else ""),
             "", f"{flight.n_samples} samples, t = {flight.t[0]:g} .. {flight.t[-1]:g} s; "
             f"{result.n_evaluations} evaluations, {result.n_iterations} iterations, "
             f"{result.wall_time_s:.3g} s.", "", "## Warnings and notes", ""]
    found = [f"- warning: {_number(w)}" for w in result.warnings]
    found += [f"- {_number(n)}" for n in notes]
    found += _mass_lines(result, flight)
    lines += (found or ["none"]) + [""]
    frame = _with_holds(result.to_frame(flight, floor=floor), result)
    header, rows = _coefficient_rows(frame)
    lines += ["## Coefficients", ""] + _table(header, rows) + [""]
    lines += _imu_error_lines(result.info)
    if "floor" not in frame.columns:
        lines += ["No Cramér-Rao floor: the data are noise-free (every channel's noise "
                  "level at the fit check's resolution) or the model diverges.", ""]
    else:
        lines += ["The floor is the Cramér-Rao standard deviation of output-error "
                  "(both triads, p q r, initial rates estimated) with each channel's noise "
                  "level estimated from the data, at the estimate.", ""]
    check = result.info.get("fit_check")
    lines += ["## Fit check", ""]
    if isinstance(check, Mapping) and check:
        lines += ["The method's residual RMS against each channel's noise level estimated "
                  "from the data (about 1 when the model fits).", ""]
        lines += _fit_check_lines(check) + [""]
    else:
        lines += ["The method reports no residuals: no fit check.", ""]
    if prediction is not None:
        attrs = prediction.attrs
        lines += ["## Model against the data", "",
                  f"The model's outputs simulated at the estimate: input "
                  f"`{attrs['input']}`, delay {attrs['delay_s']:g} s, "
                  f"{attrs['substeps']} RK4 step(s) per sample, accelerometer positions "
                  f"{_positions(attrs['accel_positions_m'])} m, initial state "
                  f"{attrs['initial_state_from']}; "
                  f"{attrs.get('imu_errors_note', 'no IMU errors applied')}. "
                  f"Residual band: +-{BAND_SD:g} noise sd.", ""]
        if "fit_check" in result.info and not set(OUTPUT_CHANNELS) & set(
                result.info["fit_check"].get("ratio", {})):
            lines += ["This method fits forces and moments, not these outputs: the fit "
                      "check above is on its own channels.", ""]
        lines += view_lines(view) if view is not None else []
    for stem in figures:
        drawn = None if view is None else view.channels.get(stem)
        lines += [f"![{_caption(stem, 'model' if drawn is None else drawn.label)}]"
                  f"({stem}.png)", ""]
    lines += _details(result)
    return "\n".join(lines).rstrip() + "\n"


def _mass_lines(result: EstimationResult, flight: Flight) -> list[str]:
    """The mass constants taken as exact (an assumption) and the consider parameters."""
    exact = exact_mass_note(flight.airframe)
    lines = [f"- assumption: {_number(exact)}"] if exact else []
    consider = result.consider
    if consider is not None:
        line = f"- {_number(consider.describe())}"
        if consider.stderr_without is not None:
            line += "; std err without them: " + ", ".join(
                f"{n} {_number(v)}" for n, v in zip(result.names, consider.stderr_without,
                                                     strict=True))
        lines.append(line)
    return lines


def _imu_error_lines(info: Mapping[str, Any]) -> list[str]:
    """The fit's IMU errors with their standard errors (none: no lines)."""
    errors = info.get("imu_errors")
    if not isinstance(errors, Mapping) or not errors:
        return []
    stderr = info.get("imu_error_stderr")
    stderr = stderr if isinstance(stderr, Mapping) else {}
    rows = [[name, value, stderr.get(name, float("nan"))] for name, value in errors.items()]
    return (["## IMU errors", "", "Estimated with the coefficients: reading = (1 + s) model + "
             "b per channel (b [m/s^2, rad/s], s [-]); the model's figures apply them.", ""]
            + _table(["error", "estimate", "std err"], rows) + [""])


def _positions(positions: Sequence[Sequence[float]]) -> str:
    return "; ".join("(" + ", ".join(f"{v:.4g}" for v in row) + ")" for row in positions)


def _caption(stem: str, label: str = "model") -> str:
    if stem in UNITS:
        what = "innovation" if "one-step" in label else "residual"
        return f"{stem} [{UNITS[stem]}]: measured, {label} and {what}"
    return {"autocorrelation": "residual autocorrelation [-] of every output channel",
            "deflection": "delta [deg]: logged and used by the model",
            "wind": "wind [m/s] per sample, north, east, down",
            "correlation": "correlation of the estimates [-]"}.get(stem, stem)


def _details(result: EstimationResult) -> list[str]:
    info = result.info
    lines = ["## Method details", ""]
    for key in ("passes", "delay_s", "delay_stderr_s", "compiled", "input"):
        if key in info:
            lines.append(f"- {key}: {_number(info[key])}")
    if "accel_positions_m" in info:
        lines.append(f"- estimated accelerometer positions [m]: "
                     f"{_positions(np.asarray(info['accel_positions_m']).tolist())}")
    options = info.get("options")
    if isinstance(options, Mapping):
        lines.append("- options: " + ", ".join(f"{k} = {_number(v)}"
                                                for k, v in options.items()))
    return lines + [""]


def write_report(result: EstimationResult, flight: Flight, directory: str | Path, *,
                 notes: Sequence[str] = (), fmt: str = "md",
                 reference: ReferenceCurve | None = None) -> Path:
    """Write ``report.md`` (or ``report.html``) and its PNG figures into ``directory``;
    return the report's path.

    Every file is written atomically (a temporary file beside it, then ``os.replace``).
    ``notes``: one-line notes to list with the warnings (what reading the log did, the
    flight's validation warnings). ``fmt``: ``md``, or ``html`` for the same markdown
    rendered as one self-contained page (:func:`aeroid.report.html_page`) linking the
    same PNG files. ``reference``: a design tool's drag curve, drawn beside the fitted
    Cx (:func:`aeroid.report.reference_lines`: a figure, its data and a section).

    Raises
    ------
    UsageError
        One line naming the path when the folder or a file cannot be written.
    """
    name = report_name(REPORT_NAME.rsplit(".", 1)[0], fmt)
    folder = make_directory(directory)
    extra = [] if reference is None else reference_lines(result, flight, reference, folder)
    if has_tables(result.names):  # coefficient tables in Mach: aeroid/report/_tables.py
        return write_tables_report(result, flight, folder, name, notes=notes, fmt=fmt,
                                   sections=extra)
    finite = bool(np.all(np.isfinite(result.theta)))
    prediction = result.predict(flight) if finite else None
    floor = None
    if finite:
        floor = data_floor(flight, result.theta, prediction.attrs["input"],  # type: ignore
                           holds=holds_of(result))  # held: no floor; priors added
    view = None if prediction is None else fit_view(result, flight, prediction,
                                                     _noise_levels(result, flight))
    figures = report_figures(result, flight, prediction, view)
    for stem, fig in figures.items():
        write_figure_atomic(fig, folder / f"{stem}.png", DPI)
    text = report_markdown(result, flight, list(figures), notes, prediction, floor, view)
    text += "\n" + "\n".join(extra) if extra else ""
    if fmt == "html":
        source = flight.metadata.get("source", "flight")
        text = html_page(text, f"{result.estimator} on {source}")
    return write_text_atomic(folder / name, text)
