"""The figures of a fit report (matplotlib ``Figure`` objects, no pyplot state).

Each builder takes what it plots and returns a :class:`matplotlib.figure.Figure` whose
axes name their channel and unit, so a test (or a notebook) can read them; writing is
:func:`aeroid.report.write_report`'s job.

- :func:`channel_figure`: one output channel, measured and model (top), and the residual
  with the band of +-2 noise sd (bottom);
- :func:`autocorrelation_figure`: the residual's autocorrelation of every channel, with
  the +-1.96/sqrt(n) band of white noise;
- :func:`deflection_figure`: the logged deflection and the one the fit's model used
  (its input between samples and its delay);
- :func:`wind_figure`: the wind the model is drawn in, or the filter's wind, per sample;
- :func:`correlation_figure`: the estimates' correlation matrix.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure

#: Dots per inch of the written PNGs.
DPI = 110
#: The noise band drawn around a residual: +- this many noise sd (95 % of Gaussian noise).
BAND_SD = 2.0
#: Lags of the residual autocorrelation shown [samples]: far beyond a white residual's
#: one lag, short enough to see the structure of a model error.
MAX_LAG = 100
#: The 95 % band of a white residual's autocorrelation is +- this over sqrt(n).
WHITE_Z = 1.96


def channel_figure(name: str, unit: str, t: np.ndarray, measured: np.ndarray,
                   model: np.ndarray, noise_sd: float | None, *, model_label: str = "model",
                   index: np.ndarray | None = None, second: np.ndarray | None = None,
                   second_label: str = "") -> Figure:
    """Measured and model output of one channel, and the residual with its noise band.

    Parameters
    ----------
    name, unit : str
        The channel (``"ax1"``) and its unit (``"m/s^2"``), shown on both y axes.
    t : ndarray, shape (n,)
        Time [s].
    measured, model : ndarray, shape (n,)
        The logged channel and the model's prediction (:meth:`EstimationResult.predict`).
    noise_sd : float or None
        The channel's noise level (the fit check's); the band is +- :data:`BAND_SD` of it.
    model_label : str
        What the model line is (the legend: ``"model in still air"``, ``"filter's one-step
        prediction"``).
    index : ndarray of int, optional
        The samples ``model`` is given at (default all).
    second, second_label : ndarray, shape (n,), and str, optional
        A second model trace at every sample, dashed, and its legend (no residual drawn).
    """
    index = np.arange(np.size(t)) if index is None else np.asarray(index)
    fig = Figure(figsize=(8.0, 5.0))
    fig.subplots_adjust(left=0.12, right=0.97, top=0.93, bottom=0.1, hspace=0.3)
    top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=(3, 2))
    top.plot(t, measured, ".", ms=2.5, color="0.45", label="measured")
    top.plot(t[index], model, "-", lw=1.2, color="C0", label=model_label)
    if second is not None:
        top.plot(t, second, "--", lw=0.9, color="C1", label=second_label)
    top.legend(loc="best", fontsize="x-small")
    top.set_ylabel(f"{name} [{unit}]")
    top.set_title(f"{name} [{unit}]: measured (grey dots) and {model_label} (blue line)",
                  fontsize="medium" if model_label == "model" else "small")
    residual = measured[index] - model
    bottom.plot(t[index], residual, "-", lw=0.8, color="C3")
    band = ""
    if noise_sd is not None and np.isfinite(noise_sd):
        bottom.axhspan(-BAND_SD * noise_sd, BAND_SD * noise_sd, color="C2", alpha=0.2)
        band = f"; green: +-{BAND_SD:g} noise sd ({noise_sd:.3g} {unit})"
    bottom.axhline(0.0, color="0.3", lw=0.6)
    what = "innovation" if "one-step" in model_label else "residual"
    bottom.set_title(f"{what} (measured - {model_label}){band}", fontsize="small")
    bottom.set_ylabel(f"{name} residual [{unit}]")
    bottom.set_xlabel("t [s]")
    return fig


def autocorrelation(residual: np.ndarray, max_lag: int = MAX_LAG) -> np.ndarray:
    """The sample autocorrelation of ``residual`` (mean removed), lags 0..max_lag."""
    x = np.asarray(residual, dtype=float)
    x = x[np.isfinite(x)]
    x = x - x.mean()
    n = x.size
    lags = min(max_lag, n - 1)
    denom = float(np.dot(x, x))
    if n < 2 or denom == 0.0:
        return np.full(lags + 1, np.nan)
    full = np.correlate(x, x, mode="full")[n - 1:n + lags]
    return full / denom


def autocorrelation_figure(residuals: Mapping[str, np.ndarray], dt: float,
                           max_lag: int = MAX_LAG) -> Figure:
    """The residual autocorrelation of every channel against lag [s], with the white band."""
    names = list(residuals)
    cols = 3
    rows = max(1, -(-len(names) // cols))
    fig = Figure(figsize=(10.0, 2.3 * rows + 0.6))
    height = 2.3 * rows + 0.6
    fig.subplots_adjust(left=0.08, right=0.98, top=1 - 0.8 / height, bottom=0.5 / height,
                        hspace=0.35, wspace=0.12)
    axes = np.atleast_1d(fig.subplots(rows, cols, sharex=True, sharey=True)).ravel()
    for k, (ax, name) in enumerate(zip(axes, names, strict=False)):
        rho = autocorrelation(residuals[name], max_lag)
        n = int(np.sum(np.isfinite(residuals[name])))
        lag = np.arange(rho.size) * dt
        ax.vlines(lag, 0.0, rho, color="C0", lw=0.8)
        band = WHITE_Z / np.sqrt(max(n, 1))
        ax.axhspan(-band, band, color="C2", alpha=0.25)
        ax.axhline(0.0, color="0.3", lw=0.6)
        ax.set_title(f"{name} residual", fontsize="medium")
        if k % cols == 0:
            ax.set_ylabel("autocorrelation [-]")
        if k >= len(names) - cols:
            ax.set_xlabel("lag [s]")
    for ax in axes[len(names):]:
        ax.set_visible(False)
    fig.suptitle(f"Residual autocorrelation (band: white noise, +-{WHITE_Z}/sqrt(n))")
    return fig


def deflection_figure(t: np.ndarray, delta: np.ndarray, knot_t: np.ndarray,
                      knot_delta: np.ndarray, label: str) -> Figure:
    """The logged deflection (samples) and the model's (the knots of its schedule) [deg]."""
    fig = Figure(figsize=(8.0, 3.6))
    fig.subplots_adjust(left=0.1, right=0.97, top=0.9, bottom=0.27)
    ax = fig.subplots()
    ax.plot(t, np.degrees(delta), ".", ms=3, color="0.45", label="logged delta")
    ax.plot(knot_t, np.degrees(knot_delta), "-", lw=1.0, color="C1", label=label)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("delta [deg]")
    ax.set_title("delta [deg]: fin deflection logged and used by the model")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2, fontsize="small")
    return fig


def wind_figure(t: np.ndarray, wind: np.ndarray, label: str) -> Figure:
    """The wind per sample, north, east and down [m/s] (``wind`` shape (n, 3))."""
    fig = Figure(figsize=(8.0, 3.6))
    fig.subplots_adjust(left=0.1, right=0.97, top=0.9, bottom=0.27)
    ax = fig.subplots()
    for j, axis in enumerate(("north", "east", "down")):
        ax.plot(t, np.asarray(wind)[:, j], "-", lw=1.0, color=f"C{j}", label=f"wind {axis}")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("wind [m/s]")
    ax.set_title(f"wind [m/s], NED: {label}", fontsize="small")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=3, fontsize="small")
    return fig


def correlation_figure(matrix: np.ndarray, names: Sequence[str]) -> Figure:
    """The estimates' correlation matrix, each cell annotated."""
    matrix = np.asarray(matrix, dtype=float)
    fig = Figure(figsize=(6.4, 5.4))
    fig.subplots_adjust(left=0.12, right=0.98, top=0.93, bottom=0.1)
    ax = fig.subplots()
    image = ax.imshow(matrix, vmin=-1.0, vmax=1.0, cmap="RdBu_r")
    ticks = np.arange(len(names))
    ax.set_xticks(ticks, list(names), rotation=45)
    ax.set_yticks(ticks, list(names))
    for i in range(matrix.shape[0]):
        for j in range(matrix.shape[1]):
            if np.isfinite(matrix[i, j]):
                ax.text(j, i, f"{matrix[i, j]:.2f}", ha="center", va="center",
                        fontsize=7, color="white" if abs(matrix[i, j]) > 0.6 else "black")
    fig.colorbar(image, ax=ax, label="correlation [-]")
    ax.set_title("Correlation of the estimates [-]")
    return fig
