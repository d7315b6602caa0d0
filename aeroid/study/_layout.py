"""Fixed layout of the study's figures: margins and gaps in inches, notes wrapped.

matplotlib's constrained layout measures every text of a figure twice and makes
``savefig`` draw it twice; a study's figures hold known texts (titles, tick labels,
notes), so their room is set here from what they hold
(``tests/integration/test_study_figures.py`` checks that nothing overlaps).
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

#: Inches per character of a note at 8 pt (DejaVu Sans averages about 0.07 in): notes
#: under a figure are wrapped to its width with this and the bottom margin grows by a
#: line each.
NOTE_CHAR_IN = 0.075
NOTE_LINE_IN = 0.16
#: Inches per character of an 8 pt tick label (upper bound of DejaVu Sans' average).
TICK_CHAR_IN = 0.075


def grid(rows: int, cols: int, figsize: tuple[float, float], **kwargs: Any
          ) -> tuple[Figure, np.ndarray]:
    """Return a figure on an Agg canvas and its ``rows x cols`` axes (never squeezed)."""
    fig = Figure(figsize=figsize)
    FigureCanvasAgg(fig)
    return fig, fig.subplots(rows, cols, squeeze=False, **kwargs)


def place(fig: Figure, rows: int, cols: int, *, left: float, right: float, top: float,
           bottom: float, wgap: float, hgap: float) -> None:
    """Set the margins and the gaps between panels, all in inches."""
    width, height = fig.get_size_inches()
    panel_w = (width - left - right - (cols - 1) * wgap) / cols
    panel_h = (height - top - bottom - (rows - 1) * hgap) / rows
    fig.subplots_adjust(left=left / width, right=1 - right / width, top=1 - top / height,
                        bottom=bottom / height, wspace=wgap / panel_w, hspace=hgap / panel_h)


def note(fig: Figure, text: str) -> float:
    """Write ``text`` (8 pt) under the figure, wrapped to its width; return its height [in]."""
    width = fig.get_size_inches()[0]
    lines = textwrap.wrap(text, max(20, int((width - 0.4) / NOTE_CHAR_IN)))
    fig.text(0.5, 0.08 / fig.get_size_inches()[1], "\n".join(lines), ha="center",
             va="bottom", fontsize=8)
    return NOTE_LINE_IN * len(lines) + 0.1


def tick_label_height(labels: Sequence[str], rotation_deg: float, char_in: float) -> float:
    """Height [in] below an axis taken by rotated x tick labels (and the ticks)."""
    longest = max((len(line) for lab in labels for line in lab.split("\n")), default=1)
    lines = max((lab.count("\n") + 1 for lab in labels), default=1)
    angle = np.radians(rotation_deg)
    return 0.12 + longest * char_in * np.sin(angle) + 1.6 * char_in * lines * np.cos(angle)


__all__ = ["NOTE_CHAR_IN", "NOTE_LINE_IN", "TICK_CHAR_IN", "grid", "note", "place",
           "tick_label_height"]
