"""Fits with coefficient tables in Mach (the airframe's ``[tables]``; private).

The airframe's ``[tables]`` (:class:`aeroid.model.TableSpec`) makes some coefficients
piecewise-linear functions of Mach (:class:`aeroid.model.MachTables`); the fits then
estimate the tables' parameters (:meth:`~aeroid.model.MachTables.parameter_names`: the
constants and the table points ``Cx@M1.4``), and their result's ``names`` say so.

* **Equation-error** (:func:`equation_error_tables`): the loads are linear in the
  coefficients and a table is linear in its points, so the regressor of table point
  ``i`` of coefficient ``j`` is the coefficient's regressor times the hat function
  ``B_i`` at each sample's Mach (:func:`expand_regressors`); each SEBM sub-problem takes
  the expanded columns of its coefficients and is solved as equation-error's
  (:func:`baselines._ee_least_squares._lstsq`, Newey-West covariance).
* **Output-error** evaluates the tables at each RK4 stage's Mach inside its CasADi graph
  (:func:`aeroid.model.symbolic_record` with ``tables``); its Cramér-Rao covariance
  gives each point's standard error. :func:`table_floor` is the Cramér-Rao floor of the
  points at given parameters with given noise (the same information, at the truth).
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np

import aeroid
from aeroid import estimation as rc
from aeroid.errors import EstimatorError
from aeroid.flights import Flight, air_temperature, flight_mach_tables, speed_of_sound_note
from aeroid.model import NAMES, MachTables
from aeroid.model import tables as mach_tables
from baselines._ee_least_squares import (
    SUBPROBLEMS,
    _correlation,
    _lstsq,
    moved_positions,
    with_position_consider,
)
from baselines._held import ee_held_check, ee_prior_rows
from baselines._oe_record import RecordModel

#: Initial-state components the floor's record model takes as nuisance parameters: the
#: rates, as output-error estimates them by default.
FLOOR_FREE_STATES = (3, 4, 5)
#: Data whose every output channel's noise level (from the data) is below this fraction
#: of its RMS are noise-free: no floor (the fit check's NOISE_FREE_FRACTION).
NOISE_FREE_FRACTION = 1e-3
#: A channel's noise level is at least this fraction of its RMS (the fit check's
#: RESOLUTION: a clean channel counts much, not infinitely).
RESOLUTION = 1e-5
#: Standard errors below this fraction of the table floor claim more than the data allow
#: (a warning; the fit check's FLOOR_FRACTION for constant coefficients).
FLOOR_FRACTION = 0.5

#: Metadata key of a window whose knots were resolved over all windows
#: (:func:`baselines._tables_windows.shared_tables`): another window may inform a point.
SHARED_KEY = "tables_shared_over_windows"

#: Time samples per block of the regressors (equation-error's).
BLOCK_SAMPLES = rc.REGRESSION_BLOCK


def flight_tables(flight: Flight) -> MachTables | None:
    """Return the tables of ``flight`` (its airframe's ``[tables]``; counted knots chosen
    from its Mach range), or None when it has none.

    Raises
    ------
    EstimatorError
        One line naming the table points no sample informs (their hat functions are zero
        at every sample's Mach): the fit could not determine them.
    """
    if flight.airframe.tables is None:
        return None
    states = flight.states()
    tables = flight_mach_tables(flight, states)  # Mach per sample from an air_temperature
    mach = tables.mach(states, air_temperature(flight))
    empty = [mach_tables.point_name(name, k) for name, knots in tables.knots
             for k, weight in zip(knots, mach_tables.basis(knots, mach).max(axis=0),
                                  strict=True) if weight == 0.0]
    if empty and not flight.metadata.get(SHARED_KEY):  # windows: checked over them all
        raise EstimatorError(f"tables: no sample informs {', '.join(empty)} (the flight "
                             f"spans Mach {mach.min():.4g}-{mach.max():.4g}); give knots "
                             "within it, or a knot count")
    if tables.angle_knots and not flight.metadata.get(SHARED_KEY):  # windows: over them all
        alpha = tables.alpha_total(states)
        empty = [point for name, knots in tables.angle_knots
                 for point, weight in zip(tables.point_names(name), mach_tables.basis(
                     knots, alpha).max(axis=0), strict=True) if weight == 0.0]
        if empty:
            raise EstimatorError(f"tables: no sample informs {', '.join(empty)} (the flight "
                                 f"spans the total angle of attack {np.degrees(alpha.min()):.3g}"
                                 f"-{np.degrees(alpha.max()):.3g} deg); give knots within it, "
                                 "or a knot count")
    return tables


class FitsTables:
    """Mixin of an estimator that fits the airframe's ``[tables]`` (the others refuse)."""

    fits_tables: ClassVar[bool] = True


def coefficient_layout(flight: Flight, pso_warm_start: bool = False
                       ) -> tuple[tuple[str, ...], np.ndarray]:
    """Return the names of the coefficient parameters and their prior.

    Without tables: :data:`aeroid.model.NAMES` and the airframe's prior; with tables,
    their parameter names and the prior's flat tables (each point at the prior value).
    ``pso_warm_start`` (output-error's option, a search of the nine constants) is
    refused with tables in one line.
    """
    prior = flight.airframe.prior_vector()
    tables = flight_tables(flight)
    if tables is None:
        return NAMES, prior
    if pso_warm_start:
        raise EstimatorError("output-error: pso_warm_start searches the constant "
                             "coefficients; it is not available with [tables]")
    return tables.parameter_names(), tables.expand(prior)


def record_tables(info: dict[str, Any], model: Any, flight: Flight, holds: Any = None
                  ) -> list[str]:
    """Output-error's result with tables: ``info['parameter_names']`` with the tables'
    names, ``info['tables']`` (the knots); returns the Mach notes (:func:`mach_notes`).
    ``holds`` (:class:`aeroid.estimation.TableHolds`): the floor of the free parameters
    with the priors. Nothing without tables."""
    if model.tables is None:
        return []
    rest = tuple(info["parameter_names"])[len(NAMES):]
    info["parameter_names"] = (*model.tables.parameter_names(), *rest)
    info["tables"] = model.tables.to_table()
    info["speed_of_sound"] = speed_of_sound_note(flight, model.tables)
    n = model.tables.n_parameters
    stderr = np.asarray(info["parameter_stderr"][:n], dtype=float)
    extra, low = floor_entries(model.tables.parameter_names(), stderr,
                               data_table_floor(flight, np.asarray(info["parameters"][:n]),
                                                holds))
    info.update(extra)
    return list(mach_notes(flight, model.tables)) + list(low)


def mach_notes(flight: Flight, tables: MachTables) -> tuple[str, ...]:
    """One line per table whose knots the flight's Mach range leaves: what was done."""
    mach = tables.mach(flight.states(), air_temperature(flight))
    lo, hi = float(np.min(mach)), float(np.max(mach))
    notes = []
    for name, knots in tables.knots:
        beyond = [f"below {knots[0]:g}" if lo < knots[0] else "",
                  f"above {knots[-1]:g}" if hi > knots[-1] else ""]
        beyond = [b for b in beyond if b]
        if beyond:
            notes.append(f"tables: the flight's Mach {lo:.4g}-{hi:.4g} goes "
                         f"{' and '.join(beyond)}, beyond {name}'s knots: its end values "
                         "hold there")
    if tables.angle_knots:
        alpha = np.degrees(tables.alpha_total(flight.states()))
        lo, hi = float(np.min(alpha)), float(np.max(alpha))
        for name, knots in tables.angle_knots:
            ends = np.degrees([knots[0], knots[-1]])
            beyond = [b for b in (f"below {ends[0]:g}" if lo < ends[0] else "",
                                  f"above {ends[1]:g}" if hi > ends[1] else "") if b]
            if beyond:
                notes.append(f"tables: the flight's total angle of attack {lo:.3g}-{hi:.3g} "
                             f"deg goes {' and '.join(beyond)} deg, beyond {name}'s knots: "
                             "its end values hold there")
    return tuple(notes)


def expand_regressors(X: np.ndarray, tables: MachTables, mach: np.ndarray,
                      alpha_total: np.ndarray | None = None) -> np.ndarray:
    """Return the regressors of the tables' parameters, shape (n, rows, n_parameters).

    ``X`` (n, rows, 9): the regressors of the nine coefficients (the loads at unit
    coefficient vectors, :func:`aeroid.model.regressors`); ``mach`` (n,) each sample's
    Mach number; ``alpha_total`` (n,) its total angle of attack [rad] (with angle tables).
    A table point's column is its coefficient's times its hat function.
    """
    given = dict(tables.knots)
    by_angle = dict(tables.angle_knots)
    if by_angle and alpha_total is None:
        raise EstimatorError("tables: angle tables need each sample's angle of attack")
    columns = []
    for j, (name, _) in enumerate(tables.layout):
        if name in given:
            columns.append(X[..., j, None] * mach_tables.basis(given[name], mach)[:, None, :])
        elif name in by_angle:
            columns.append(X[..., j, None]
                           * mach_tables.basis(by_angle[name], alpha_total)[:, None, :])
        else:
            columns.append(X[..., j, None])
    return np.concatenate(columns, axis=-1)


def subproblem_columns(tables: MachTables) -> tuple[tuple[str, int, list[int]], ...]:
    """The SEBM sub-problems (label, load row, parameter columns) with the tables' columns."""
    layout = tables.layout
    return tuple((label, row, [i for c in cols for i in range(layout[c][1].start,
                                                              layout[c][1].stop)])
                 for label, row, cols in SUBPROBLEMS)


def equation_error_tables(est: Any, flight: Flight, tables: MachTables, holds: Any = None
                          ) -> aeroid.EstimationResult:
    """Equation-error's two-step fit of the tables' parameters (module docstring).

    ``est``: the :class:`baselines.equation_error.EquationErrorEstimator` (its
    ``smoothing``, ``covariance`` and ``positions`` options). The one-step form, the
    lateral rows and ``smoothing="both"`` (which smooths the regressors before the hat
    functions would multiply them) are refused in one line. ``holds``
    (:class:`aeroid.estimation.TableHolds`): held parameters' columns move to the left
    side, priors are weighted pseudo-observations (:func:`baselines._held.ee_prior_rows`),
    and each held value is compared with the free fit's (:func:`baselines._held.ee_held_check`:
    a warning).
    """
    refused = [what for what, on in (("one_step", est.one_step),
                                     ("lateral_rows", est.lateral_rows),
                                     ('smoothing = "both"', est.smoothing == "both")) if on]
    if refused:
        raise EstimatorError(f"equation-error: with [tables] it fits the two-step form only; "
                             f"{', '.join(refused)} is not available with tables")
    result = _solve(est, flight, tables, est.covariance, holds=holds)
    if holds is not None and holds.held:  # the data against the held values (a warning)
        result = ee_held_check(result, _solve(est, flight, tables, est.covariance), holds)
    sd = flight.airframe.accel_position_sd.ravel()
    free = np.flatnonzero(sd)
    if est.positions == "known" or free.size == 0:
        return result
    return with_position_consider(  # consider the uncertain positions
        result, flight.airframe.accel_positions.ravel(), sd,
        lambda pos: _solve(est, dataclasses.replace(
            flight, airframe=moved_positions(flight.airframe, pos)), tables, "ols",
            theta_only=True, holds=holds).theta)


def solve_table_subproblems(X: np.ndarray, y: np.ndarray, sd: np.ndarray, tables: MachTables,
                            covariance: str, holds: Any = None) -> tuple:
    """Solve the SEBM sub-problems over the tables' parameters (equation-error's).

    ``X`` (n, rows, n_parameters) the expanded regressors (:func:`expand_regressors`),
    ``y`` (n, rows) the loads, ``sd`` (rows,) their noise sd (the rows' weights);
    ``holds`` (:class:`aeroid.estimation.TableHolds`): held columns to the left side,
    priors as pseudo-observations. Returns ``theta, cov, corr, sigma2, cost, bandwidth``
    (as :func:`baselines._ee_least_squares.solve_subproblems`).
    """
    n_p = tables.n_parameters
    theta, cov = np.full(n_p, np.nan), np.zeros((n_p, n_p))
    corr = np.full((n_p, n_p), np.nan)
    sigma2, bandwidth, cost = {}, {}, 0.0
    names = tables.parameter_names()
    held = {} if holds is None else dict(holds.held)
    for label, row, all_cols in subproblem_columns(tables):
        A = X[:, row, all_cols] / sd[row]
        b = y[:, row] / sd[row]
        local = [i for i, c in enumerate(all_cols) if names[c] in held]
        if local:  # held terms to the left side
            values = np.array([held[names[all_cols[i]]] for i in local])
            b = b - A[:, local] @ values
            theta[[all_cols[i] for i in local]] = values
            A = np.delete(A, local, axis=1)
        cols = [c for c in all_cols if names[c] not in held]
        if not cols:
            continue
        th, cv, s2, bandwidth[label] = _lstsq(A, b, n_time=y.shape[0], covariance=covariance)
        th, cv = ee_prior_rows(A, b, th, cv, s2, cols, holds, names)
        theta[cols] = th
        cov[np.ix_(cols, cols)] = cv
        corr[np.ix_(cols, cols)] = _correlation(A)
        sigma2[label] = s2
        cost += s2 * max(A.shape[0] - len(cols), 1)
    return theta, cov, corr, sigma2, cost, bandwidth


def _solve(est: Any, flight: Flight, tables: MachTables, covariance: str, *,
           theta_only: bool = False, holds: Any = None) -> aeroid.EstimationResult:
    rec = rc.reconstruct(flight)
    y = rc.regression_target(rec, smoothing=est.smoothing)
    mach = tables.mach(flight.states(), air_temperature(flight))
    alpha = tables.alpha_total(flight.states()) if tables.angle_knots else None
    X = np.concatenate([expand_regressors(part, tables, mach[start:stop],
                                          None if alpha is None else alpha[start:stop])
                        for start, stop, part in rc.regressor_blocks(
                            flight, smoothing=est.smoothing, window=rec.smoothing_window,
                            block=BLOCK_SAMPLES)])
    theta, cov, corr, sigma2, cost, bandwidth = solve_table_subproblems(
        X, y, rc.estimate_noise_sd(rec.fm), tables, covariance, holds)
    problems = subproblem_columns(tables)
    info: dict[str, Any] = {"sigma2": sigma2, "subproblems": [p[0] for p in problems],
                            "reconstruction_rank": rec.rank, "hac_bandwidth": bandwidth,
                            "correlation": corr, "tables": tables.to_table(),
                            "speed_of_sound_mps": tables.speed_of_sound_mps,
                            "speed_of_sound": speed_of_sound_note(flight, tables),
                            "mach_range": (float(mach.min()), float(mach.max()))}
    low: tuple[str, ...] = ()
    if not theta_only:
        info.update(rc.regression_fit(rec, X, y, theta, tuple(p[1] for p in problems)))
        extra, low = floor_entries(tables.parameter_names(), np.sqrt(np.abs(np.diag(cov))),
                                   data_table_floor(flight, theta, holds))
        info.update(extra)
    capped = [label for label, bw in bandwidth.items() if bw["capped"]]
    warnings = mach_notes(flight, tables) + low + tuple(
        f"residuals of {label} stay correlated beyond the Newey-West cap; its standard "
        "errors are not reliable" for label in capped)
    return aeroid.EstimationResult(
        estimator=est.name, names=tables.parameter_names(), theta=theta,
        stderr=np.sqrt(np.abs(np.diag(cov))), covariance=cov, cost=float(cost), success=True,
        message="", n_evaluations=1, n_iterations=1, info=info, warnings=warnings)


def table_floor(flight: Flight, parameters: np.ndarray, noise_sd: np.ndarray, *,
                substeps: int = 2, input: str = "hold",  # noqa: A002
                holds: Any = None) -> np.ndarray:
    """Return the Cramér-Rao floor of the tables' parameters, shape (n_parameters,).

    The output-error information ``sum_k J_k^T R^-1 J_k`` of the flight's record (both
    triads and the rates, :data:`aeroid.model.OUTPUT_CHANNELS`) at ``parameters`` (the
    tables' constants and points, e.g. the truth), with white noise of sd ``noise_sd``
    (one per output channel) and the initial rates as nuisance parameters; the square
    root of the diagonal of its inverse, in the parameters' units. ``holds``
    (:class:`aeroid.estimation.TableHolds`): the held parameters leave the information
    (NaN: known) and the priors' ``1 / sd^2`` join it.
    """
    tables = flight_tables(flight)
    if tables is None:
        raise EstimatorError("table floor: the flight's airframe has no [tables]")
    p = np.asarray(parameters, dtype=float)
    sd = np.asarray(noise_sd, dtype=float)
    if p.shape != (tables.n_parameters,) or sd.shape != (len(aeroid.model.OUTPUT_CHANNELS),):
        raise EstimatorError(f"table floor: expected {tables.n_parameters} parameters and "
                             f"{len(aeroid.model.OUTPUT_CHANNELS)} noise sd, got "
                             f"{p.shape} and {sd.shape}")
    scale = np.concatenate([np.where(p != 0.0, p, 1.0), np.ones(len(FLOOR_FREE_STATES))])
    model = RecordModel(flight, input=input, substeps=substeps, x0_free=FLOOR_FREE_STATES,
                        position_free=(), compiled=True, x0=flight.states()[0], scale=scale,
                        delay_s=0.0, estimate_delay=False, tables=tables)
    _, J = model.outputs_jacobian(np.concatenate([p / scale[:p.size],
                                                  np.zeros(len(FLOOR_FREE_STATES))]))
    Jw = J / sd[:, None, None]
    F = np.einsum("mnp,mnq->pq", Jw, Jw)
    keep = np.arange(F.shape[0])
    if holds is not None and not holds.empty:
        F[:p.size, :p.size] += np.diag(holds.prior_information() * scale[:p.size] ** 2)
        keep = np.concatenate([holds.free_index, np.arange(p.size, F.shape[0])])
    out = np.full(F.shape[0], np.nan)
    out[keep] = np.sqrt(np.diag(np.linalg.inv(F[np.ix_(keep, keep)]))) * np.abs(scale[keep])
    return out[:p.size]


def data_table_floor(flight: Flight, theta: np.ndarray, holds: Any = None
                     ) -> np.ndarray | None:
    """Return :func:`table_floor` at ``theta`` with each channel's noise level estimated
    from the data (:func:`aeroid.estimation.data_noise_levels`), or None on noise-free
    data (every channel below :data:`NOISE_FREE_FRACTION` of its RMS) or without a
    finite floor."""
    channels = aeroid.model.OUTPUT_CHANNELS
    levels = rc.data_noise_levels(flight, channels)
    rms = np.array([float(np.sqrt(np.mean(flight[c] ** 2))) for c in channels])
    sd = np.array([levels[c] for c in channels])
    if not np.any(sd > NOISE_FREE_FRACTION * rms) or not np.all(np.isfinite(theta)):
        return None
    try:
        floor = table_floor(flight, theta, np.maximum(sd, RESOLUTION * rms), holds=holds)
    except np.linalg.LinAlgError:
        return None
    free = np.ones(floor.size, bool) if holds is None or holds.empty else holds.free_mask
    return floor if np.all(np.isfinite(floor[free])) else None


def floor_entries(names: tuple[str, ...], stderr: np.ndarray, floor: np.ndarray | None
                  ) -> tuple[dict[str, Any], tuple[str, ...]]:
    """``info['table_floor']`` (name -> floor; NaN for a held parameter) and the warning
    of standard errors below :data:`FLOOR_FRACTION` of it (none without a floor)."""
    if floor is None:
        return {}, ()
    low = [f"{n} ({s:.3g} < {f:.3g})" for n, s, f in zip(names, stderr, floor, strict=True)
           if np.isfinite(s) and s < FLOOR_FRACTION * f]
    info = {"table_floor": dict(zip(names, floor.tolist(), strict=True))}
    return info, ((f"standard errors claim more than the data allow: below half the "
                   f"Cramér-Rao floor for {', '.join(low)}",) if low else ())


__all__ = ["SHARED_KEY", "FitsTables", "coefficient_layout", "data_table_floor",
           "equation_error_tables", "expand_regressors", "flight_tables", "floor_entries",
           "mach_notes", "record_tables", "solve_table_subproblems", "subproblem_columns",
           "table_floor"]
