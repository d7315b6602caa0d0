"""Figures of a study (matplotlib ``Figure`` objects on an Agg canvas, no pyplot; PNG files).

- :func:`plot_convergence` — best cost vs iteration of the PSO-type methods (paper Fig. 4)
- :func:`plot_coefficient_history` — each coefficient vs iteration (PSO) or vs time
  (filters), with the truth (Figs. 5-8, 13-16)
- :func:`plot_forces` — reconstructed and smoothed forces and moments of EBM-type
  methods beside the true aerodynamic ones (Figs. 9-12)
- :func:`plot_errors` — signed relative error per coefficient and estimator with the
  Cramér-Rao band +-1.96 CR sd (in % of the truth)
- :func:`plot_runtime` — wall time per fit and estimator

Every function takes plain arrays/tables, writes one PNG and returns its path.

Layout: margins and gaps are fixed in inches from what each figure holds (its title,
tick labels, notes), not found by matplotlib's constrained layout, which measured every
text twice and drew each figure twice: it was half of a warm quick study's time
(benchmarks/results/first_run.md). ``tests/integration/test_study_figures.py`` checks
that no panel's labels run into another's or off the figure.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib.ticker
import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from aeroid.model import NAMES
from aeroid.study._layout import TICK_CHAR_IN
from aeroid.study._layout import grid as _grid
from aeroid.study._layout import note as _note
from aeroid.study._layout import place as _place
from aeroid.study._layout import tick_label_height as _tick_label_height

FM_NAMES = ("F_AX [N]", "F_AY [N]", "F_AZ [N]", "M_X [N m]", "M_Y [N m]", "M_Z [N m]")
DPI = 110
_PLAIN = matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}")


def _save(fig: Figure, path: str | Path) -> Path:
    """Write ``fig`` as PNG through ``path.tmp`` and a rename: never a truncated PNG."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(tmp, dpi=DPI, format="png")
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    return path


def plot_convergence(histories: Mapping[str, Mapping[str, np.ndarray]], path: str | Path,
                     title: str = "", left_out: Mapping[str, str] | None = None) -> Path:
    """Plot the best cost against iteration, one panel per estimator (paper Fig. 4).

    Each method minimises its own objective, so each panel has its own y axis: log
    scale when every cost is positive; otherwise linear, with a note that the cost is
    known only up to a constant (output-error's negative log-likelihood without its
    constant term is negative: its level means nothing, its decrease does).

    Parameters
    ----------
    histories : mapping of str to dict
        Estimator label -> history with ``step`` (n,) and ``cost`` (n,) (the keys of
        ``EstimationResult.history``).
    path : path-like
        PNG to write.
    left_out : mapping of str to str, optional
        Estimator label -> why it has no panel; listed under the figure.
    """
    n = max(len(histories), 1)
    cols = min(n, 3)
    rows = -(-n // cols)
    fig, axes = _grid(rows, cols, (4.2 * cols, 3.2 * rows + 0.4))
    for ax, (label, h) in zip(axes.flat, histories.items(), strict=False):
        cost = np.asarray(h["cost"], dtype=float).reshape(-1)
        step = np.asarray(h["step"], dtype=float).reshape(-1)
        ok = np.isfinite(cost)
        ax.plot(step[ok], cost[ok], lw=1.6, color="C0")
        if ok.any() and np.all(cost[ok] > 0):
            ax.set_yscale("log")
            ax.yaxis.set_major_formatter(_PLAIN)
            ax.yaxis.set_minor_formatter(_PLAIN)
            ax.set_title(label, fontsize=10)
        else:
            ax.set_title(f"{label}\ncost <= 0: known up to a constant (e.g. a negative\n"
                         "log-likelihood); only its decrease matters", fontsize=8)
        ax.set_xlabel("iteration")
        ax.grid(True, which="both", alpha=0.3)
    for ax in list(axes.flat)[len(histories):]:
        ax.set_visible(False)
    axes[0, 0].set_ylabel("best cost (own objective)")
    note = 0.0
    if left_out:
        text = "; ".join(f"{k}: {v}" for k, v in left_out.items())
        note = _note(fig, "Not shown — " + text)
    fig.suptitle(title or "Convergence of the cost (run 0)")
    # panel titles: up to three lines at 8 pt (the note on a cost known up to a constant)
    _place(fig, rows, cols, left=1.0, right=0.2, top=1.0, bottom=0.6 + note, wgap=0.8,
           hgap=1.2)
    return _save(fig, path)


#: A path whose full range exceeds this many times the range of its second half and
#: the truth is shown on the narrower window, with the points outside marked.
ZOOM_RATIO = 10.0


def _coefficient_grid(figsize: tuple[float, float], **kwargs: Any) -> tuple[Figure, list[Any]]:
    """Return a figure with one panel per coefficient (three columns) and those panels."""
    rows = -(-len(NAMES) // 3)
    fig, axes = _grid(rows, 3, figsize, **kwargs)
    panels = list(axes.flat)
    for ax in panels[len(NAMES):]:
        ax.set_visible(False)
    return fig, panels[:len(NAMES)]


def _keep_in_view(ax: Any, step: np.ndarray, values: np.ndarray, truth: float) -> bool:
    """Set y limits that hold the truth and the path; mark points left outside.

    The whole path is shown unless its early part spans more than :data:`ZOOM_RATIO`
    times the window of the truth and the path's second half; then that window is
    shown and each point outside it is drawn on the edge as a triangle (returns True).
    """
    ok = np.isfinite(values)
    if not ok.any():
        return False
    finite = values[ok]
    tail = finite[len(finite) // 2:]

    def window(v: np.ndarray) -> tuple[float, float]:
        lo, hi = min(v.min(), truth), max(v.max(), truth)
        pad = 0.1 * (hi - lo) + 0.02 * abs(truth) + 1e-12
        return lo - pad, hi + pad

    full, near = window(finite), window(tail)
    lo, hi = full if (full[1] - full[0]) <= ZOOM_RATIO * (near[1] - near[0]) else near
    ax.set_ylim(lo, hi)
    above, below = ok & (values > hi), ok & (values < lo)
    if above.any() or below.any():
        for mask, edge, marker in ((above, hi, "^"), (below, lo, "v")):
            if mask.any():  # an empty unclipped line broke the constrained layout
                (line,) = ax.plot(step[mask], np.full(mask.sum(), edge), marker, color="C3",
                                  ms=5, clip_on=False)
                line.set_in_layout(False)  # drawn on the frame: no room to reserve
        return True
    return False


def plot_coefficient_history(history: Mapping[str, Any], truth: Sequence[float],
                             path: str | Path, title: str = "",
                             names: Sequence[str] = NAMES) -> Path:
    """Plot each coefficient's estimate against iteration or time in a 3 x 3 grid.

    Parameters
    ----------
    history : dict
        ``axis`` ("iteration" or "time"), ``step`` (n,) [-, s], ``theta`` (n, N_COEFFICIENTS)
        and optionally ``theta_sd`` (same shape; shown as a +-1.96 sd band).
    truth : sequence of float, one per coefficient
        True coefficients (dashed line).
    """
    step = np.asarray(history["step"], dtype=float)
    theta = np.asarray(history["theta"], dtype=float).reshape(len(step), -1)
    sd = history.get("theta_sd")
    axis = str(history.get("axis", "iteration"))
    rows = -(-len(NAMES) // 3)
    fig, panels = _coefficient_grid((10, 2.5 * rows), sharex=True)
    clipped = False
    for j, ax in enumerate(panels):
        ax.plot(step, theta[:, j], lw=1.4, color="C0", label="estimate")
        if sd is not None:
            s = np.asarray(sd, dtype=float).reshape(len(step), -1)[:, j]
            ax.fill_between(step, theta[:, j] - 1.96 * s, theta[:, j] + 1.96 * s,
                            color="C0", alpha=0.2, lw=0, label="±1.96 sd")
        ax.axhline(truth[j], color="k", ls="--", lw=1, label="truth")
        clipped |= _keep_in_view(ax, step, theta[:, j], truth[j])
        ax.set_title(names[j], fontsize=10)
        ax.grid(True, alpha=0.3)
        if j >= len(panels) - 3:
            ax.set_xlabel("time [s]" if axis == "time" else "iteration")
    panels[0].legend(fontsize=7)
    note = 0.0
    if clipped:
        note = _note(fig, "▲ ▼ mark estimates beyond the axis (early iterations far from "
                     "the truth); the axis keeps the truth and the converged part in view")
    fig.suptitle(title or "Coefficient estimates (run 0)")
    # shared x: only the bottom row has tick labels; a gap holds a title and an offset
    _place(fig, rows, 3, left=0.85, right=0.2, top=0.6, bottom=0.55 + note, wgap=0.8,
           hgap=0.5)
    return _save(fig, path)


def plot_forces(t: np.ndarray, fm_raw: np.ndarray, fm_smooth: np.ndarray | None,
                path: str | Path, fm_true: np.ndarray | None = None, title: str = "") -> Path:
    """Plot reconstructed (raw), smoothed and true forces and moments (2 x 3 grid).

    Parameters
    ----------
    t : ndarray, shape (n,)
        Time [s].
    fm_raw, fm_smooth, fm_true : ndarray, shape (n, 6)
        ``[F_AX, F_AY, F_AZ, M_X, M_Y, M_Z]`` [N, N m]; ``fm_smooth`` and ``fm_true`` optional.
    """
    t = np.asarray(t, dtype=float)
    fig, axes = _grid(2, 3, (11, 6), sharex=True)
    for j, ax in enumerate(axes.flat):
        ax.plot(t, np.asarray(fm_raw)[:, j], color="0.6", lw=0.7, label="reconstructed")
        if fm_smooth is not None:
            ax.plot(t, np.asarray(fm_smooth)[:, j], color="C0", lw=1.3, label="smoothed (SG)")
        if fm_true is not None:
            ax.plot(t, np.asarray(fm_true)[:, j], color="k", ls="--", lw=1, label="truth")
        ax.set_title(FM_NAMES[j], fontsize=10)
        ax.grid(True, alpha=0.3)
        if j >= 3:
            ax.set_xlabel("time [s]")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(title or "Reconstructed forces and moments (run 0)")
    _place(fig, 2, 3, left=0.85, right=0.2, top=0.6, bottom=0.55, wgap=0.8, hgap=0.5)
    return _save(fig, path)


#: Relative errors beyond this [%] are drawn on the edge of the axis (triangles), so
#: that one absurd estimate (1e300) does not stretch the axis over 300 decades.
CLIP_PCT = 1e6
#: Panels whose errors and Cramér-Rao band stay within this [%] get a linear axis.
LINEAR_UP_TO_PCT = 10.0


def _tick_label(v: float) -> str:
    if v == 0:
        return "0"
    return f"{v:g}" if abs(v) < 1e4 else f"{'-' if v < 0 else ''}1e{round(np.log10(abs(v)))}"


def _error_axis(ax: Any, lo: float, hi: float) -> None:
    """Linear axis for small errors; otherwise symmetric-log with ticks 0, +-1, +-10, ..."""
    if max(abs(lo), abs(hi)) <= LINEAR_UP_TO_PCT:
        ax.set_ylim(lo, hi)
        ax.yaxis.set_major_locator(matplotlib.ticker.MaxNLocator(6))
        ax.yaxis.set_major_formatter(_PLAIN)
        return
    ax.set_yscale("symlog", linthresh=1.0)

    def decade(v: float) -> float:  # round away from zero to a power of ten (or +-1)
        return float(np.sign(v) * 10.0 ** np.ceil(np.log10(abs(v)))) if abs(v) > 1 else v

    lo, hi = decade(min(lo, -0.5)), decade(max(hi, 0.5))
    ax.set_ylim(lo * 1.3 if lo < -1 else lo - 0.3, hi * 1.3 if hi > 1 else hi + 0.3)
    top = int(np.ceil(np.log10(max(abs(lo), abs(hi), 1.0))))
    ticks = [0.0] + [s * 10.0**k for k in range(top + 1) for s in (-1, 1)]
    ticks = sorted(t for t in ticks if lo <= t <= hi)
    if len(ticks) > 9:  # every other decade
        ticks = [t for t in ticks if t == 0 or round(np.log10(abs(t))) % 2 == top % 2]
    ax.yaxis.set_major_locator(matplotlib.ticker.FixedLocator(ticks))
    ax.yaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: _tick_label(v)))
    ax.yaxis.set_minor_locator(matplotlib.ticker.NullLocator())


def plot_errors(tidy: pd.DataFrame, path: str | Path,
                cr_pct: Mapping[str, float] | None = None, title: str = "",
                names: Sequence[str] = NAMES,
                cr_sample_pct: Mapping[str, float] | None = None) -> Path:
    """Box-and-strip plot of the signed relative error [%] per coefficient and estimator.

    Parameters
    ----------
    tidy : pandas.DataFrame
        Rows of one noise condition from :func:`aeroid.study.tidy` (successful
        fits are plotted; the x labels count the failed ones left out).
    cr_pct : mapping of str to float, optional
        Coefficient -> Cramér-Rao sd in % of |truth|; drawn as the band +-1.96 of it.
    cr_sample_pct : mapping of str to float, optional
        Coefficient -> the per-sample Cramér-Rao sd in % of |truth|; a darker band.

    Notes
    -----
    Panels whose errors stay within +-:data:`LINEAR_UP_TO_PCT` % are linear; the others
    are symmetric-log (linear within +-1 %) with ticks at 0, +-1, +-10, ... %, since
    errors of different methods span several decades on the same coefficient. Errors
    beyond +-:data:`CLIP_PCT` % are drawn on the edge as triangles.
    """
    good = tidy[tidy["success"] & np.isfinite(tidy["error"])]
    labels = list(dict.fromkeys(tidy["estimator"]))
    fits = tidy.drop_duplicates(["run", "estimator"])
    failed = {lab: int((~fits.loc[fits["estimator"] == lab, "success"]).sum())
              for lab in labels}
    ticks = [lab + (f"\n({failed[lab]} failed)" if failed[lab] else "") for lab in labels]
    n_rows = -(-len(NAMES) // 3)
    fig, panels = _coefficient_grid((12, 3 * n_rows))
    rng = np.random.default_rng(0)  # horizontal jitter of the strip only
    n_clipped = 0
    for j, ax in enumerate(panels):
        name = names[j]
        rows = good[good["coefficient"] == name]
        data = []
        for lab in labels:
            sel = rows[rows["estimator"] == lab]
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                pct = 100.0 * (sel["error"] / sel["truth"].abs()).to_numpy(dtype=float)
            pct = pct[~np.isnan(pct)]
            n_clipped += int(np.sum(np.abs(pct) > CLIP_PCT))
            data.append(np.clip(pct, -CLIP_PCT, CLIP_PCT))
        band = np.nan
        if cr_pct is not None and np.isfinite(cr_pct.get(name, np.nan)):
            band = 1.96 * cr_pct[name]
            ax.axhspan(-band, band, color="C2", alpha=0.25, lw=0,
                       label="±1.96 Cramér-Rao sd" + (" (per-channel)" if cr_sample_pct
                                                       else ""))
        if cr_sample_pct is not None and np.isfinite(cr_sample_pct.get(name, np.nan)):
            inner = 1.96 * cr_sample_pct[name]
            ax.axhspan(-inner, inner, color="C2", alpha=0.45, lw=0,
                       label="±1.96 Cramér-Rao sd (per-sample)")
        positions = np.arange(1, len(labels) + 1)
        nonempty = [k for k, d in enumerate(data) if len(d)]
        if nonempty:
            ax.boxplot([data[k] for k in nonempty], positions=positions[nonempty],
                       widths=0.6, showfliers=False, medianprops={"color": "C3"})
            for k in nonempty:
                x = positions[k] + rng.uniform(-0.15, 0.15, len(data[k]))
                edge = np.abs(data[k]) >= CLIP_PCT
                ax.plot(x[~edge], data[k][~edge], ".", ms=3, alpha=0.5, color="C0")
                up = edge & (data[k] > 0)
                ax.plot(x[up], data[k][up], "^", ms=5, color="C3")
                ax.plot(x[edge & ~up], data[k][edge & ~up], "v", ms=5, color="C3")
        values = np.concatenate([*data, [0.0]] + ([[-band, band]] if np.isfinite(band) else []))
        lo, hi = float(values.min()), float(values.max())
        pad = 0.08 * (hi - lo) + 1e-9
        _error_axis(ax, lo - pad, hi + pad)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_xticks(positions, ticks, rotation=35, ha="right", fontsize=7)
        ax.set_xlim(0.4, len(labels) + 0.6)
        ax.set_title(name, fontsize=10)
        ax.grid(True, axis="y", alpha=0.3)
        if j % 3 == 0:
            ax.set_ylabel("(estimate - truth) / |truth| [%]")
    handles, texts = panels[0].get_legend_handles_labels()
    if handles:
        panels[0].legend(handles, texts, fontsize=7, loc="upper left")
    note = 0.0
    if n_clipped:
        note = _note(fig, f"▲ ▼ {n_clipped} error(s) beyond ±{_tick_label(CLIP_PCT)} % drawn "
                     "on the edge")
    fig.suptitle(title or "Relative error per coefficient (successful fits)")
    below = _tick_label_height(ticks, 35.0, TICK_CHAR_IN * 7 / 8)  # 7 pt labels
    _place(fig, n_rows, 3, left=1.0, right=0.2, top=0.6, bottom=below + 0.1 + note, wgap=0.8,
           hgap=below + 0.35)
    return _save(fig, path)


def plot_runtime(tidy: pd.DataFrame, path: str | Path, title: str = "") -> Path:
    """Box plot of wall time per fit [s] for each estimator (all noise conditions).

    Parameters
    ----------
    tidy : pandas.DataFrame
        From :func:`aeroid.study.tidy` (one value per fit is used).
    """
    fits = tidy.drop_duplicates(["run", "noise", "estimator"])
    labels = list(dict.fromkeys(fits["estimator"]))
    data = [fits.loc[fits["estimator"] == lab, "wall_time_s"].dropna().to_numpy()
            for lab in labels]
    fig, axes = _grid(1, 1, (max(5.0, 1.1 * len(labels) + 2), 4.0))
    ax = axes[0, 0]
    positions = np.arange(1, len(labels) + 1)
    keep = [k for k, d in enumerate(data) if len(d)]
    if keep:
        ax.boxplot([data[k] for k in keep], positions=positions[keep], widths=0.6,
                   medianprops={"color": "C3"})
    ax.set_xticks(positions, labels, rotation=30, ha="right", fontsize=8)
    ax.set_xlim(0.4, len(labels) + 0.6)
    if any(len(d) and np.all(d > 0) for d in data):
        ax.set_yscale("log")
        ax.yaxis.set_major_formatter(_PLAIN)
        ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_ylabel("wall time per fit [s]")
    ax.grid(True, axis="y", which="both", alpha=0.3)
    ax.set_title(title or "Run time per fit")
    _place(fig, 1, 1, left=0.85, right=0.2, top=0.4,
           bottom=_tick_label_height(labels, 30.0, TICK_CHAR_IN) + 0.1, wgap=0.0, hgap=0.0)
    return _save(fig, path)


__all__ = ["plot_coefficient_history", "plot_convergence", "plot_errors", "plot_forces",
           "plot_runtime"]
