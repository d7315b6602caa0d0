"""The augmented filters (EKF, UKF) over several windows with shared coefficients (private).

A pass runs the filter over the windows in turn. Each window starts its motion states
(and its IMU-error states, ``imu_errors``) afresh from its own first sample and sd, as a
single flight's filter does (:meth:`baselines._common.AugmentedFilterOptions.setup` of
that window, with its own noise law, input, density and inputs); the coefficient and
position states and their covariance are carried from the end of the previous window, with
no correlation to the new window's motion states (its start is measured, not predicted).
The passes (``max_passes``) repeat the whole sequence as a single flight's do
(:meth:`~baselines._common.AugmentedFilterOptions.run_passes`): the first window of a later
pass starts the coefficients at the previous pass's end with ``PASS_INFLATION`` times its
sd, the positions again at their given values and sd, and each window's noise law is
refitted to its own innovations before passes 2 .. ``LAW_REFITS + 1``.

A last pass that still moves a coefficient by more than
:data:`baselines._kalman_verdict.SETTLE_LIMIT_SE` of its standard error makes the fit no
success, as for one flight. The result is the end of the last window: coefficients, their
covariance; its history and
states run over the windows joined (:meth:`aeroid.flights.Windows.joined`), the fit check's
residuals are the second half of the joined innovations; each window's filtered start
state and, with ``imu_errors``, its IMU errors at its end are in
``info['window_parameters']`` (sd in ``info['window_parameter_stderr']``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from aeroid.errors import EstimatorError
from aeroid.estimation import EstimationResult
from aeroid.flights import Windows, flight_record
from baselines import _common, _held, _kalman, _kalman_verdict
from baselines._augmented import COEFFICIENTS, STATES, augmented_model

__all__ = ["run_windows"]

PassRunner = Callable[[_kalman.DiscreteModel, _common.FilterSetup], _kalman.FilterOutput]


def _one_pass(parts: list, run_filter: PassRunner, shared: slice,
              start: tuple[np.ndarray, np.ndarray] | None
              ) -> tuple[list[_kalman.FilterOutput], int | None]:
    """Filter the windows in turn; return their outputs and the failed window (or None)."""
    outs: list[_kalman.FilterOutput] = []
    carry = start
    for w, (model, setup) in enumerate(parts):
        if carry is not None:
            x0, P0 = setup.x0.copy(), setup.P0.copy()
            x0[shared] = carry[0]
            P0[shared, :] = 0.0
            P0[:, shared] = 0.0
            P0[shared, shared] = carry[1]
            setup = setup._replace(x0=x0, P0=P0)
            parts[w] = (model, setup)
        out = run_filter(model, setup)
        outs.append(out)
        if out.failed_at is not None:
            return outs, w
        carry = (out.x[-1, shared].copy(), out.P[shared, shared].copy())
    return outs, None


def _joined(outs: list[_kalman.FilterOutput]) -> _kalman.FilterOutput:
    """The windows' outputs one after the other (the last window's covariance)."""
    def cat(name: str) -> np.ndarray | None:
        parts = [getattr(o, name) for o in outs]
        return None if any(p is None for p in parts) else np.concatenate(parts)
    return _kalman.FilterOutput(cat("x"), cat("sd"), outs[-1].P, None, "", cat("innovation"),
                                cat("innovation_var"), cat("noise_var"))


def run_windows(est: Any, windows: Windows, run_filter: PassRunner,
                evaluations_per_pass: Callable[[_kalman.DiscreteModel, int], int],
                holds: Any = None) -> EstimationResult:
    """Run the filter's passes over the windows (module docstring) and return the result.

    ``run_filter(model, setup)`` is one forward pass of one window (EKF or UKF);
    ``evaluations_per_pass(model, n_samples)`` its model evaluations. ``holds``: held
    coefficients leave each window's state and priors start theirs, as one flight's
    (:func:`baselines._held.held_pass`); carried between windows at their held values.
    """
    if holds is not None and not holds.empty:
        plain = run_filter

        def run_filter(model: _kalman.DiscreteModel, setup: _common.FilterSetup
                       ) -> _kalman.FilterOutput:
            return _held.held_pass(model, setup, holds, plain)

    if getattr(est, "aiding", "none") != "none":
        raise EstimatorError(f"{est.name}: aiding = {est.aiding} is not available for several "
                             "windows yet (one flight at a time); set aiding = none")
    names = est.imu_error_names()
    parts = []
    for flight in windows:
        setup = est.setup(flight)
        model = augmented_model(flight, est.substeps,
                                flight_record(flight, est.input, est.delay_s),
                                setup.position_free)
        if names:
            model = _kalman.with_sensor_errors(model, len(names))
        parts.append((model, setup))
    first_setups = [setup for _, setup in parts]
    n_free = len(first_setups[0].position_free)
    shared = slice(COEFFICIENTS.start, COEFFICIENTS.stop + n_free)
    outs, failed = _one_pass(parts, run_filter, shared, None)
    evaluations = sum(evaluations_per_pass(m, f.n_samples)
                      for (m, _), f in zip(parts, windows, strict=True))
    joined = windows.joined()
    if failed is not None:
        return est.result(joined, _failed(outs, windows), parts[failed][1], evaluations)
    changes: list[float] = []
    warnings: list[str] = []
    ends = [outs[-1]]  # each pass's last window: the coefficients where the pass left them
    n_passes = 1
    while n_passes < est.max_passes:
        end = outs[-1]
        x_start = first_setups[0].x0[shared].copy()
        P_start = first_setups[0].P0[shared, shared].copy()
        x_start[:COEFFICIENTS.stop - COEFFICIENTS.start] = end.x[-1, COEFFICIENTS]
        P_start[:COEFFICIENTS.stop - COEFFICIENTS.start,
                :COEFFICIENTS.stop - COEFFICIENTS.start] = (
            _common.PASS_INFLATION**2 * end.P[COEFFICIENTS, COEFFICIENTS])
        nxt_parts = []
        for (model, setup), first, out in zip(parts, first_setups, outs, strict=True):
            law = est.innovation_noise_law(out, setup) if n_passes <= _common.LAW_REFITS \
                else setup.law
            nxt_parts.append((model, first._replace(law=law)))
        nxt, failed = _one_pass(nxt_parts, run_filter, shared, (x_start, P_start))
        n_passes += 1
        if failed is not None:
            at = windows.flights[failed].t[nxt[-1].failed_at]
            warnings.append(f"pass {n_passes} diverged in window {windows.names[failed]} at "
                            f"t = {at:.4f} s ({nxt[-1].reason}); the result is pass "
                            f"{n_passes - 1}'s")
            break
        changes.append(float(np.nanmax(np.abs(nxt[-1].x[-1, COEFFICIENTS]  # held: 0/0
                                           - outs[-1].x[-1, COEFFICIENTS])
                                    / nxt[-1].sd[-1, COEFFICIENTS])))
        outs, parts = nxt, nxt_parts
        ends.append(outs[-1])
        if changes[-1] <= _common.PASS_TOL:
            break
    else:
        if changes and changes[-1] > _common.PASS_TOL:
            warnings.append(f"the passes had not settled after {n_passes} (max_passes): the "
                            f"last moved a coefficient by {changes[-1]:.2f} standard errors")
    result = est.result(joined, _joined(outs), parts[-1][1], n_passes * evaluations)
    info = dict(result.info)
    info.update(passes=n_passes, pass_changes=changes,
                noise_law={name: {"a": s.law[0], "b": s.law[1]}
                           for name, (_, s) in zip(windows.names, parts, strict=True)})
    info.update(_window_parameters(windows, outs, names))
    result = dataclasses.replace(result, info=info, warnings=(*result.warnings, *warnings))
    judged = np.arange(COEFFICIENTS.start, COEFFICIENTS.stop)  # passes that do not settle
    return _kalman_verdict.settle_verdict(result, ends, judged, tuple(result.names))


def _window_parameters(windows: Windows, outs: list[_kalman.FilterOutput],
                       names: tuple[str, ...]) -> dict[str, Any]:
    """Each window's filtered first state and its IMU errors at its end (and their sd)."""
    values, sds = {}, {}
    k = len(names)
    for name, out in zip(windows.names, outs, strict=True):
        values[name] = {"initial_state": out.x[0, STATES].tolist()}
        sds[name] = {"initial_state": out.sd[0, STATES].tolist()}
        if k:
            values[name].update(zip(names, out.x[-1, -k:].tolist(), strict=True))
            sds[name].update(zip(names, np.sqrt(np.diag(out.P)[-k:]).tolist(), strict=True))
    return {"window_parameters": values, "window_parameter_stderr": sds}


def _failed(outs: list[_kalman.FilterOutput], windows: Windows) -> _kalman.FilterOutput:
    """The first pass's outputs joined, failed at the failing window's sample (joined index)."""
    out = outs[-1]
    before = sum(f.n_samples for f in windows.flights[:len(outs) - 1])
    rest = sum(f.n_samples for f in windows.flights[len(outs):])
    pad = [np.full((rest, a.shape[1]), np.nan) for a in (out.x, out.innovation)]
    joined = _joined(outs)
    x = np.concatenate([joined.x, pad[0]])
    sd = np.concatenate([joined.sd, pad[0]])
    innov = np.concatenate([joined.innovation, pad[1]])
    return _kalman.FilterOutput(x, sd, out.P, before + int(out.failed_at), out.reason, innov)
