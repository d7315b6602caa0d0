"""Write a study's report: tidy CSV, summary CSV, figures and ``report.md``.

``report.md`` puts our figures beside the paper's published ones
(``aeroid/data/paper-results.csv``), always labelled as the paper's. Our labels are
matched to the paper's methods by method name (eam-pso, ebm-pso, sebm-pso, ekf) and
the noise condition by the paper's model with ``accelerations_xi == rates_xi == xi``:

- ebm-pso with ``smoothing = "forces"`` (the paper's SG filter on the reconstructed
  forces) -> Table 6 ("with SG filter") at its xi;
- ebm-pso with ``smoothing = "none"`` -> Table 7 ("no filter") at its xi;
- otherwise, at xi = 0.05, any of the four methods -> Table 5 (100 runs).

Decision: an EBM-PSO run with our default smoothing ("both") is shown beside Table 5
(the paper's EBM-PSO at xi = 0.05); its configuration differs and the table says so.
The Cramér-Rao floor comes from ``aeroid.estimation.cramer_rao_sd`` with
:data:`FLOOR_OPTIONS` and shows "n/a" where it cannot be computed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from aeroid.model._coefficients import NAMES
from aeroid.study import _metrics as metrics
from aeroid.study._design import Study
from aeroid.study._runner import RESULTS_FILE, load_history, read_results, slug

PAPER_METHODS = {"eam-pso": "EAM-PSO", "ebm-pso": "EBM-PSO", "sebm-pso": "SEBM-PSO",
                 "ekf": "EKF"}
XI_MATCH_TOL = 1e-9
"""xi values in study files are decimal literals like 0.05: equal up to rounding."""


# --------------------------------------------------------------------------------------
# The paper's figures
# --------------------------------------------------------------------------------------
def paper_results() -> pd.DataFrame:
    """Return the paper's published tables (columns table, method, condition, coefficient,
    nominal, estimate, error_pct)."""
    path = resources.files("aeroid") / "data" / "paper-results.csv"
    with path.open() as fh:
        return pd.read_csv(fh)


def _paper_xi(noise: Mapping[str, Any]) -> float | None:
    if noise.get("model") != "paper":
        return None
    xa, xr = noise.get("accelerations_xi"), noise.get("rates_xi")
    if xa is None or xr is None or abs(float(xa) - float(xr)) > XI_MATCH_TOL:
        return None
    return float(xa)


def paper_condition(method: str, options: Mapping[str, Any], noise: Mapping[str, Any]
                    ) -> tuple[int, str] | None:
    """Return the paper's (table, condition) comparable to one study cell, or None.

    Parameters
    ----------
    method : str
        Our method name (``ebm-pso``...).
    options : dict
        The estimator's options (``smoothing`` is read for ebm-pso).
    noise : dict
        The noise condition's settings (``NoiseCondition.describe()``).
    """
    if method not in PAPER_METHODS:
        return None
    xi = _paper_xi(noise)
    if xi is None:
        return None
    text = f"{xi:g}"
    if method == "ebm-pso" and options.get("smoothing") == "forces":
        return 6, f"xi={text} with SG filter"
    if method == "ebm-pso" and options.get("smoothing") == "none":
        return 7, f"xi={text} no filter"
    if abs(xi - 0.05) <= XI_MATCH_TOL:
        return 5, "xi=0.05 100 runs"
    return None


def paper_errors(table: int, condition: str, method: str) -> dict[str, float]:
    """Return the paper's error % per coefficient for (table, condition, our method)."""
    data = paper_results()
    rows = data[(data["table"] == table) & (data["condition"] == condition)
                & (data["method"] == PAPER_METHODS.get(method, ""))]
    return {str(c): float(e) for c, e in zip(rows["coefficient"], rows["error_pct"],
                                              strict=True)}


# --------------------------------------------------------------------------------------
# Cramér-Rao floor
# --------------------------------------------------------------------------------------
#: How the study's floor is computed (:func:`aeroid.estimation.cramer_rao_sd` options).
#: Decision: the floor is the output-error information matrix as the output-error
#: maximum-likelihood method itself uses it: one noise level per channel (the
#: channel's noise RMS: what an estimator that learns a constant diagonal noise
#: covariance from residuals can exploit), both triads and p, q, r, the initial rates
#: estimated as nuisance parameters, true sensor positions. Under eq. 43 the
#: per-sample (heteroscedastic) form is 10-20x lower on Czq, Cl0, Clp, because
#: samples near a zero crossing of a multiplicative-noise channel are almost exact;
#: no estimator here models that, so that floor would compare methods with an
#: unreachable bound. This form reproduces reference/README.md's prototype floor to
#: within its rounding on all but Cx (which used triad 1 only).
FLOOR_OPTIONS: dict[str, Any] = {"noise_form": "homoscedastic",
                                 "estimate_initial": ("p", "q", "r")}
FLOOR_DESCRIPTION = ("aeroid.estimation.cramer_rao_sd, output-error information matrix: one noise "
                     "level per channel (its RMS), both triads and p, q, r, initial rates "
                     "estimated, true sensor positions")


def cramer_rao_floor(study: Study, noise_index: int) -> tuple[np.ndarray | None, str]:
    """Return the Cramér-Rao sd (9,) of the study's scenario under one noise condition.

    Calls ``aeroid.estimation.cramer_rao_sd`` with :data:`FLOOR_OPTIONS`; returns
    ``(None, reason)`` when a floor for this noise model is not available.
    """
    from aeroid.estimation import _floor as fisher

    scenario, noise = study.scenario, study.noise[noise_index].model
    try:
        sd = fisher.cramer_rao_sd(scenario, noise, **FLOOR_OPTIONS)
    except Exception as exc:  # a floor is an extra: never let it break the report
        return None, f"cramer_rao_sd failed: {type(exc).__name__}: {exc}"
    sd = np.asarray(sd, dtype=float).reshape(-1)
    if sd.shape != (len(NAMES),):
        return None, f"cramer_rao_sd returned shape {sd.shape}"
    return sd, FLOOR_DESCRIPTION


# --------------------------------------------------------------------------------------
# Markdown
# --------------------------------------------------------------------------------------
def _fmt(x: Any, digits: int = 3) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a"
    if isinstance(x, float | np.floating):
        if x == 0:
            return "0"
        if float(x).is_integer() and 100 <= abs(x) < 1e7:
            return str(int(x))
        if abs(x) >= 1000 or abs(x) < 0.01:
            return f"{x:.{digits}g}"
        return f"{x:.{digits}g}" if abs(x) < 1 else f"{x:.{max(digits - 1, 1)}f}"
    return str(x)


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |",
             "|" + "|".join("---:" if k else ":---" for k in range(len(header))) + "|"]
    lines += ["| " + " | ".join(_fmt(v) for v in row) + " |" for row in rows]
    return lines


def markdown(study: Study, summary: pd.DataFrame, floors: Mapping[str, str],
             figures: Sequence[Path], out_dir: Path, command: str = "") -> str:
    """Return ``report.md``: design, overall table, per-noise Table-5-style tables."""
    d = study.describe()
    lines = [f"# Study: {study.name}", ""]
    if study.description:
        lines += [study.description, ""]
    lines += ["## Design", "",
              f"- scenario: {d['scenario']}; seed {study.seed}; {study.runs} runs; "
              f"{len(study.noise)} noise condition(s) x {len(study.estimators)} estimator(s)",
              f"- study file: {study.source}; fingerprint {d['fingerprint']}"]
    if command:
        lines.append(f"- command: `{command}`")
    for n in d["noise"]:
        opts = ", ".join(f"{k}={v}" for k, v in n.items() if k not in ("label",))
        lines.append(f"- noise **{n['label']}**: {opts}")
    for e in d["estimators"]:
        opts = ", ".join(f"{k}={v}" for k, v in e["options"].items())
        lines.append(f"- estimator **{e['label']}**: {e['method']} ({opts or 'defaults'})")
    if study.skipped:
        lines.append(f"- skipped (not installed): {', '.join(study.skipped)}")
    lines += ["", "Error figures are over successful fits: mean |error| % = mean of "
              "|estimate - truth| / |truth| x 100 (the paper's figure); coverage = share of "
              f"fits whose estimate +- {metrics.COVERAGE_Z} x its standard error holds the "
              "truth (nominal 0.95); CR sd = Cramér-Rao standard deviation in % of |truth| "
              "(the floor on the spread of any unbiased estimator); sd/CR = spread over "
              "floor (1 = efficient).", ""]

    over = metrics.overall(summary)
    lines += ["## Overall (mean over the nine coefficients)", ""]
    lines += _table(["noise", "estimator", "method", "mean abs error %", "coverage",
                     "success", "median time [s]", "median evaluations"],
                    over[["noise", "estimator", "method", "mean_abs_error_pct", "coverage",
                          "success_rate", "median_wall_time_s",
                          "median_evaluations"]].itertuples(index=False))
    lines.append("")

    est_opts = {e["label"]: e["options"] for e in d["estimators"]}
    for cond in study.noise:
        part = summary[summary["noise"] == cond.label]
        if part.empty:
            continue
        lines += [f"## Noise: {cond.label}", "",
                  f"Cramér-Rao floor: {floors.get(cond.label, 'n/a')}.", ""]
        labels = list(dict.fromkeys(part["estimator"]))
        header = ["coef", "truth", "CR sd %"]
        paper_cols: list[tuple[str, dict[str, float], str]] = []
        for lab in labels:
            header.append(f"{lab} error %")
            method = part.loc[part["estimator"] == lab, "method"].iloc[0]
            match = paper_condition(method, est_opts.get(lab, {}), cond.describe())
            if match is not None:
                errs = paper_errors(match[0], match[1], method)
                if errs:
                    name = f"PAPER {PAPER_METHODS[method]} (Table {match[0]})"
                    if all(name != c[0] for c in paper_cols):
                        paper_cols.append((name, errs, match[1]))
        header += [c[0] for c in paper_cols]
        rows = []
        for name in NAMES:
            sel = part[part["coefficient"] == name]
            if sel.empty:
                continue
            row: list[Any] = [name, float(sel["truth"].iloc[0]),
                              float(sel["cr_sd_pct"].iloc[0])]
            for lab in labels:
                row.append(float(sel.loc[sel["estimator"] == lab,
                                         "mean_abs_error_pct"].iloc[0]))
            row += [c[1].get(name, math.nan) for c in paper_cols]
            rows.append(row)
        lines += ["Mean |error| % per coefficient (ours"
                  + ("; columns marked PAPER are the paper's published figures, not ours"
                     if paper_cols else "") + "):", ""]
        lines += _table(header, rows)
        for name, _, condition in paper_cols:
            lines.append(f"- {name}: the paper's published mean error % for \"{condition}\" "
                         "(paper section 4; its configuration may differ from ours)")
        lines += ["", "Bias, spread, coverage:", ""]
        detail = part[["estimator", "coefficient", "bias_pct", "sd", "cr_sd", "sd_over_cr",
                       "rmse_pct", "coverage", "n_success", "n_runs"]]
        lines += _table(["estimator", "coef", "bias %", "sd", "CR sd", "sd/CR", "RMSE %",
                         "coverage", "ok", "runs"], detail.itertuples(index=False))
        lines.append("")
    if figures:
        lines += ["## Figures", ""]
        lines += [f"![{p.stem}]({p.relative_to(out_dir).as_posix()})" for p in figures]
        lines.append("")
    return "\n".join(lines)


# --------------------------------------------------------------------------------------
# Figures
# --------------------------------------------------------------------------------------
def _true_forces(study: Study, t: np.ndarray) -> np.ndarray | None:
    """True aerodynamic forces and moments of the scenario at times ``t`` (n, 6)."""
    from aeroid.model._dynamics import aero_forces_moments, constants
    from aeroid.study._runner import _truth

    try:
        t_all, states, delta = _truth(study.scenario)
        k = np.rint(np.asarray(t) / study.scenario.manoeuvre.dt).astype(int)
        if k.min() < 0 or k.max() >= len(t_all):
            return None
        return aero_forces_moments(states[k], delta[k], study.scenario.coefficient_vector,
                                   constants(study.scenario.airframe))
    except Exception:  # the truth line is a courtesy: never let it break the report
        return None


def make_figures(study: Study, tidy: pd.DataFrame, summary: pd.DataFrame, out_dir: Path
                 ) -> list[Path]:
    """Write every figure of the study into ``out_dir/figures``; return their paths."""
    from aeroid.study import _plots as plots

    fig_dir = out_dir / "figures"
    written: list[Path] = []
    truth = list(study.scenario.coefficients)
    for cond in study.noise:
        tag = slug(cond.label)
        convergence = {}
        for spec in study.estimators:
            h = load_history(out_dir, cond.label, spec.label)
            if h is None:
                continue
            history = {k[len("history_"):]: v for k, v in h.items()
                       if k.startswith("history_")}
            if "theta" in history and "step" in history:
                axis = str(history.get("axis", "iteration"))
                if axis == "iteration" and "cost" in history:
                    convergence[spec.label] = history
                written.append(plots.plot_coefficient_history(
                    history, truth, fig_dir / f"coefficients_{tag}__{slug(spec.label)}.png",
                    title=f"{spec.label} — estimates vs {axis} (run 0, noise {cond.label})"))
            if "info_t" in h and "info_fm_raw" in h:
                written.append(plots.plot_forces(
                    h["info_t"], h["info_fm_raw"], h.get("info_fm_smooth"),
                    fig_dir / f"forces_{tag}__{slug(spec.label)}.png",
                    fm_true=_true_forces(study, h["info_t"]),
                    title=f"{spec.label} — reconstructed forces and moments "
                          f"(run 0, noise {cond.label})"))
        if convergence:
            written.append(plots.plot_convergence(
                convergence, fig_dir / f"convergence_{tag}.png",
                title=f"Convergence of the cost (run 0, noise {cond.label})"))
        part = tidy[tidy["noise"] == cond.label]
        if not part.empty:
            s = summary[(summary["noise"] == cond.label)]
            cr = dict(zip(s["coefficient"], s["cr_sd_pct"], strict=True))
            written.append(plots.plot_errors(
                part, fig_dir / f"errors_{tag}.png", cr_pct=cr,
                title=f"Relative error per coefficient — noise {cond.label} "
                      f"({study.runs} runs)"))
    if not tidy.empty:
        written.append(plots.plot_runtime(tidy, fig_dir / "runtime.png",
                                          title=f"Run time per fit — {study.name}"))
    return written


# --------------------------------------------------------------------------------------
# Everything
# --------------------------------------------------------------------------------------
def write_report(study: Study, out_dir: str | Path,
                 records: Sequence[Mapping[str, Any]] | None = None, *,
                 figures: bool = True, command: str = "",
                 cramer_rao: Mapping[str, np.ndarray | None] | None = None) -> Path:
    """Write ``results.csv``, ``summary.csv``, figures and ``report.md``; return the latter.

    Parameters
    ----------
    study : Study
        The design the records belong to.
    out_dir : path-like
        The study's output folder (where the runner wrote ``results.jsonl``).
    records : sequence of dict, optional
        Runner records (default: read ``out_dir/results.jsonl``).
    figures : bool
        Draw the PNG figures (``out_dir/figures``).
    command : str
        The command line to quote in the report.
    cramer_rao : mapping of str to ndarray (9,) or None, optional
        Noise label -> Cramér-Rao sd; default: :func:`cramer_rao_floor` per condition.
    """
    out_dir = Path(out_dir)
    if records is None:
        records = read_results(out_dir / RESULTS_FILE)
    noise_order = {n.label: k for k, n in enumerate(study.noise)}
    est_order = {e.label: k for k, e in enumerate(study.estimators)}
    records = sorted(records, key=lambda r: (int(r["run"]), noise_order.get(r["noise"], -1),
                                             est_order.get(r["estimator"], -1)))
    tidy = metrics.tidy(records)
    floors: dict[str, str] = {}
    if cramer_rao is None:
        cramer_rao = {}
        for k, cond in enumerate(study.noise):
            sd, why = cramer_rao_floor(study, k)
            cramer_rao[cond.label] = sd
            floors[cond.label] = why if sd is not None else f"n/a ({why})"
    else:
        floors = {k: ("given" if v is not None else "n/a") for k, v in cramer_rao.items()}
    summary = metrics.summarize(tidy, cramer_rao)
    tidy.to_csv(out_dir / "results.csv", index=False)
    summary.to_csv(out_dir / "summary.csv", index=False)
    paths = make_figures(study, tidy, summary, out_dir) if figures else []
    report = out_dir / "report.md"
    report.write_text(markdown(study, summary, floors, paths, out_dir, command))
    return report


__all__ = ["cramer_rao_floor", "make_figures", "markdown", "paper_condition", "paper_errors",
           "paper_results", "write_report"]
