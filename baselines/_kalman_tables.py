"""The EKF and UKF with coefficient tables (the airframe's ``[tables]``; private).

With ``[tables]`` the filters estimate the tables' parameters
(:meth:`aeroid.model.MachTables.parameter_names`: the constants and the table points
``Cx@M1.4`` / ``Cma@A1.2deg``) as the augmented state's constant part, in place of the
nine coefficients: ``z = [x (9), p (n_parameters), d]`` (``d``: the free accelerometer
position offsets, as without tables). The transition is one sample interval of the
model with the coefficients evaluated from the tables at each RK4 stage's Mach and total
angle of attack (:func:`aeroid.model.symbolic.interval_step_symbolic` with ``tables``,
the graph output-error differentiates), the measurement the model's outputs at the
sample's state; both Jacobians are CasADi's exact ones (:func:`table_functions`), and the
UKF's sigma points go through the same functions mapped over them. A table point's state
starts at the airframe's ``[prior]`` of its coefficient with the same sd as the
coefficient's (``initial_coefficient_sd_rel``), the points independent.

The passes are the filters' (:meth:`baselines._common.AugmentedFilterOptions.run_passes`:
the coefficients carried with ``PASS_INFLATION`` times their sd, the noise law refitted
before passes 2 and 3, stop at ``PASS_TOL``), over the tables' parameters; the estimator's
own pass (``one_pass``: the EKF's carried or smoothed pass, the UKF's, with held states
out of the filter and priors as their initial mean and sd,
:func:`baselines._held.held_pass`) runs each. Each point's standard error is the square
root of the final covariance's diagonal; ``info['table_floor']`` the points' Cramér-Rao
floor (output-error's information, :func:`baselines._tables_fit.data_table_floor`).

Not built with tables (one line each): IMU-error states, a steady wind or gusts, GNSS
aiding, saturated samples left out, several windows.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np

import aeroid
from aeroid.errors import EstimatorError
from aeroid.estimation import EstimationResult
from aeroid.flights import Flight, flight_record, model_constants
from aeroid.model import N_STATE, OUTPUT_CHANNELS, Constants, MachTables, symbolic
from baselines import _common, _kalman, _kalman_verdict
from baselines._augmented import buffered_steps
from baselines._oe_airdata import air_channels
from baselines._tables_fit import data_table_floor, floor_entries, mach_notes

__all__ = ["refuse_windows", "run_table_passes", "table_functions", "table_model",
           "table_setup"]

PassRunner = Callable[[_kalman.DiscreteModel, _common.FilterSetup], _kalman.FilterOutput]


@functools.lru_cache(maxsize=8)
def table_functions(const: Constants, dt: float, substeps: int, n_pieces: int, varying: bool,
                    position_free: tuple[int, ...], tables: MachTables
                    ) -> tuple[ca.Function, ...]:
    """Return the augmented model with tables: ``f``, ``h`` with Jacobians, and both without.

    ``f(z, pieces, exo_a, exo_b) -> (z_next, F)``, ``h(z, delta, exo, positions (6)) -> (y,
    H)`` (as :func:`aeroid.model.symbolic.augmented_functions`, the coefficients replaced by
    the tables' ``n_parameters``); ``f_x``, ``h_y`` the same without the Jacobians (the
    UKF's sigma points).
    """
    n_p = tables.n_parameters
    z = ca.SX.sym("z", N_STATE + n_p + len(position_free))
    sym = symbolic.interval_symbols(n_pieces, varying)
    x, theta, offsets = z[:N_STATE], z[N_STATE:N_STATE + n_p], z[N_STATE + n_p:]
    z_next = ca.vertcat(symbolic.interval_step_symbolic(x, theta, sym, const, dt, substeps,
                                                        tables), z[N_STATE:])
    f = ca.Function("f_tab", [z, *sym], [z_next, ca.densify(ca.jacobian(z_next, z))])
    f_x = ca.Function("f_tab_x", [z, *sym], [z_next])
    delta = ca.SX.sym("delta")
    exo = ca.SX.sym("exo", sym.exo_a.shape[0])
    pos_given = ca.SX.sym("pos", 6)
    pos = ca.vertcat(*[pos_given[c] + offsets[position_free.index(c)]
                       if c in position_free else pos_given[c] for c in range(6)])
    y = symbolic.measurement(x, delta, theta, pos, symbolic.sample_constants(const, exo),
                             tables)
    h = ca.Function("h_tab", [z, delta, exo, pos_given], [y, ca.densify(ca.jacobian(y, z))])
    h_y = ca.Function("h_tab_y", [z, delta, exo, pos_given], [y])
    return f, h, f_x, h_y


def table_model(flight: Flight, substeps: int, tables: MachTables,
                record: aeroid.model.Record | None = None,
                position_free: tuple[int, ...] = ()) -> _kalman.DiscreteModel:
    """Return the filters' augmented model ``[x, p, d]`` of ``flight`` with ``tables``.

    As :func:`baselines._augmented.augmented_model` (``record`` default: the logged
    deflection held), the coefficients the tables' parameters.
    """
    const = model_constants(flight)
    record = record or flight_record(flight)
    delta, pieces_table, exo_table = record.symbolic_inputs()
    delta = delta[0]
    varying = record.exogenous is not None
    free = tuple(position_free)
    f, h, f_x, h_y = table_functions(const, float(record.dt), int(substeps),
                                     int(record.n_pieces), varying, free, tables)
    n_aug = N_STATE + tables.n_parameters + len(free)
    pos_flat = flight.airframe.accel_positions.ravel()
    transition, observe = buffered_steps(f, h, n_aug, delta, pieces_table, exo_table, pos_flat)
    mapped: dict[tuple[str, int], ca.Function] = {}  # the UKF's sigma-point count

    def over(fun: ca.Function, n: int) -> ca.Function:
        key = (fun.name(), n)
        if key not in mapped:
            mapped[key] = fun.map(n)
        return mapped[key]

    def transition_batch(Z: np.ndarray, k: int) -> np.ndarray:
        out = over(f_x, len(Z))(Z.T, pieces_table[:, k], exo_table[:, k], exo_table[:, k + 1])
        return np.asarray(out).T

    def observe_batch(Z: np.ndarray, k: int) -> np.ndarray:
        out = over(h_y, len(Z))(Z.T, delta[k], exo_table[:, k], pos_flat)
        return np.asarray(out).T

    return _kalman.DiscreteModel(n_aug, len(OUTPUT_CHANNELS), transition, observe,
                                 transition_batch, observe_batch)


def table_setup(setup: _common.FilterSetup, tables: MachTables) -> _common.FilterSetup:
    """Return a filter start over the tables' parameters from one over the nine
    coefficients: each point as its coefficient (mean, sd, random walk), independent."""
    n_c = aeroid.model.N_COEFFICIENTS
    coefficients = slice(N_STATE, N_STATE + n_c)
    rest = slice(N_STATE + n_c, setup.x0.size)

    def widen(matrix: np.ndarray) -> np.ndarray:
        diagonal = tables.expand(np.diag(matrix)[coefficients])
        n_p = diagonal.size
        out = np.zeros((setup.x0.size - n_c + n_p,) * 2)
        states, tail = slice(0, N_STATE), slice(N_STATE + n_p, out.shape[0])
        out[states, states] = matrix[:N_STATE, :N_STATE]
        out[N_STATE:N_STATE + n_p, N_STATE:N_STATE + n_p] = np.diag(diagonal)
        out[tail, tail] = matrix[rest, rest]
        return out

    x0 = np.concatenate([setup.x0[:N_STATE], tables.expand(setup.x0[coefficients]),
                         setup.x0[rest]])
    return setup._replace(x0=x0, P0=widen(setup.P0), Q=widen(setup.Q))


def _refuse(est: Any, flight: Flight) -> None:
    """One line for what the filters do not do with tables yet (module docstring)."""
    given = [what for what, on in (
        (f"imu_errors = {getattr(est, 'imu_errors', 'none')}",
         getattr(est, "imu_errors", "none") != "none"),
        ("estimate_wind", getattr(est, "estimate_wind", False)),
        ("gust states", getattr(est, "gusts", False)),
        (f"aiding = {getattr(est, 'aiding', 'none')}", getattr(est, "aiding", "none") != "none"),
        ("saturated samples (metadata 'saturated')", bool(flight.metadata.get("saturated"))),
        (f"air_data = {getattr(est, 'air_data', 'inertial')}",
         getattr(est, "air_data", "inertial") == "measured"
         or (getattr(est, "air_data", "inertial") == "auto" and bool(air_channels(flight)))),
    ) if on]
    if given:
        raise EstimatorError(f"{est.name}: with [tables] the filter estimates the table points "
                             f"and the flight's states only; {', '.join(given)} is not "
                             "available with tables")


def refuse_windows(est: Any, windows: Any) -> None:
    """Several windows with ``[tables]`` in the filters: not built (one line)."""
    if windows.airframe.tables is not None:
        raise EstimatorError(f"{est.name}: several windows with [tables] are not built for "
                             "the filters; fit the windows with output-error or "
                             "equation-error, or one window at a time")


def run_table_passes(est: Any, flight: Flight, tables: MachTables, one_pass: PassRunner,
                     evaluations_per_pass: Callable[[_kalman.DiscreteModel], int],
                     holds: Any = None) -> EstimationResult:
    """The filter's passes over the tables' parameters (module docstring).

    ``one_pass(model, setup)``: the estimator's own pass (held states out of the filter);
    ``holds`` (:class:`aeroid.estimation.TableHolds`): for the floor of the free points.
    """
    _refuse(est, flight)
    setup = table_setup(est.setup(flight), tables)
    model = table_model(flight, est.substeps, tables,
                        flight_record(flight, est.input, est.delay_s), setup.position_free)
    points = slice(N_STATE, N_STATE + tables.n_parameters)
    passes = [one_pass(model, setup)]
    out, changes, warnings = passes[0], [], []
    while out.failed_at is None and len(passes) < est.max_passes:
        x0, P0 = setup.x0.copy(), setup.P0.copy()
        x0[points] = out.x[-1, points]
        P0[points, points] = _common.PASS_INFLATION ** 2 * out.P[points, points]
        law = (est.innovation_noise_law(out, setup) if len(passes) <= _common.LAW_REFITS
               else setup.law)
        nxt_setup = setup._replace(x0=x0, P0=P0, law=law)
        passes.append(nxt := one_pass(model, nxt_setup))
        if nxt.failed_at is not None:
            warnings.append(f"pass {len(passes)} diverged at t = {flight.t[nxt.failed_at]:.4f}"
                            f" s ({nxt.reason}); the result is pass {len(passes) - 1}'s")
            break
        with np.errstate(divide="ignore", invalid="ignore"):  # held: 0 / 0
            changes.append(float(np.nanmax(np.abs(nxt.x[-1, points] - out.x[-1, points])
                                           / nxt.sd[-1, points])))
        out, setup = nxt, nxt_setup
        if changes[-1] <= _common.PASS_TOL:
            break
    else:
        if changes and changes[-1] > _common.PASS_TOL:
            warnings.append(f"the passes had not settled after {len(passes)} (max_passes): "
                            f"the last moved a parameter by {changes[-1]:.2f} standard errors")
    result = _result(est, flight, tables, out, setup, points,
                     len(passes) * evaluations_per_pass(model), holds)
    result.info.update(passes=len(passes), pass_changes=changes,
                       noise_law={"a": setup.law[0], "b": setup.law[1]})
    result = _kalman_verdict.settle_verdict(result, passes, np.arange(points.start, points.stop),
                                            tables.parameter_names())
    return dataclasses.replace(result, warnings=(*result.warnings, *warnings))


def _result(est: Any, flight: Flight, tables: MachTables, out: _kalman.FilterOutput,
            setup: _common.FilterSetup, points: slice, n_evaluations: int, holds: Any
            ) -> EstimationResult:
    """A pass as the result over the tables' parameters (as the filters' own result)."""
    t = flight.t
    names = tables.parameter_names()
    history = {"axis": "time", "step": t, "theta": out.x[:, points],
               "theta_sd": out.sd[:, points]}
    info: dict[str, Any] = {"measurement_sd": setup.meas_sd, "state": out.x[:, :N_STATE],
                            "state_sd": out.sd[:, :N_STATE], "tables": tables.to_table(),
                            "speed_of_sound_mps": tables.speed_of_sound_mps,
                            "parameter_names": names}
    if out.failed_at is not None:
        return aeroid.failed_result(est.name, f"filter diverged at t = {t[out.failed_at]:.4f} "
                                    f"s: {out.reason}", history=history, info=info,
                                    n_iterations=int(out.failed_at))
    theta = out.x[-1, points]
    cov = out.P[points, points].copy()
    stderr = np.sqrt(np.diag(cov))
    half = len(t) // 2  # the fit check reads the innovations of the second half
    info["fit_residuals"] = {name: out.innovation[half:, j]
                             for j, name in enumerate(OUTPUT_CHANNELS)}
    positions = flight.airframe.accel_positions.ravel().copy()
    position_sd = np.zeros(6)
    for j, c in enumerate(setup.position_free):
        positions[c] += out.x[-1, points.stop + j]
        position_sd[c] = out.sd[-1, points.stop + j]
    info["accel_positions_m"] = positions.reshape(2, 3)
    info["accel_position_stderr_m"] = position_sd.reshape(2, 3)
    extra, low = floor_entries(names, stderr, data_table_floor(flight, theta, holds))
    info.update(extra)
    return EstimationResult(
        estimator=est.name, names=names, theta=theta, stderr=stderr, covariance=cov,
        cost=math.nan, success=True, message="", n_evaluations=n_evaluations,
        n_iterations=len(t), history=history, info=info,
        warnings=(*mach_notes(flight, tables), *low))
