"""Coefficient tables in Mach over several windows (private).

The windows share the tables' parameters (the constants and the table points, at the
same knots) and keep their own nuisances (initial state, delay, IMU errors; output-error)
and their own reconstruction (equation-error). Each window's Mach number uses its own
speed of sound (its airframe's ``[tables] temperature_K``, else ISA at its altitude), so
windows flown in different air share points at the same Mach.

:func:`shared_tables` resolves the knots once for all windows: knots given as a count
are chosen over the windows' Mach ranges together (a gap between windows is allowed),
and a table point is refused only when no sample of any window informs it. Each window's
airframe then carries those knots, and its metadata :data:`SHARED_KEY` so that
:func:`baselines._tables_fit.flight_tables` does not refuse a point another window
informs. :func:`equation_error_windows` stacks the windows' expanded regressions.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

import aeroid
from aeroid import estimation as rc
from aeroid.errors import EstimatorError
from aeroid.flights import Windows
from aeroid.model import MachTables
from aeroid.model import tables as mach_tables
from baselines._common import pooled_sd
from baselines._tables_fit import (
    BLOCK_SAMPLES,
    SHARED_KEY,
    expand_regressors,
    mach_notes,
    solve_table_subproblems,
    subproblem_columns,
)

__all__ = ["SHARED_KEY", "equation_error_windows", "shared_tables"]

def shared_tables(windows: Windows) -> tuple[Windows, list[MachTables]]:
    """Return the windows with the knots resolved over all of them, and each one's tables.

    Raises
    ------
    EstimatorError
        Windows whose ``[tables]`` differ, or a table point no window's sample informs
        (one line naming the points and the windows' Mach range).
    """
    spec = windows.airframe.tables
    for name, flight in windows.items():
        if flight.airframe.tables != spec:
            raise EstimatorError(f"windows: window {name!r} has other [tables] than "
                                 f"{windows.names[0]!r}; the windows share their tables")
    resolved, every, alpha = rc.windows_table_spec(windows)  # counted knots over them all
    knots, angles = resolved.knots, resolved.angle_knots
    empty = [mach_tables.point_name(name, k) for name, ks in knots
             for k, weight in zip(ks, mach_tables.basis(ks, every).max(axis=0), strict=True)
             if weight == 0.0]
    if empty:
        raise EstimatorError(f"tables: no sample of any window informs {', '.join(empty)} "
                             f"(the windows span Mach {every.min():.4g}-{every.max():.4g}); "
                             "give knots within it, or a knot count")
    empty = [f"{name}{mach_tables.ANGLE_SEPARATOR}{k:g}deg" for name, ks in angles
             for k, weight in zip(ks, mach_tables.basis(np.radians(ks), alpha).max(axis=0),
                                  strict=True) if weight == 0.0]
    if empty:
        raise EstimatorError(f"tables: no sample of any window informs {', '.join(empty)} "
                             f"(the windows span the total angle of attack "
                             f"{np.degrees(alpha.min()):.3g}-{np.degrees(alpha.max()):.3g} deg);"
                             " give knots within it, or a knot count")
    flights = tuple(dataclasses.replace(f, airframe=f.airframe.replace(tables=resolved),
                                        metadata={**f.metadata, SHARED_KEY: True})
                    for f in windows)
    out = Windows(flights, windows.names)
    return out, [f.airframe.mach_tables() for f in out]


def equation_error_windows(est: Any, windows: Windows, covariance: str, *,
                           theta_only: bool = False, holds: Any = None
                           ) -> aeroid.EstimationResult:
    """Equation-error's two-step table fit of several windows: the expanded regressions
    of the windows (each at its own Mach) stacked, the tables' parameters shared; row
    weights pooled over the windows as :mod:`baselines._ee_windows` does. ``holds``
    (:class:`aeroid.estimation.TableHolds` over the shared points): held columns to the
    left side and priors as pseudo-observations in the stacked rows, as one flight's.
    """

    refused = [what for what, on in (("one_step", est.one_step),
                                     ("lateral_rows", est.lateral_rows),
                                     ('smoothing = "both"', est.smoothing == "both")) if on]
    if refused:
        raise EstimatorError(f"equation-error: with [tables] it fits the two-step form only; "
                             f"{', '.join(refused)} is not available with tables")
    windows, per = shared_tables(windows)
    recs = [rc.reconstruct(flight) for flight in windows]
    ys = [rc.regression_target(rec, smoothing=est.smoothing) for rec in recs]
    Xs = []
    for flight, rec, tables in zip(windows, recs, per, strict=True):
        mach = tables.mach(flight.states())
        alpha = tables.alpha_total(flight.states()) if tables.angle_knots else None
        Xs.append(np.concatenate([
            expand_regressors(part, tables, mach[a:b], None if alpha is None else alpha[a:b])
            for a, b, part in rc.regressor_blocks(
                flight, smoothing=est.smoothing, window=rec.smoothing_window,
                block=BLOCK_SAMPLES)]))
    counts = [f.n_samples for f in windows]
    sd = pooled_sd([rc.estimate_noise_sd(rec.fm) for rec in recs], counts)
    theta, cov, corr, sigma2, cost, bandwidth = solve_table_subproblems(
        np.concatenate(Xs), np.vstack(ys), sd, per[0], covariance, holds)
    rows = tuple(p[1] for p in subproblem_columns(per[0]))
    info: dict[str, Any] = {"sigma2": sigma2, "subproblems": [p[0] for p in
                                                              subproblem_columns(per[0])],
                            "reconstruction_rank": [rec.rank for rec in recs],
                            "hac_bandwidth": bandwidth, "correlation": corr,
                            "tables": per[0].to_table()}
    warnings: tuple[str, ...] = ()
    if not theta_only:
        parts = [rc.regression_fit(rec, X, y, theta, rows)
                 for rec, X, y in zip(recs, Xs, ys, strict=True)]
        for key in ("fit_residuals", "fit_signals"):
            info[key] = {k: np.concatenate([p[key][k] for p in parts]) for k in parts[0][key]}
        info["fit_noise_sd"] = {k: float(pooled_sd([np.array(p["fit_noise_sd"][k])
                                                  for p in parts], counts))
                                for k in parts[0]["fit_noise_sd"]}
        warnings = tuple(f"window {name}: {note}" for (name, flight), tables in
                         zip(windows.items(), per, strict=True)
                         for note in mach_notes(flight, tables))
    warnings += tuple(f"residuals of {label} stay correlated beyond the Newey-West cap; its "
                      "standard errors are not reliable"
                      for label, bw in bandwidth.items() if bw["capped"])
    return aeroid.EstimationResult(
        estimator=est.name, names=per[0].parameter_names(), theta=theta,
        stderr=np.sqrt(np.abs(np.diag(cov))), covariance=cov, cost=float(cost), success=True,
        message="", n_evaluations=1, n_iterations=1, info=info, warnings=warnings)
