"""Figures of a study (matplotlib, Agg backend; PNG files).

- :func:`plot_convergence` — best cost vs iteration of the PSO-type methods (paper Fig. 4)
- :func:`plot_coefficient_history` — each coefficient vs iteration (PSO) or vs time
  (filters), with the truth (Figs. 5-8, 13-16)
- :func:`plot_forces` — reconstructed and smoothed forces and moments of EBM-type
  methods beside the true aerodynamic ones (Figs. 9-12)
- :func:`plot_errors` — signed relative error per coefficient and estimator with the
  Cramér-Rao band +-1.96 CR sd (in % of the truth)
- :func:`plot_runtime` — wall time per fit and estimator

Every function takes plain arrays/tables, writes one PNG and returns its path.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from aeroid.model._coefficients import NAMES  # noqa: E402

FM_NAMES = ("F_AX [N]", "F_AY [N]", "F_AZ [N]", "M_X [N m]", "M_Y [N m]", "M_Z [N m]")
DPI = 110
_PLAIN = matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}")


def _save(fig: Any, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def plot_convergence(histories: Mapping[str, Mapping[str, np.ndarray]], path: str | Path,
                     title: str = "") -> Path:
    """Plot the best cost against iteration, one panel per estimator (paper Fig. 4).

    Each method minimises its own objective, so each panel has its own y axis (log
    scale when every cost is positive).

    Parameters
    ----------
    histories : mapping of str to dict
        Estimator label -> history with ``step`` (n,) and ``cost`` (n,) (the keys of
        ``EstimationResult.history``).
    path : path-like
        PNG to write.
    """
    n = max(len(histories), 1)
    cols = min(n, 3)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.2 * rows), squeeze=False,
                             layout="constrained")
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
        ax.set_xlabel("iteration")
        ax.grid(True, which="both", alpha=0.3)
    for ax in list(axes.flat)[len(histories):]:
        ax.set_visible(False)
    axes[0, 0].set_ylabel("best cost (own objective)")
    fig.suptitle(title or "Convergence of the cost (run 0)")
    return _save(fig, path)


def plot_coefficient_history(history: Mapping[str, Any], truth: Sequence[float],
                             path: str | Path, title: str = "",
                             names: Sequence[str] = NAMES) -> Path:
    """Plot each coefficient's estimate against iteration or time in a 3 x 3 grid.

    Parameters
    ----------
    history : dict
        ``axis`` ("iteration" or "time"), ``step`` (n,) [-, s], ``theta`` (n, 9) and
        optionally ``theta_sd`` (n, 9) (shown as a +-1.96 sd band).
    truth : sequence of 9 float
        True coefficients (dashed line).
    """
    step = np.asarray(history["step"], dtype=float)
    theta = np.asarray(history["theta"], dtype=float).reshape(len(step), -1)
    sd = history.get("theta_sd")
    axis = str(history.get("axis", "iteration"))
    fig, axes = plt.subplots(3, 3, figsize=(10, 7.5), sharex=True, layout="constrained")
    for j, ax in enumerate(axes.flat):
        ax.plot(step, theta[:, j], lw=1.4, color="C0", label="estimate")
        if sd is not None:
            s = np.asarray(sd, dtype=float).reshape(len(step), -1)[:, j]
            ax.fill_between(step, theta[:, j] - 1.96 * s, theta[:, j] + 1.96 * s,
                            color="C0", alpha=0.2, lw=0, label="±1.96 sd")
        ax.axhline(truth[j], color="k", ls="--", lw=1, label="truth")
        finite = theta[np.isfinite(theta[:, j]), j]
        if finite.size:  # keep the truth and the last half of the path in view
            tail = finite[len(finite) // 2:]
            lo, hi = min(tail.min(), truth[j]), max(tail.max(), truth[j])
            pad = 0.15 * (hi - lo) + 0.02 * abs(truth[j]) + 1e-12
            ax.set_ylim(lo - pad, hi + pad)
        ax.set_title(names[j], fontsize=10)
        ax.grid(True, alpha=0.3)
        if j >= 6:
            ax.set_xlabel("time [s]" if axis == "time" else "iteration")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(title or "Coefficient estimates (run 0)")
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
    fig, axes = plt.subplots(2, 3, figsize=(11, 6), sharex=True, layout="constrained")
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
    return _save(fig, path)


def plot_errors(tidy: pd.DataFrame, path: str | Path,
                cr_pct: Mapping[str, float] | None = None, title: str = "",
                names: Sequence[str] = NAMES) -> Path:
    """Box-and-strip plot of the signed relative error [%] per coefficient and estimator.

    Parameters
    ----------
    tidy : pandas.DataFrame
        Rows of one noise condition from :func:`aeroid.study.tidy` (successful
        fits are plotted).
    cr_pct : mapping of str to float, optional
        Coefficient -> Cramér-Rao sd in % of |truth|; drawn as the band +-1.96 of it.

    Notes
    -----
    The y axis is symmetric-log (linear within +-1 %), since errors of different
    methods span several decades on the same coefficient.
    """
    good = tidy[tidy["success"] & np.isfinite(tidy["error"])]
    labels = list(dict.fromkeys(tidy["estimator"]))
    fig, axes = plt.subplots(3, 3, figsize=(12, 9), layout="constrained")
    rng = np.random.default_rng(0)  # horizontal jitter of the strip only
    for j, ax in enumerate(axes.flat):
        name = names[j]
        rows = good[good["coefficient"] == name]
        data = [100.0 * (rows.loc[rows["estimator"] == lab, "error"]
                         / rows.loc[rows["estimator"] == lab, "truth"].abs()).to_numpy()
                for lab in labels]
        if cr_pct is not None and np.isfinite(cr_pct.get(name, np.nan)):
            band = 1.96 * cr_pct[name]
            ax.axhspan(-band, band, color="C2", alpha=0.25, lw=0,
                       label="±1.96 Cramér-Rao sd")
        positions = np.arange(1, len(labels) + 1)
        nonempty = [k for k, d in enumerate(data) if len(d)]
        if nonempty:
            ax.boxplot([data[k] for k in nonempty], positions=positions[nonempty],
                       widths=0.6, showfliers=False, medianprops={"color": "C3"})
            for k in nonempty:
                x = positions[k] + rng.uniform(-0.15, 0.15, len(data[k]))
                ax.plot(x, data[k], ".", ms=3, alpha=0.5, color="C0")
        ax.axhline(0, color="k", lw=0.8)
        ax.set_yscale("symlog", linthresh=1.0)
        ax.yaxis.set_major_formatter(_PLAIN)
        ax.margins(y=0.08)
        ax.set_xticks(positions, labels, rotation=35, ha="right", fontsize=7)
        ax.set_xlim(0.4, len(labels) + 0.6)
        ax.set_title(name, fontsize=10)
        ax.grid(True, axis="y", alpha=0.3)
        if j % 3 == 0:
            ax.set_ylabel("(estimate - truth) / |truth| [%]")
    handles, texts = axes.flat[0].get_legend_handles_labels()
    if handles:
        axes.flat[0].legend(handles, texts, fontsize=7, loc="upper left")
    fig.suptitle(title or "Relative error per coefficient (successful fits)")
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
    fig, ax = plt.subplots(figsize=(max(5.0, 1.1 * len(labels) + 2), 4), layout="constrained")
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
    return _save(fig, path)


__all__ = ["plot_coefficient_history", "plot_convergence", "plot_errors", "plot_forces",
           "plot_runtime"]
