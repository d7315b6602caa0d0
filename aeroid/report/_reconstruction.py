"""The report of a flight-path reconstruction: markdown and PNG figures.

``aeroid reconstruct LOG -o OUT --report DIR`` writes ``DIR/reconstruction.md`` and:

- ``innovations_SOURCE.png``: each aiding source's innovations (measured - predicted,
  one panel per channel, in its SI unit) against the band of +- :data:`BAND_SD` times
  their predicted sd (the filter's ``sqrt(S)``): a consistent source stays inside it
  about 95 % of the time;
- ``states_velocity.png``, ``states_attitude.png``, ``states_position.png``: each state
  with its smoothed +- :data:`BAND_SD` sd band (left) and that sd (right);
- ``instrument_errors.png``: the accelerometer and gyro biases and the scale factors,
  each with +- :data:`BAND_SD` sd.

Every axis names its channel and unit (a test reads them).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from aeroid.flights import SI_UNITS
from aeroid.reconstruction import STATES, Reconstruction
from aeroid.report._figures import BAND_SD, DPI
from aeroid.report._files import make_directory, write_figure_atomic, write_text_atomic

#: The report's file name in its folder.
RECONSTRUCTION_REPORT = "reconstruction.md"
#: The state figures (stem -> states) and each state's unit.
STATE_FIGURES: dict[str, tuple[str, ...]] = {
    "states_velocity": ("u", "v", "w"),
    "states_attitude": ("phi", "theta", "psi"),
    "states_position": ("pn", "pe", "pd", "alt0"),
}
STATE_UNITS: dict[str, str] = {"u": "m/s", "v": "m/s", "w": "m/s", "phi": "rad",
                               "theta": "rad", "psi": "rad", "pn": "m", "pe": "m", "pd": "m",
                               "alt0": "m"}
#: The instrument errors: panel title -> (state-name prefix, unit).
INSTRUMENT_PANELS: dict[str, tuple[tuple[str, ...], str]] = {
    "accelerometer biases": (("bax1", "bay1", "baz1", "bax2", "bay2", "baz2"), "m/s^2"),
    "gyro biases": (("bp", "bq", "br"), "rad/s"),
    "scale factors": (("sax1", "say1", "saz1", "sax2", "say2", "saz2", "sp", "sq", "sr"),
                      "-"),
}


def innovation_figure(source: str, table: pd.DataFrame) -> Figure:
    """One aiding source's innovations against +- BAND_SD predicted sd, a panel a channel.

    Parameters
    ----------
    source : str
        The aiding source (``"gnss"``).
    table : pandas.DataFrame
        :attr:`Reconstruction.innovation_tables` ``[source]``: ``t``, each channel and its
        ``sd_CHANNEL`` (SI).
    """
    channels = [c for c in table.columns if c != "t" and not c.startswith("sd_")]
    fig = Figure(figsize=(8.0, 1.2 + 1.8 * len(channels)), layout="constrained")
    axes = np.atleast_1d(fig.subplots(len(channels), 1, sharex=True))
    t = table["t"].to_numpy()
    for ax, channel in zip(axes, channels, strict=True):
        unit = SI_UNITS[channel]
        nu, sd = table[channel].to_numpy(), table[f"sd_{channel}"].to_numpy()
        ax.fill_between(t, -BAND_SD * sd, BAND_SD * sd, color="C2", alpha=0.25, lw=0)
        ax.plot(t, nu, ".", ms=3, color="C3")
        ax.axhline(0.0, color="0.3", lw=0.6)
        inside = np.mean(np.abs(nu[np.isfinite(nu)]) <= BAND_SD * sd[np.isfinite(nu)])
        ax.set_title(f"{source} {channel} innovation [{unit}]: {inside:.0%} inside "
                     f"+-{BAND_SD:g} sd (green)", fontsize="medium")
        ax.set_ylabel(f"{channel} [{unit}]")
    axes[-1].set_xlabel("t [s]")
    return fig


def state_figure(rec: Reconstruction, names: Sequence[str]) -> Figure:
    """The states ``names`` with their +- BAND_SD sd band (left) and their sd (right)."""
    table = rec.table
    t = table["t"].to_numpy()
    fig = Figure(figsize=(10.0, 1.2 + 2.0 * len(names)), layout="constrained")
    axes = np.atleast_2d(fig.subplots(len(names), 2, sharex=True))
    for (left, right), name in zip(axes, names, strict=True):
        unit = STATE_UNITS[name]
        x, sd = table[name].to_numpy(), table[f"sd_{name}"].to_numpy()
        left.fill_between(t, x - BAND_SD * sd, x + BAND_SD * sd, color="C2", alpha=0.35, lw=0)
        left.plot(t, x, "-", lw=0.9, color="C0")
        left.set_ylabel(f"{name} [{unit}]")
        left.set_title(f"{name} [{unit}], +-{BAND_SD:g} sd band (green)", fontsize="medium")
        right.plot(t, sd, "-", lw=0.9, color="C1")
        right.set_ylabel(f"sd {name} [{unit}]")
        right.set_title(f"smoothed sd of {name} [{unit}]", fontsize="medium")
    axes[-1, 0].set_xlabel("t [s]")
    axes[-1, 1].set_xlabel("t [s]")
    return fig


def instrument_figure(rec: Reconstruction) -> Figure:
    """The biases and scale factors (constant states: the first sample's smoothed value)."""
    first = rec.table.iloc[0]
    fig = Figure(figsize=(8.0, 8.0), layout="constrained")
    axes = fig.subplots(len(INSTRUMENT_PANELS), 1)
    for ax, (title, (names, unit)) in zip(axes, INSTRUMENT_PANELS.items(), strict=True):
        values = np.array([first[n] for n in names])
        sd = np.array([first[f"sd_{n}"] for n in names])
        ax.errorbar(np.arange(len(names)), values, yerr=BAND_SD * sd, fmt="o", color="C0",
                    capsize=3)
        ax.axhline(0.0, color="0.3", lw=0.6)
        ax.set_xticks(np.arange(len(names)), names)
        ax.set_ylabel(f"{title} [{unit}]")
        ax.set_title(f"{title} [{unit}]: estimate +-{BAND_SD:g} sd", fontsize="medium")
    return fig


def reconstruction_figures(rec: Reconstruction) -> dict[str, Figure]:
    """Return every figure of the report by file stem (module docstring)."""
    figures = {f"innovations_{source}": innovation_figure(source, table)
               for source, table in rec.innovation_tables.items()}
    figures.update({stem: state_figure(rec, names) for stem, names in STATE_FIGURES.items()})
    figures["instrument_errors"] = instrument_figure(rec)
    return figures


def reconstruction_markdown(rec: Reconstruction, stems: Sequence[str]) -> str:
    """Return the report's markdown: residual check, instrument errors, notes, figures."""
    source = rec.metadata.get("source", "suite log")
    table = rec.table
    lines = [f"# Flight-path reconstruction of {source}", "",
             f"{len(table)} IMU samples, t = {table['t'].iloc[0]:.6g} to "
             f"{table['t'].iloc[-1]:.6g} s; {rec.metadata.get('reconstruction', '')}.", "",
             "## Residual check (innovations against their predicted sd)", "",
             "| source | mean NIS per dof | updates | chi-square interval | verdict |",
             "|---|---|---|---|---|"]
    for name, stats in rec.nis.items():
        low, high = stats["interval"]
        verdict = "consistent" if stats["consistent"] else "**NOT consistent**"
        lines.append(f"| {name} | {stats['mean_nis_per_dof']:.3f} | {stats['n_updates']} | "
                     f"{low:.2f}-{high:.2f} | {verdict} |")
    lines += ["", "## Instrument errors (first sample, smoothed)", "",
              "| error | estimate | sd | unit |", "|---|---|---|---|"]
    first = table.iloc[0]
    for names, unit in INSTRUMENT_PANELS.values():
        lines += [f"| {n} | {first[n]:.4g} | {first[f'sd_{n}']:.2g} | {unit} |" for n in names]
    lines += ["", "## Largest sd of each state", "", "| state | max sd | unit |",
              "|---|---|---|"]
    lines += [f"| {n} | {table[f'sd_{n}'].max():.3g} | {STATE_UNITS[n]} |"
              for n in STATES if n in STATE_UNITS]
    lines += ["", "## Notes", "", *[f"- {note}" for note in rec.notes], "", "## Figures", ""]
    lines += [f"![{stem}]({stem}.png)" for stem in stems]
    return "\n".join(lines) + "\n"


def write_reconstruction_report(rec: Reconstruction, directory: str | Path) -> Path:
    """Write ``reconstruction.md`` and its PNG figures into ``directory``; return its path.

    Raises
    ------
    UsageError
        One line naming the path when the folder or a file cannot be written.
    """
    folder = make_directory(directory)
    figures = reconstruction_figures(rec)
    for stem, fig in figures.items():
        write_figure_atomic(fig, folder / f"{stem}.png", DPI)
    return write_text_atomic(folder / RECONSTRUCTION_REPORT,
                             reconstruction_markdown(rec, list(figures)))
