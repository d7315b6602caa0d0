"""Studies of coefficient tables in Mach: each fit scored per parameter name.

A scenario with ``[tables]`` (the fits' tables) is scored over the parameters each fit
returns (``result.names``: its constants and table points ``Cx@M1.4``), not the nine
coefficients. The truth of a parameter (:func:`parameter_truth`) is the scenario's true
coefficient at that point's Mach: its true table (rows ``[Mach, value]``, linear between
them) evaluated at the knot, or its constant value. It is the truth of the fitted table
point only when the true coefficient is linear between the fit's knots (the scenario's
rows at the fit's knots, as in ``studies/scenarios/mach_sweep.toml``); the report says so.

The report of such a study (:func:`write_tables_report`): ``results.csv`` (one row per
fit and parameter), ``summary.csv`` (:func:`aeroid.study._metrics.summarize` per
parameter, no Cramér-Rao columns: each fit carries its own points' floor,
``info['table_floor']``) and ``report.md`` with the coverage of each table point's 95 %
interval per estimator and its binomial interval. No figures (said in the report).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy.stats import binomtest

from aeroid.flights import flight_mach_tables
from aeroid.model import NAMES, tables
from aeroid.study import _metrics as metrics
from aeroid.study._perturb import perturb_lines
from aeroid.study._spec import Study
from aeroid.study._store import write_atomic

__all__ = ["TABLES_NO_FLOOR", "has_tables", "parameter_names", "parameter_truth",
           "write_tables_report"]

#: floors.json's reason for a study of tables.
TABLES_NO_FLOOR = ("coefficient tables: each fit carries the Cramér-Rao floor of its own "
                   "table points (info['table_floor']); the study's nine-coefficient floor "
                   "does not apply")


def has_tables(study: Study) -> bool:
    """True when the study's fits estimate tables (the scenario airframe's ``[tables]``)."""
    return study.scenario.airframe.tables is not None


def parameter_names(flight: Any) -> tuple[str, ...]:
    """The parameter names of a table fit of ``flight`` (its airframe's tables)."""
    return flight_mach_tables(flight).parameter_names()  # Mach from a logged air temperature


def parameter_truth(scenario: Any, names: Sequence[str]) -> np.ndarray:
    """Return the true value of each parameter name (module docstring), shape (len(names),)."""
    values = np.asarray(scenario.coefficient_vector, dtype=float)
    out = np.empty(len(names))
    for i, name in enumerate(names):
        base, kind, knot = tables.split_point(name)  # Cx@M1.4, Cma@A4deg [rad] or Cza
        j = NAMES.index(base)
        if scenario.tables is None:
            out[i] = values[j]
        else:
            mach = knot if kind == "mach" else 1.0  # a constant: any Mach gives its value
            alpha = knot if kind == "alpha" else 0.0
            out[i] = float(scenario.tables.coefficients(list(values), mach, alpha)[j])
    return out


def _coverage_rows(tidy: pd.DataFrame) -> list[list[Any]]:
    rows = []
    for (estimator, name), part in tidy.groupby(["estimator", "coefficient"], sort=False):
        covered = part.loc[part["success"], "covered"].dropna().astype(bool)
        n, k = len(covered), int(covered.sum())
        low, high = (binomtest(k, n).proportion_ci(0.95, method="exact") if n else
                     (np.nan, np.nan))
        z = (part.loc[part["success"], "error"] / part.loc[part["success"], "stderr"]).abs()
        rows.append([estimator, name, float(part["truth"].iloc[0]), n, k,
                     k / n if n else np.nan, float(low), float(high),
                     float(z.max()) if len(z) else np.nan])
    return rows


def write_tables_report(study: Study, out_dir: Path, records: Sequence[Mapping[str, Any]],
                        command: str = "") -> Path:
    """Write ``results.csv``, ``summary.csv`` and ``report.md`` of a study of tables."""
    from aeroid.study._markdown import _table

    tidy = metrics.tidy(records)
    summary = metrics.summarize(tidy)
    write_atomic(out_dir / "results.csv", tidy.to_csv(index=False).encode())
    write_atomic(out_dir / "summary.csv", summary.to_csv(index=False).encode())
    d = study.describe()
    lines = [f"# Study: {study.name}", ""]
    if study.description:
        lines += [study.description, ""]
    lines += ["## Design", "", f"- scenario: {d['scenario']}; seed {study.seed}; "
              f"{study.runs} runs; {len(study.noise)} noise condition(s) x "
              f"{len(study.estimators)} estimator(s); fingerprint {d['fingerprint']}"]
    if command:
        lines.append(f"- command: `{command}`")
    for e in d["estimators"]:
        opts = ", ".join(f"{k}={v}" for k, v in e["options"].items())
        lines.append(f"- estimator **{e['label']}**: {e['method']} ({opts or 'defaults'})")
    lines += ["- scored per parameter of the fits (their constants and table points); the "
              "truth of a point is the scenario's true coefficient at its Mach (its rows, "
              "linear between them): the fitted point's truth when the truth is linear "
              "between the fit's knots", "- no figures and no study Cramér-Rao floor for "
              "tables (each fit's info['table_floor'] has its points' floor)", ""]
    for cond in study.noise:
        part = tidy[tidy["noise"] == cond.label]
        if part.empty:
            continue
        ok = part.drop_duplicates(["run", "estimator"])
        lines += [f"## Noise: {cond.label}", "",
                  f"Successful fits: {int(ok['success'].sum())} of {len(ok)}."
                  + "".join(f" Not successful ({n}): {m[:160]}" for m, n in
                            ok.loc[~ok["success"], "message"].value_counts().items()), "",
                  f"Coverage of each parameter's 95 % interval (|error| <= "
                  f"{metrics.COVERAGE_Z} se, successful fits) with its exact binomial 95 % "
                  "interval:", ""]
        lines += _table(["estimator", "parameter", "truth [-]", "fits [count]",
                         "covered [count]", "coverage [share]", "low [share]",
                         "high [share]", "max |error|/se [-]"], _coverage_rows(part),
                        counts=(3, 4))
        points = part[part["coefficient"].str.contains(tables.POINT_SEPARATOR, regex=False)
                      & part["success"]]["covered"].dropna().astype(bool)
        if len(points):
            lines += ["", f"All table points together: {int(points.sum())} of {len(points)} "
                      f"point-fits covered ({points.mean():.3f})."]
        lines.append("")
    lines += perturb_lines(records, study)
    report = out_dir / "report.md"
    write_atomic(report, "\n".join(lines).encode())
    return report
