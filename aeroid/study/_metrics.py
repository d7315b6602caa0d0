"""Accuracy, honesty and cost of each estimator in a study (pure pandas/numpy).

:func:`tidy` turns the runner's records into one row per run x noise x estimator x
coefficient; :func:`summarize` reduces it per noise condition, estimator and
coefficient. Definitions (``e = estimate - truth``, over *successful* fits only):

- ``bias`` = mean(e); ``bias_pct`` = bias / |truth| * 100
- ``sd`` = sample standard deviation of the estimates (ddof = 1; NaN for one fit);
  ``sd_pct`` = sd / |truth| * 100
- ``mean_abs_error_pct`` = mean(|e| / |truth|) * 100 — the paper's error figure
- ``rmse`` = sqrt(mean(e^2)); ``rmse_pct`` = rmse / |truth| * 100
- ``coverage`` = fraction of fits with a finite standard error whose nominal 95 %
  interval holds the truth, ``|e| <= COVERAGE_Z * stderr`` (NaN when no fit has one)
- ``success_rate`` = successful fits / fits; wall time and evaluations are medians
  over all fits (failures cost time too)
- ``cr_sd`` = the Cramér-Rao standard deviation of the scenario (the floor no unbiased
  estimator beats on average), ``cr_sd_pct`` in % of |truth| and ``sd_over_cr``
  (1 = efficient), when a floor is given.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from aeroid.model import NAMES

COVERAGE_Z = 1.96
"""Two-sided 95 % normal quantile (rounded as in the brief: |e| <= 1.96 stderr)."""

GROUP = ["noise", "estimator", "coefficient"]

TIDY_COLUMNS = ["run", "noise", "estimator", "method", "coefficient", "truth", "estimate",
                "stderr", "error", "rel_error_pct", "covered", "success", "message", "cost",
                "n_evaluations", "n_iterations", "wall_time_s"]


def _array(values: Any, n: int) -> np.ndarray:
    if values is None:
        return np.full(n, np.nan)
    return np.array([np.nan if v is None else float(v) for v in values], dtype=float)


def tidy(records: Iterable[Mapping[str, Any]], names: Sequence[str] = NAMES) -> pd.DataFrame:
    """Return one row per fit and coefficient.

    Parameters
    ----------
    records : iterable of dict
        Runner records (``run``, ``noise``, ``estimator``, ``method``, ``truth`` (9,),
        ``theta`` (9,), ``stderr`` (9,) or None, ``success``, ``message``, ``cost``,
        ``n_evaluations``, ``n_iterations``, ``wall_time_s``; None means NaN).
    names : sequence of str
        Coefficient names, in the order of ``truth`` and ``theta``, for records without
        their own ``names`` (a study of tables records each fit's parameter names).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`TIDY_COLUMNS`; ``error`` = estimate - truth, ``rel_error_pct`` =
        |error| / |truth| * 100, ``covered`` = |error| <= COVERAGE_Z * stderr (NA where
        the fit failed, gave no finite standard error, or held the coefficient: sd 0, no
        interval to cover anything); with a study's ``[perturb]``, also ``mass_scale``
        (the run's drawn true mass over the file's).
    """
    rows: list[dict[str, Any]] = []
    default = tuple(names)
    for r in records:
        own = tuple(r.get("names") or default)  # a table fit's parameters (study/_tables)
        n = len(own)
        truth, theta, stderr = (_array(r.get(k), n) for k in ("truth", "theta", "stderr"))
        for j, name in enumerate(own):
            rows.append({
                "run": int(r["run"]), "noise": str(r["noise"]),
                "estimator": str(r["estimator"]), "method": str(r.get("method", "")),
                "coefficient": name, "truth": truth[j], "estimate": theta[j],
                "stderr": stderr[j], "success": bool(r["success"]),
                "message": str(r.get("message", "")),
                "cost": np.nan if r.get("cost") is None else float(r["cost"]),
                "n_evaluations": int(r.get("n_evaluations") or 0),
                "n_iterations": int(r.get("n_iterations") or 0),
                "wall_time_s": np.nan if r.get("wall_time_s") is None
                else float(r["wall_time_s"]),
                "mass_scale": float(r.get("mass_scale", np.nan)),  # [perturb]'s draw
            })
    frame = pd.DataFrame(rows, columns=[c for c in TIDY_COLUMNS
                                        if c not in ("error", "rel_error_pct", "covered")]
                         + ["mass_scale"])
    frame["error"] = frame["estimate"] - frame["truth"]
    frame["rel_error_pct"] = frame["error"].abs() / frame["truth"].abs() * 100.0
    ok = (frame["success"] & np.isfinite(frame["stderr"]) & (frame["stderr"] > 0)  # held: 0
          & np.isfinite(frame["error"]))
    covered = frame["error"].abs() <= COVERAGE_Z * frame["stderr"]
    frame["covered"] = pd.array(np.where(ok, covered, False), dtype="boolean")
    frame.loc[~ok, "covered"] = pd.NA
    drawn = ["mass_scale"] if frame["mass_scale"].notna().any() else []  # [perturb] only
    return frame[TIDY_COLUMNS + drawn]


def _reduce(group: pd.DataFrame) -> pd.Series:
    with np.errstate(over="ignore", invalid="ignore"):  # an absurd estimate: inf, not noise
        return _reduce_finite(group)


def _reduce_finite(group: pd.DataFrame) -> pd.Series:
    good = group[group["success"]]
    err = good["error"].to_numpy(dtype=float)
    truth = float(group["truth"].iloc[0])
    scale = abs(truth) if truth != 0.0 else np.nan  # no relative measure of a zero truth
    n_good = len(good)
    covered = good["covered"].dropna()
    return pd.Series({
        "method": group["method"].iloc[0],
        "truth": truth,
        "n_runs": len(group),
        "n_success": n_good,
        "success_rate": n_good / len(group) if len(group) else np.nan,
        "mean_estimate": good["estimate"].mean() if n_good else np.nan,
        "bias": err.mean() if n_good else np.nan,
        "bias_pct": err.mean() / scale * 100.0 if n_good else np.nan,
        "sd": good["estimate"].std(ddof=1) if n_good > 1 else np.nan,
        "sd_pct": good["estimate"].std(ddof=1) / scale * 100.0 if n_good > 1 else np.nan,
        "mean_abs_error_pct": good["rel_error_pct"].mean() if n_good else np.nan,
        "rmse": float(np.sqrt(np.mean(err**2))) if n_good else np.nan,
        "rmse_pct": float(np.sqrt(np.mean(err**2))) / scale * 100.0 if n_good else np.nan,
        "n_stderr": len(covered),
        "coverage": float(covered.astype(float).mean()) if len(covered) else np.nan,
        "median_wall_time_s": group["wall_time_s"].median(),
        "median_evaluations": group["n_evaluations"].median(),
    })


def summarize(frame: pd.DataFrame,
              cramer_rao: Mapping[str, Sequence[float] | None] | None = None,
              names: Sequence[str] = NAMES) -> pd.DataFrame:
    """Return the per (noise, estimator, coefficient) summary of a :func:`tidy` table.

    Parameters
    ----------
    frame : pandas.DataFrame
        Output of :func:`tidy`.
    cramer_rao : mapping of str or (str, str) to array_like (9,) or None, optional
        Noise label, or (noise label, estimator label), -> Cramér-Rao standard deviation
        of each coefficient (same units as the coefficient); an estimator's own entry
        wins over its noise condition's; missing or None gives NaN floor columns.
    names : sequence of str
        Coefficient order of ``cramer_rao`` vectors.

    Returns
    -------
    pandas.DataFrame
        One row per group, in the order of first appearance, with the columns named in
        the module docstring.
    """
    order = frame[GROUP].drop_duplicates()
    rows = []
    for key, group in frame.groupby(GROUP, sort=False):
        rows.append(pd.concat([pd.Series(dict(zip(GROUP, key, strict=True))),
                               _reduce(group)]))
    out = pd.DataFrame(rows)
    if out.empty:
        out = pd.DataFrame(columns=[*GROUP, "method", "truth"])
    out = order.merge(out, on=GROUP, how="left")
    index = {n: j for j, n in enumerate(names)}
    cr = []
    floors = cramer_rao or {}
    for noise, est, coef in zip(out["noise"], out["estimator"], out["coefficient"],
                                strict=True):
        floor = floors.get((noise, est), floors.get(noise))
        cr.append(np.nan if floor is None else float(floor[index[coef]]))
    out["cr_sd"] = np.array(cr, dtype=float)
    out["cr_sd_pct"] = out["cr_sd"] / out["truth"].abs() * 100.0
    out["sd_over_cr"] = out["sd"] / out["cr_sd"]
    return out.reset_index(drop=True)


def overall(summary: pd.DataFrame) -> pd.DataFrame:
    """Return one row per (noise, estimator): mean over the coefficients.

    Columns: ``mean_abs_error_pct`` (the paper's "average error"), ``coverage``
    (mean over coefficients with standard errors), ``success_rate``,
    ``median_wall_time_s`` and ``median_evaluations``.
    """
    grouped = summary.groupby(["noise", "estimator"], sort=False)
    return grouped.agg(method=("method", "first"),
                       mean_abs_error_pct=("mean_abs_error_pct", "mean"),
                       coverage=("coverage", "mean"),
                       success_rate=("success_rate", "first"),
                       median_wall_time_s=("median_wall_time_s", "first"),
                       median_evaluations=("median_evaluations", "first")).reset_index()


__all__ = ["COVERAGE_Z", "TIDY_COLUMNS", "overall", "summarize", "tidy"]
