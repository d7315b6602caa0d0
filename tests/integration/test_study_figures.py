"""The study's figures: what they show, and that their fixed layout leaves no overlap.

The figures are laid out with margins in inches (:mod:`aeroid.study._layout`) instead of
matplotlib's constrained layout. These tests read the drawn figures (captured as they
are saved): every panel, title, axis label and plotted run is there, with the data given,
and no panel's box (ticks, tick labels, title, axis labels) runs into another panel's,
into the figure's title or note, or off the figure.
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd
import pytest

from aeroid import nominal
from aeroid.model import NAMES
from aeroid.study import _plots

#: Pixels two boxes may share: a tick's half line width on the common edge.
TOUCH_PX = 1.0


@pytest.fixture
def saved(monkeypatch):
    """Figures as written: the list each plotting call appends its figure to."""
    figures = []
    original = _plots._save

    def spy(fig, path):
        figures.append(fig)
        return original(fig, path)

    monkeypatch.setattr(_plots, "_save", spy)
    return figures


def _overlap(a, b):
    return (min(a.x1, b.x1) - max(a.x0, b.x0) > TOUCH_PX
            and min(a.y1, b.y1) - max(a.y0, b.y0) > TOUCH_PX)


def assert_laid_out(fig):
    """No visible panel overlaps another, the figure's texts, or leaves the figure."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    page = fig.bbox
    boxes = [ax.get_tightbbox(renderer) for ax in fig.axes if ax.get_visible()]
    texts = [t.get_window_extent(renderer) for t in fig.texts if t.get_text()]
    for box in boxes + texts:
        assert box.x0 >= -TOUCH_PX and box.y0 >= -TOUCH_PX, box
        assert box.x1 <= page.x1 + TOUCH_PX and box.y1 <= page.y1 + TOUCH_PX, box
    for a, b in itertools.combinations(boxes, 2):
        assert not _overlap(a, b), (a, b)
    for a, b in itertools.product(boxes, texts):
        assert not _overlap(a, b), (a, b)


def _notes(fig):
    return [t for t in fig.texts if t is not fig._suptitle]


def _visible(fig):
    return [ax for ax in fig.axes if ax.get_visible()]


@pytest.mark.parametrize("axis", ["iteration", "time"])
def test_coefficient_history_shows_each_coefficient_with_its_truth(tmp_path, saved, axis):
    truth = np.array(nominal())
    step = np.arange(40.0) * (0.01 if axis == "time" else 1.0)
    theta = truth * (1.0 + 0.3 * np.exp(-np.arange(40.0) / 5.0))[:, None]
    theta[:4, 8] = truth[8] * 30.0  # far beyond one edge early: marked on the edge
    history = {"axis": axis, "step": step, "theta": theta}
    if axis == "time":
        history["theta_sd"] = np.abs(theta) * 0.05
    _plots.plot_coefficient_history(history, truth, tmp_path / "h.png", title="T")
    (fig,) = saved
    panels = _visible(fig)
    assert [ax.get_title() for ax in panels] == list(NAMES)
    unit = "time [s]" if axis == "time" else "iteration"
    assert [ax.get_xlabel() for ax in panels[-3:]] == [unit] * 3
    for j, ax in enumerate(panels):
        estimate, truth_line = ax.lines[:2]  # then the edge markers, if any
        np.testing.assert_array_equal(estimate.get_xdata(), step)
        np.testing.assert_array_equal(estimate.get_ydata(), theta[:, j])
        assert truth_line.get_ydata()[0] == truth[j]
        assert len(ax.collections) == (1 if axis == "time" else 0)  # the +-1.96 sd band
    assert len(panels[8].lines) == 3  # estimate, truth, the markers above the axis
    assert fig._suptitle.get_text() == "T" and len(_notes(fig)) == 1  # on the markers
    assert_laid_out(fig)


def _tidy(labels, runs, failed=()):
    truth = np.array(nominal())
    rng = np.random.default_rng(3)
    rows = []
    for run, lab in itertools.product(range(runs), labels):
        ok = (run, lab) not in failed
        for j, name in enumerate(NAMES):
            rows.append({"run": run, "noise": "n", "estimator": lab, "coefficient": name,
                         "truth": truth[j], "error": truth[j] * rng.normal(0, 0.5),
                         "success": ok, "wall_time_s": 0.5 + run})
    return pd.DataFrame(rows)


def test_error_figure_plots_every_successful_run_of_every_estimator(tmp_path, saved):
    labels = ["SEBM-PSO", "equation-error", "output-error", "pyswarms"]
    tidy = _tidy(labels, runs=5, failed={(2, "pyswarms")})
    cr = {name: 3.0 for name in NAMES}
    _plots.plot_errors(tidy, tmp_path / "e.png", cr_pct=cr, cr_sample_pct=cr)
    (fig,) = saved
    panels = _visible(fig)
    assert [ax.get_title() for ax in panels] == list(NAMES)
    ticks = [t.get_text() for t in panels[0].get_xticklabels()]
    assert ticks == [*labels[:3], "pyswarms\n(1 failed)"]
    assert [ax.get_ylabel() for ax in panels[::3]] == ["(estimate - truth) / |truth| [%]"] * 3
    for ax in panels:
        strips = [line for line in ax.lines if line.get_marker() == "."]
        assert [len(line.get_xdata()) for line in strips] == [5, 5, 5, 4]
    assert_laid_out(fig)


def test_convergence_forces_and_runtime_figures_keep_their_content(tmp_path, saved):
    steps = np.arange(50.0)
    histories = {lab: {"step": steps, "cost": sign * (1.0 + np.exp(-steps / 9.0))}
                 for lab, sign in (("SEBM-PSO", 1.0), ("EBM-PSO", 1.0),
                                   ("output-error", -1.0), ("pyswarms", 1.0))}
    left_out = {"equation-error": "no iterations (closed form)",
                "EKF": "a filter: estimates against time, no cost iterations",
                "UKF": "a filter: estimates against time, no cost iterations"}
    _plots.plot_convergence(histories, tmp_path / "c.png", left_out=left_out)
    t = np.linspace(0.0, 5.0, 400)
    fm = np.column_stack([np.sin(k * t) * 10.0**k for k in range(6)])
    _plots.plot_forces(t, fm, fm * 0.9, tmp_path / "f.png", fm_true=fm * 1.1)
    labels = ["SEBM-PSO", "EBM-PSO", "equation-error", "output-error", "EKF", "UKF"]
    _plots.plot_runtime(_tidy(labels, runs=3), tmp_path / "r.png")
    convergence, forces, runtime = saved
    panels = _visible(convergence)
    assert [ax.get_title().split("\n")[0] for ax in panels] == list(histories)
    assert [len(ax.lines) for ax in panels] == [1] * 4
    assert panels[0].get_ylabel() == "best cost (own objective)"
    (note,) = _notes(convergence)
    assert all(k in note.get_text().replace("\n", " ") for k in left_out)
    panels = _visible(forces)
    assert [ax.get_title() for ax in panels] == list(_plots.FM_NAMES)
    assert [len(ax.lines) for ax in panels] == [3] * 6  # raw, smoothed, truth
    (ax,) = _visible(runtime)
    assert [t.get_text() for t in ax.get_xticklabels()] == labels
    assert ax.get_ylabel() == "wall time per fit [s]"
    for fig in saved:
        assert_laid_out(fig)
