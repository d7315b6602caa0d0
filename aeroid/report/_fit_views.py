"""What a fit report draws for each output channel: the fit the method made (issue 26).

- **Open-loop** (every method): the model simulated at the estimate
  (:func:`aeroid.estimation.predict`) **in the air the fit used**: its fitted steady
  wind, or the wind its air data imply, or the reconstruction's
  (:mod:`aeroid.estimation._predict_air`). When that is not still air, the same model in
  still air is a second, dashed trace: the difference is what the wind does.

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

__all__ = ["ChannelView", "FitView", "fit_view", "view_lines"]


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
    if still is not None:
        lines.append("Dashed: the same model in still air; the difference is the wind's "
                     "effect.")
    wind = None if air == "still" else (np.asarray(attrs["wind_ned_mps"], dtype=float),
                                        f"wind per sample: the model is drawn {label}")
    return FitView("open-loop", channels, lines, wind)


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
