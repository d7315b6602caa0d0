"""What a fit report draws for each output channel: the fit the method made (issue 26).

- **Open-loop** (every other method): the model simulated at the estimate
  (:func:`aeroid.estimation.predict`) **in the air the fit used**: its fitted steady
  wind, or the wind its air data imply, or the reconstruction's
  (:mod:`aeroid.estimation._predict_air`). When that is not still air, the same model in
  still air is a second, dashed trace: the difference is what the wind does.
- **The filter's** (filter-error, the EKF with gust states): the one-step predictions
  before each update, made again from the filtered states the result keeps
  (:mod:`aeroid.report._filter_steps`), and the innovations ``measured - prediction``:
  the residuals the fit check judged. The open-loop simulation at the estimate is the
  second, dashed trace: in turbulence it shows the gusts' effect, not the fit. The UKF
  with gust states (and the EKF with states it does not keep per sample) is drawn
  open-loop, and the report says why in one line.

:func:`fit_view` returns per channel what is drawn, and each trace's residual RMS over the
channel's noise level (about 1 when the trace fits).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aeroid.estimation import EstimationResult, predict
from aeroid.flights import Flight
from aeroid.model import OUTPUT_CHANNELS
from aeroid.report._filter_steps import filter_prediction, has_filter_states, one_step_states

__all__ = ["ChannelView", "FitView", "fit_view", "is_gust_filter", "view_lines"]


@dataclass(frozen=True)
class ChannelView:
    """One channel's drawing: ``model`` at the samples ``index`` (its ``label``), and the
    dashed ``second`` trace at every sample (or None); ``ratio`` and ``second_ratio``: the
    residual RMS over the noise level of each."""

    index: np.ndarray
    model: np.ndarray
    label: str
    second: np.ndarray | None = None
    second_label: str = ""
    ratio: float = float("nan")
    second_ratio: float = float("nan")


@dataclass(frozen=True)
class FitView:
    """What the report draws: ``kind`` ``"open-loop"`` or ``"filter"``; ``channels``;
    ``lines``: what was drawn and why, one line each; ``wind``: ``(wind (n, 3) NED [m/s],
    label)`` drawn beside them, or None (still air)."""

    kind: str
    channels: dict[str, ChannelView]
    lines: list[str] = field(default_factory=list)
    wind: tuple[np.ndarray, str] | None = None


def is_gust_filter(result: EstimationResult) -> bool:
    """Whether ``result`` is a filter with gust states (filter-error, the EKF/UKF with
    gust states): ``info["gust_sd_mps"]``."""
    return "gust_sd_mps" in result.info


def _ratio(residual: np.ndarray, level: float) -> float:
    residual = np.asarray(residual, dtype=float)
    if not (np.isfinite(level) and level > 0) or not np.any(np.isfinite(residual)):
        return float("nan")
    return float(np.sqrt(np.nanmean(residual * residual)) / level)


def fit_view(result: EstimationResult, flight: Flight, prediction: Any,
             levels: Mapping[str, float]) -> FitView:
    """What the report draws for ``result`` (module docstring); ``prediction``: its
    :func:`aeroid.estimation.predict` on ``flight``, ``levels``: each channel's noise sd."""
    n = flight.n_samples
    attrs = prediction.attrs
    air = str(attrs.get("air", "still"))
    label = str(attrs.get("air_label", "in still air"))
    why = ""
    if is_gust_filter(result):
        outputs, why = filter_prediction(result, flight, str(attrs["input"]),
                                         float(attrs["delay_s"]))
        if outputs is not None:
            whole = (has_filter_states(result.info, flight.n_samples)
                     or one_step_states(result.info, flight.n_samples) is not None)
            start = 1 if whole else flight.n_samples // 2  # the EKF's own: the 2nd half
            return _filter_view(result, flight, prediction, outputs, levels, label, start)
    still = None if air == "still" else predict(result, flight, air="still")
    channels: dict[str, ChannelView] = {}
    for name in OUTPUT_CHANNELS:
        measured, model = flight[name], prediction[name].to_numpy()
        second = None if still is None else still[name].to_numpy()
        channels[name] = ChannelView(
            np.arange(n), model, f"model {label}", second,
            "model in still air (for comparison)", _ratio(measured - model, levels[name]),
            float("nan") if second is None else _ratio(measured - second, levels[name]))
    lines = [f"The model is drawn {label}: the air the fit used."]
    if why:
        lines.append(f"Not drawn from the filter: {why}.")
    if still is not None:
        lines.append("Dashed: the same model in still air; the difference is the wind's "
                     "effect.")
    wind = None if air == "still" else (np.asarray(attrs["wind_ned_mps"], dtype=float),
                                        f"wind per sample: the model is drawn {label}")
    if wind is None and why:  # a gust filter drawn open-loop: its gusts beside it
        wind = _filter_wind(result.info, n)
    return FitView("open-loop", channels, lines, wind)


def _filter_wind(info: Mapping[str, Any], n: int) -> tuple[np.ndarray, str] | None:
    wind = info.get("wind_filtered_ned_mps", ())  # filter-error: steady + gusts
    if np.shape(wind) == (n, 3):
        return np.asarray(wind, dtype=float), "the filter's wind (filtered: steady + gusts)"
    gust = info.get("gust_ned_mps", ())  # the EKF's gust states
    if np.shape(gust) == (n, 3):
        return np.asarray(gust, dtype=float), "the filter's gusts (filtered)"
    return None


def _filter_view(result: EstimationResult, flight: Flight, prediction: Any,
                 outputs: np.ndarray, levels: Mapping[str, float], label: str,
                 start: int) -> FitView:
    """The filter's one-step predictions (rows 1..n-1 of ``outputs``) as the drawing; the
    ratio over the samples from ``start`` on (those the fit check read)."""
    n = flight.n_samples
    index = np.arange(1, n)
    judged = index >= start
    channels: dict[str, ChannelView] = {}
    for j, name in enumerate(OUTPUT_CHANNELS):
        measured, open_loop = flight[name], prediction[name].to_numpy()
        model = outputs[index, j]
        channels[name] = ChannelView(
            index, model, "filter's one-step prediction", open_loop,
            f"open-loop model {label} (for comparison)",
            _ratio((measured[index] - model)[judged], levels[name]),
            _ratio(measured - open_loop, levels[name]))
    lines = ["Drawn from the filter: its one-step predictions before each update, made "
             "again from the filtered states the result keeps, and its innovations "
             "(measured minus prediction), the residuals its fit check judged; from the "
             f"second sample (the first is the fit's start); the ratios below over t >= "
             f"{flight.t[max(start, 1)]:g} s" + (" (the fit check also read the first sample)"
                                                 if start <= 1 else ", the samples the "
                                                 "fit check read") + ". Dashed: the "
             f"open-loop simulation at the estimate {label}; in turbulence it shows the "
             "gusts' effect, not the fit."]
    return FitView("filter", channels, lines, _filter_wind(result.info, n))


def _cell(value: float) -> str:
    return "n/a" if not np.isfinite(value) else f"{value:.3g}"


def view_lines(view: FitView) -> list[str]:
    """The report's lines on what is drawn: the view's sentences and, with a second trace,
    each trace's residual RMS over the channel's noise level (markdown table)."""
    lines = [" ".join(view.lines), ""]
    if not any(c.second is not None for c in view.channels.values()):
        return lines
    first = "filter's innovation" if view.kind == "filter" else "model, the fit's air"
    second = "open-loop model" if view.kind == "filter" else "model in still air"
    lines += [f"Residual RMS over the channel's noise level (about 1 when the trace fits): "
              f"{first} (solid) against {second} (dashed).", "",
              f"| channel | {first} | {second} |", "|---|---|---|"]
    lines += [f"| {name} | {_cell(c.ratio)} | {_cell(c.second_ratio)} |"
              for name, c in view.channels.items()]
    return lines + [""]
