"""Write a study's report: tidy CSV, summary CSV, figures and ``report.md``.

``report.md`` has the design (with the code that computed the numbers, from
``study.json``), an overall table, and per noise condition a Table-5-style table of
mean |error| % per coefficient beside the paper's published figures
(:mod:`aeroid.study._paper`, always labelled as the paper's) and a table of bias,
spread, Cramér-Rao ratio and coverage. Every header names its unit; counts are
integers. Studies of fewer than :data:`COMPACT_RUNS` runs get a compact report: the
spread and coverage of a handful of fits say little, so that table is left out (it is
in ``summary.csv``) and the report says so. Per noise condition it shows both
Cramér-Rao floors the runner stored in ``floors.json`` (:mod:`aeroid.study._floors`:
per channel and per sample, with the sensor-position uncertainty when the noise model
has one) and which one each estimator can reach; an estimator's "CR sd" and "sd/CR"
are against the floor it can reach. A folder without a valid ``floors.json`` (written
by an older aeroid) gets them computed for the report, which says so.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from aeroid.model import NAMES
from aeroid.study import _metrics as metrics
from aeroid.study._fits import HISTORY_RUN
from aeroid.study._floors import (
    FLOOR_NUISANCE_STATES,
    floor_paragraph,
    floor_pct,
    reachable_floors,
    report_floors,
)
from aeroid.study._histories import read_history
from aeroid.study._markdown import _count, _fmt, _table  # noqa: F401 - _fmt, _count: the report's
from aeroid.study._paper import PAPER_METHODS, paper_condition, paper_errors, paper_results
from aeroid.study._perturb import perturb_lines
from aeroid.study._spec import Study
from aeroid.study._store import (
    DESIGN_FILE,
    RESULTS_FILE,
    read_design,
    read_results,
    write_atomic,
)
from aeroid.study._suite import suite_lines
from aeroid.study._tables import has_tables, write_tables_report

#: Below this many runs the report is compact (no bias/spread/coverage table).
COMPACT_RUNS = 10

# --------------------------------------------------------------------------------------
# Cramér-Rao floors
# --------------------------------------------------------------------------------------
#: The per-channel floor with known positions is ``aeroid.estimation.cramer_rao_sd``
#: with these options (the output-error information matrix as that method uses it: one
#: noise level per channel, both triads and p, q, r, initial rates estimated); it
#: reproduces reference/README.md's prototype floor to within its rounding on all but
#: Cx (which used triad 1 only).
FLOOR_OPTIONS: dict[str, Any] = {"noise_form": "homoscedastic",
                                 "estimate_initial": FLOOR_NUISANCE_STATES}


# --------------------------------------------------------------------------------------
# Markdown
# --------------------------------------------------------------------------------------
def _code_line(out_dir: Path) -> str:
    """The code that computed the results, from ``study.json`` (or the running code)."""
    from aeroid.study._provenance import code_identity

    code = None
    if (out_dir / DESIGN_FILE).exists():
        code = read_design(out_dir).get("code")
    if not isinstance(code, dict):
        code = code_identity()
        where = "the running code (no study.json)"
    else:
        where = "from study.json"
    packages = ", ".join(f"{k} {v}" for k, v in (code.get("packages") or {}).items()
                         if v is not None and k != "aeroid-toolkit")
    return (f"- code ({where}): aeroid {code.get('aeroid')}, source {code.get('source')}, "
            f"Python {code.get('python')}; {packages}")


def _prior_line(study: Study) -> str:
    """Where the estimators start: the run's offset prior or the airframe's prior."""
    if study.prior_offset is None:
        return ("- prior: the scenario airframe's (its [prior] table, else the nominal "
                "coefficients: for the reference scenario the truth), the same in every run")
    lo, hi = study.prior_offset
    return (f"- prior: per run, each coefficient truth x (1 + s U({lo:g}, {hi:g})) with a "
            "random sign s (every estimator of a run starts from, or centres its search "
            "box on, the same prior; each record keeps it)")


def markdown(study: Study, summary: pd.DataFrame, floors: Mapping[str, Mapping[str, Any]],
             figures: Sequence[Path], out_dir: Path, command: str = "",
             floors_from: str = "floors.json",
             records: Sequence[Mapping[str, Any]] = ()) -> str:
    """Return ``report.md``: design, overall table, per-noise Table-5-style tables.

    ``floors`` maps a noise label to its entry of :func:`aeroid.study._floors.study_floors`;
    ``floors_from`` says where they come from; ``records`` (the runner's) give the
    sensor-suite conditions' fitted IMU errors (:func:`aeroid.study._suite.suite_lines`).
    """
    d = study.describe()
    lines = [f"# Study: {study.name}", ""]
    if study.description:
        lines += [study.description, ""]
    lines += ["## Design", "",
              f"- scenario: {d['scenario']}; seed {study.seed}; {study.runs} runs; "
              f"{len(study.noise)} noise condition(s) x {len(study.estimators)} estimator(s)",
              f"- study file: {study.source}; fingerprint {d['fingerprint']}",
              _prior_line(study), _code_line(out_dir)]
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
    lines += ["", "Error figures are over successful fits: mean |error| [%] = mean of "
              "|estimate - truth| / |truth| x 100 (the paper's figure); bias, sd and RMSE "
              "are in % of |truth|; coverage = share of fits whose estimate +- "
              f"{metrics.COVERAGE_Z} x its standard error holds the truth (nominal 0.95); "
              "CR sd = Cramér-Rao standard deviation in % of |truth| (the floor on the "
              "spread of any unbiased estimator; beside each estimator, the floor it can "
              "reach); sd/CR = spread over floor (1 = efficient).", ""]

    over = metrics.overall(summary)
    lines += ["## Overall (mean over the nine coefficients)", ""]
    lines += _table(["noise", "estimator", "method", "mean abs error [%]",
                     "coverage [share]", "success [share]", "median time [s]",
                     "median evaluations [count]"],
                    list(over[["noise", "estimator", "method", "mean_abs_error_pct",
                               "coverage", "success_rate", "median_wall_time_s",
                               "median_evaluations"]].itertuples(index=False)), counts=(7,))
    lines.append("")
    lines += suite_lines(records)
    lines += perturb_lines(records, study)

    est_opts = {e["label"]: e["options"] for e in d["estimators"]}
    reach = reachable_floors(study)
    truth = np.asarray(study.scenario.coefficient_vector, dtype=float)
    for cond in study.noise:
        part = summary[summary["noise"] == cond.label]
        if part.empty:
            continue
        entry = floors.get(cond.label)
        lines += [f"## Noise: {cond.label}", ""]
        lines += floor_paragraph(entry, floors_from, reach)
        channel_pct = floor_pct(entry, "per_channel", truth)
        sample_pct = floor_pct(entry, "per_sample", truth)
        labels = list(dict.fromkeys(part["estimator"]))
        header = ["coef", "truth [-]", "CR sd per-channel [% of truth]",
                  "CR sd per-sample [% of truth]"]
        paper_cols: list[tuple[str, dict[str, float], str]] = []
        for lab in labels:
            header.append(f"{lab} error [%]")
            method = part.loc[part["estimator"] == lab, "method"].iloc[0]
            match = paper_condition(method, est_opts.get(lab, {}), cond.describe())
            if match is not None:
                errs = paper_errors(match[0], match[1], method)
                if errs:
                    name = f"PAPER {PAPER_METHODS[method]} (Table {match[0]}) [%]"
                    if all(name != c[0] for c in paper_cols):
                        paper_cols.append((name, errs, match[1]))
        header += [c[0] for c in paper_cols]
        rows = []
        for name in NAMES:
            sel = part[part["coefficient"] == name]
            if sel.empty:
                continue
            j = list(NAMES).index(name)
            row: list[Any] = [name, float(sel["truth"].iloc[0]), float(channel_pct[j]),
                              float(sample_pct[j])]
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
        if study.runs < COMPACT_RUNS:
            lines += ["", f"Bias, spread, coverage: not shown for {study.runs} run(s) "
                      f"(from {COMPACT_RUNS} runs on; a spread of so few fits says little); "
                      "the per-coefficient figures are in summary.csv, every fit in "
                      "results.csv.", ""]
            continue
        lines += ["", "Bias, spread, coverage (in % of |truth| unless stated):", ""]
        detail = part[["estimator", "coefficient", "bias_pct", "sd_pct", "cr_sd_pct",
                       "sd_over_cr", "rmse_pct", "coverage", "n_success", "n_runs"]]
        lines += _table(["estimator", "coef", "bias [%]", "sd [%]", "CR sd [%]",
                         "sd/CR [-]", "RMSE [%]", "coverage [share]", "ok [fits]",
                         "runs [fits]"], list(detail.itertuples(index=False)), counts=(8, 9))
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
    from aeroid.model import aero_forces_moments, constants
    from aeroid.study._fits import scenario_truth

    try:
        t_all, states, delta = scenario_truth(study.scenario)
        k = np.rint(np.asarray(t) / study.scenario.manoeuvre.dt).astype(int)
        if k.min() < 0 or k.max() >= len(t_all):
            return None
        return aero_forces_moments(states[k], delta[k], study.scenario.coefficient_vector,
                                   constants(study.scenario.airframe))
    except Exception:  # the truth line is a courtesy: never let it break the report
        return None


def slug(text: str) -> str:
    """Return ``text`` as a file-name-safe slug (readability only: names carry an index)."""
    return re.sub(r"[^A-Za-z0-9.=+-]+", "_", text).strip("_.") or "x"


def make_figures(study: Study, tidy: pd.DataFrame, summary: pd.DataFrame, out_dir: Path,
                 records: Sequence[Mapping[str, Any]] = (),
                 floors: Mapping[str, Mapping[str, Any]] | None = None) -> list[Path]:
    """Write every figure of the study into ``out_dir/figures``; return their paths.

    File names carry the design's indices (``n<k>`` noise, ``e<j>`` estimator) and, for
    reading, a slug of the labels; the run-0 histories are the files named by the
    records (``record["history"]``).
    """
    from aeroid.study import _plots as plots

    fig_dir = out_dir / "figures"
    written: list[Path] = []
    truth = list(study.scenario.coefficients)
    run0 = {(r["noise"], r["estimator"]): r for r in records
            if int(r["run"]) == HISTORY_RUN}
    for k, cond in enumerate(study.noise):
        tag = f"n{k}_{slug(cond.label)}"
        convergence: dict[str, Any] = {}
        left_out: dict[str, str] = {}
        for j, spec in enumerate(study.estimators):
            record = run0.get((cond.label, spec.label))
            name = record.get("history") if record else None
            h = read_history(out_dir, name) if name else None
            if h is None:
                left_out[spec.label] = ("run 0 not run yet" if record is None else
                                        "run 0 failed" if not record["success"] else
                                        "no iterations (closed form)")
                continue
            stem = f"n{k}-e{j}_{slug(spec.label)}"
            history = {key[len("history_"):]: v for key, v in h.items()
                       if key.startswith("history_")}
            if "theta" in history and "step" in history:
                axis = str(history.get("axis", "iteration"))
                if axis == "iteration" and "cost" in history:
                    convergence[spec.label] = history
                else:
                    left_out[spec.label] = ("a filter: estimates against time, no cost "
                                            "iterations" if axis == "time" else
                                            "no cost history")
                written.append(plots.plot_coefficient_history(
                    history, truth, fig_dir / f"coefficients_{stem}.png",
                    title=f"{spec.label} — estimates vs {axis} (run 0, noise {cond.label})"))
            else:
                left_out[spec.label] = "no convergence history"
            if "info_t" in h and "info_fm_raw" in h:
                written.append(plots.plot_forces(
                    h["info_t"], h["info_fm_raw"], h.get("info_fm_smooth"),
                    fig_dir / f"forces_{stem}.png",
                    fm_true=_true_forces(study, h["info_t"]),
                    title=f"{spec.label} — reconstructed forces and moments "
                          f"(run 0, noise {cond.label})"))
        if convergence:
            written.append(plots.plot_convergence(
                convergence, fig_dir / f"convergence_{tag}.png", left_out=left_out,
                title=f"Convergence of the cost (run 0, noise {cond.label})"))
        part = tidy[tidy["noise"] == cond.label]
        if not part.empty:
            entry = (floors or {}).get(cond.label)
            truth_v = np.asarray(study.scenario.coefficient_vector, dtype=float)
            cr = dict(zip(NAMES, floor_pct(entry, "per_channel", truth_v), strict=True))
            cr_sample = dict(zip(NAMES, floor_pct(entry, "per_sample", truth_v), strict=True))
            written.append(plots.plot_errors(
                part, fig_dir / f"errors_{tag}.png", cr_pct=cr, cr_sample_pct=cr_sample,
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
                 figures: bool = True, command: str = "") -> Path:
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

    The Cramér-Rao floors are the runner's (``floors.json``, :func:`report_floors`);
    each estimator's "CR sd" is the floor it can reach
    (:func:`aeroid.study._floors.reachable_floor`).
    """
    out_dir = Path(out_dir)
    if records is None:
        records = read_results(out_dir / RESULTS_FILE)
    if has_tables(study):  # scored per table point: aeroid/study/_tables.py
        return write_tables_report(study, out_dir, records, command)
    noise_order = {n.label: k for k, n in enumerate(study.noise)}
    est_order = {e.label: k for k, e in enumerate(study.estimators)}
    records = sorted(records, key=lambda r: (int(r["run"]), noise_order.get(r["noise"], -1),
                                             est_order.get(r["estimator"], -1)))
    tidy = metrics.tidy(records)
    floors, floors_from = report_floors(study, out_dir)
    cramer_rao = {(noise, label): entry.get(key) for noise, entry in floors.items()
                  for label, key in reachable_floors(study).items()}
    summary = metrics.summarize(tidy, cramer_rao)
    # every file through a temporary name and a rename: a kill or a full disk leaves the
    # previous file or none, never a truncated one
    write_atomic(out_dir / "results.csv", tidy.to_csv(index=False).encode())
    write_atomic(out_dir / "summary.csv", summary.to_csv(index=False).encode())
    paths = make_figures(study, tidy, summary, out_dir, records, floors) if figures else []
    report = out_dir / "report.md"
    write_atomic(report, markdown(study, summary, floors, paths, out_dir, command,
                                  floors_from, records).encode())
    return report


__all__ = ["FLOOR_OPTIONS", "make_figures", "markdown", "paper_condition", "paper_errors",
           "paper_results", "write_report"]
