"""The report of a fit of several windows: one set of model panels per window.

The shared part (status, warnings, coefficients, fit check, correlation) is the one-fit
report's (:func:`aeroid.report.report_markdown`) over the windows joined; then a table of
each window's own parameters (initial state, delay, IMU errors: whatever the method
estimated) and, per window, the model against that window's data, simulated from that
window's own start with its own delay, input and IMU errors
(:func:`window_view`, :meth:`aeroid.estimation.EstimationResult.predict`).
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from aeroid.estimation import EstimationResult
from aeroid.flights import Flight, Windows, imu_error_names
from aeroid.report._figures import DPI
from aeroid.report._files import make_directory, write_figure_atomic, write_text_atomic
from aeroid.report._fit import REPORT_NAME, report_figures, report_markdown
from aeroid.report._html import html_page, report_name

__all__ = ["window_view", "windows_markdown", "write_windows_report"]

#: Every IMU-error name a window's parameters may hold (biases and scale factors).
_IMU_NAMES = frozenset(imu_error_names("bias+scale"))


def window_view(result: EstimationResult, name: str) -> EstimationResult:
    """The result as seen by window ``name``: its start, delay, input, IMU errors and wind.

    ``info`` keeps the shared entries and takes the window's ``initial_state``,
    ``delay_s`` and ``imu_errors`` from ``info['window_parameters'][name]`` (when the method
    estimated them), its input from ``info['window_input'][name]`` and its steady wind
    from ``info['window_wind'][name]`` (drawn in it: :mod:`aeroid.report._fit_views`).
    """
    info = {k: v for k, v in result.info.items()
            if k not in ("initial_state", "delay_s", "imu_errors", "imu_error_stderr",
                         "wind_ned_mps")}
    own = (result.info.get("window_parameters") or {}).get(name, {})
    if "initial_state" in own:
        info["initial_state"] = np.asarray(own["initial_state"], dtype=float)
    if "delay_s" in own:
        info["delay_s"] = float(own["delay_s"])
    imu = {k: float(v) for k, v in own.items() if k in _IMU_NAMES}
    if imu:
        info["imu_errors"] = imu
    wind = (result.info.get("window_wind") or {}).get(name, {}).get("wind_ned_mps")
    if wind is not None:  # the window's own steady wind (output-error's estimate_wind)
        info["wind_ned_mps"] = wind
    choice = (result.info.get("window_input") or {}).get(name, {})
    used = choice.get("input", result.input)
    return dataclasses.replace(result, info=info, input=used)


def _stem(name: str) -> str:
    """A file-name-safe form of a window's name."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)


def _number(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def windows_markdown(result: EstimationResult, windows: Windows,
                     window_figures: dict[str, list[str]], shared: Sequence[str],
                     notes: Sequence[str] = ()) -> str:
    """The report's markdown: the one-fit report of the joined windows, then per window."""
    joined = windows.joined()
    text = report_markdown(result, joined, list(shared), notes)
    ranges = "; ".join(f"{name}: {f.n_samples} samples, t = {f.t[0]:g} .. {f.t[-1]:g} s"
                       for name, f in windows.items())
    text = text.replace(f"{joined.n_samples} samples, t = {joined.t[0]:g} .. "
                        f"{joined.t[-1]:g} s; ", f"{len(windows)} windows ({ranges}); ", 1)
    values = result.info.get("window_parameters") or {}
    stderr = result.info.get("window_parameter_stderr") or {}
    lines = ["", "## Windows", "",
             "The coefficients are shared; each window has its own start, inputs, "
             "atmosphere and, where the method estimated them, delay and IMU errors.", "",
             "| window | parameter | estimate | std err |", "| --- | --- | --- | --- |"]
    for name in windows.names:
        own = {k: v for k, v in values.get(name, {}).items() if isinstance(v, float | int)}
        if not own:
            lines.append(f"| {name} | none estimated | | |")
        for key, value in own.items():
            sd = stderr.get(name, {}).get(key, float("nan"))
            lines.append(f"| {name} | {key} | {_number(float(value))} | {_number(float(sd))} |")
    for name, flight in windows.items():
        lines += ["", f"### Window {name}", "",
                  f"{flight.metadata.get('source', name)}: {flight.n_samples} samples, "
                  f"t = {flight.t[0]:g} .. {flight.t[-1]:g} s; the model simulated from "
                  "this window's own start.", ""]
        for stem in window_figures.get(name, []):
            channel = stem.rsplit("--", 1)[1]
            lines += [f"![{name}: {channel}]({stem}.png)", ""]
    return text.rstrip() + "\n" + "\n".join(lines).rstrip() + "\n"


def write_windows_report(result: EstimationResult, windows: Windows,
                         directory: str | Path, *, notes: Sequence[str] = (),
                         fmt: str = "md") -> Path:
    """Write the report of a fit of several windows (module docstring); return its path.

    Figures: the shared ``correlation``, and per window ``NAME--CHANNEL.png`` for every
    output channel, ``NAME--autocorrelation`` and ``NAME--deflection``.
    """
    folder = make_directory(directory)
    shared = report_figures(dataclasses.replace(result, theta=np.full_like(result.theta,
                                                                          np.nan)),
                            _first(windows))  # the correlation only (no model panels)
    for stem, fig in shared.items():
        write_figure_atomic(fig, folder / f"{stem}.png", DPI)
    per_window: dict[str, list[str]] = {}
    if np.all(np.isfinite(result.theta)):
        for name, flight in windows.items():
            figures = report_figures(window_view(result, name), flight)
            figures.pop("correlation", None)
            per_window[name] = []
            for stem, fig in figures.items():
                full = f"{_stem(name)}--{stem}"
                write_figure_atomic(fig, folder / f"{full}.png", DPI)
                per_window[name].append(full)
    text = windows_markdown(result, windows, per_window, list(shared), notes)
    if fmt == "html":
        text = html_page(text, f"{result.estimator} on {len(windows)} windows")
    return write_text_atomic(folder / report_name(REPORT_NAME.rsplit(".", 1)[0], fmt), text)


def _first(windows: Windows) -> Flight:
    return windows.flights[0]
