"""Equation-error over several windows: the regressions stacked (private).

Each window is reconstructed on its own (:func:`aeroid.estimation.reconstruct`: its own
density, mass, inputs, derivatives), and its rows join one least-squares problem per
sub-problem (two-step) or one problem (one-step): the regressors and targets of the
windows one after the other, with the coefficients shared. Row weights (two-step: the
loads' noise sd; one-step: the channels' residual sd) are pooled over the windows as a
mean square weighted by their samples. The Newey-West covariance runs over the stacked
rows (a join is one lag among hundreds of samples).

The positions' consider term (``positions="consider"``) moves the shared positions in
every window at once. The gyro-only floor of Cl0 and Clp is given per window
(``info['window_gyro_only_floor']``): the floor of the stack is not computed.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

import aeroid
from aeroid import estimation as rc
from aeroid.estimation import EstimationResult
from aeroid.flights import Windows
from baselines import _held
from baselines._common import pooled_sd
from baselines._ee_least_squares import (
    LATERAL,
    SUBPROBLEMS,
    _correlation,
    _lstsq,
    moved_positions,
    one_step_target,
    solve_subproblems,
    with_position_consider,
)
from baselines._tables_windows import equation_error_windows

__all__ = ["run_windows"]


def _two_step(est: Any, windows: Windows, covariance: str, theta_only: bool,
              holds: Any = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, dict]:
    recs = [rc.reconstruct(flight) for flight in windows]
    ys = [rc.regression_target(rec, smoothing=est.smoothing) for rec in recs]
    y = np.vstack(ys)

    def blocks(w: int | None = None) -> Iterator[tuple[int, int, np.ndarray]]:
        offset = 0
        for k, (flight, rec) in enumerate(zip(windows, recs, strict=True)):
            if w is None or w == k:
                for a, b, part in rc.regressor_blocks(
                        flight, smoothing=est.smoothing, window=rec.smoothing_window,
                        block=rc.REGRESSION_BLOCK):
                    yield (a + offset, b + offset, part) if w is None else (a, b, part)
            offset += flight.n_samples

    sd = pooled_sd([rc.estimate_noise_sd(rec.fm) for rec in recs], [f.n_samples for f in windows])
    theta, cov, corr, sigma2, cost, bandwidth = solve_subproblems(
        blocks(), y, sd, lateral_rows=est.lateral_rows, covariance=covariance,
        held=_held.held_dict(holds), holds=holds)
    info: dict[str, Any] = {"sigma2": sigma2, "subproblems": [s[0] for s in SUBPROBLEMS],
                            "reconstruction_rank": [rec.rank for rec in recs],
                            "hac_bandwidth": bandwidth}
    if not theta_only:
        rows = tuple(row for _, row, _ in SUBPROBLEMS)
        if est.lateral_rows:
            rows = tuple(sorted(rows + tuple(LATERAL.values())))
        parts = [rc.regression_fit(rec, blocks(w), yw, theta, rows)
                 for w, (rec, yw) in enumerate(zip(recs, ys, strict=True))]
        info["fit_residuals"] = {k: np.concatenate([p["fit_residuals"][k] for p in parts])
                                 for k in parts[0]["fit_residuals"]}
        info["fit_signals"] = {k: np.concatenate([p["fit_signals"][k] for p in parts])
                               for k in parts[0]["fit_signals"]}
        info["fit_noise_sd"] = {
            k: float(pooled_sd([np.array(p["fit_noise_sd"][k]) for p in parts],
                             [f.n_samples for f in windows]))
            for k in parts[0]["fit_noise_sd"]}
    return theta, cov, corr, cost, info


def _one_step(est: Any, windows: Windows, covariance: str, affine_accelerations: Callable,
              holds: Any = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, dict]:
    As, targets, meas_all = [], [], []
    for flight in windows:
        c, A = affine_accelerations(flight)
        c, A, free = _held.ee_one_step(c, A, holds)  # held terms into c
        meas, target, A = one_step_target(flight, c, A, est.smoothing)
        As.append(A)
        targets.append(target)
        meas_all.append(meas)
    A, target, meas = np.concatenate(As), np.concatenate(targets), np.concatenate(meas_all)
    n = A.shape[0]
    sd = pooled_sd([rc.estimate_noise_sd(m) for m in meas_all], [f.n_samples for f in windows])
    theta = cov = None
    for _ in range(2):  # pass 1: a priori channel sds; pass 2: residual sds
        Aw = (A / sd[None, :, None]).reshape(-1, A.shape[-1])
        bw = (target / sd[None, :]).reshape(-1)
        theta, cov, s2, bandwidth = _lstsq(Aw, bw, n_time=n, covariance=covariance)
        resid = target - np.einsum("noc,c->no", A, theta)
        sd = np.sqrt(np.mean(resid * resid, axis=0))
        sd = np.maximum(sd, 1e-12 * np.sqrt(np.mean(meas * meas, axis=0)) + 1e-300)
    theta, cov = _held.ee_full(*_held.ee_prior_rows(Aw, bw, theta, cov, s2, free, holds),
                               free, holds)
    info = {"sigma2": {"one_step": s2}, "channel_sd": sd, "subproblems": ["one_step"],
            "hac_bandwidth": {"one_step": bandwidth},
            "fit_residuals": {name: resid[:, j]
                              for j, name in enumerate(aeroid.model.ACCEL_CHANNELS)}}
    corr = _held.ee_full_matrix(_correlation(Aw), free, np.nan)
    return theta, cov, corr, s2 * max(Aw.shape[0] - Aw.shape[1], 1), info


def _solve(est: Any, windows: Windows, tools: tuple[Callable, Callable], *,
           theta_only: bool = False, holds: Any = None) -> EstimationResult:
    covariance = "ols" if theta_only else est.covariance
    affine_accelerations, roll_floor = tools
    if windows.airframe.tables is not None:  # shared table points: baselines._tables_windows
        return equation_error_windows(est, windows, covariance, theta_only=theta_only,
                                      holds=holds)
    if est.one_step:
        theta, cov, corr, cost, info = _one_step(est, windows, covariance,
                                                 affine_accelerations, holds)
    else:
        theta, cov, corr, cost, info = _two_step(est, windows, covariance, theta_only, holds)
    result = est._result(windows.flights[0], theta, cov, corr, cost, info, floor=False)
    if theta_only or not np.all(np.isfinite(theta)):
        return result
    floors = {name: roll_floor(flight, theta) for name, flight in windows.items()}
    return dataclasses.replace(result, info={**result.info, "window_gyro_only_floor": floors})


def run_windows(est: Any, windows: Windows, rng: np.random.Generator, *,
                affine_accelerations: Callable, roll_floor: Callable,
                holds: Any = None) -> EstimationResult:
    """Equation-error's ``run_windows``: the windows' regressions stacked (deterministic).

    ``holds``: held terms to the left side and priors as pseudo-observations, in every
    window's rows, as one flight's (:mod:`baselines._held`); held values compared with
    the free fit of the windows (:func:`baselines._held.ee_held_check`).

    ``affine_accelerations`` and ``roll_floor``: :mod:`baselines.equation_error`'s (given
    by it: this module does not import it back).
    """
    tools = (affine_accelerations, roll_floor)
    result = _solve(est, windows, tools, holds=holds)
    if holds is not None and holds.held:  # the data against the held values
        result = _held.ee_held_check(result, _solve(est, windows, tools), holds)
    result.info["window_parameters"] = {name: {} for name in windows.names}
    result.info["window_parameter_stderr"] = {name: {} for name in windows.names}
    sd = windows.airframe.accel_position_sd.ravel()
    free = np.flatnonzero(sd)
    if est.positions == "known" or free.size == 0 or not result.success:
        return result
    return with_position_consider(
        result, windows.airframe.accel_positions.ravel(), sd,
        lambda pos: _solve(est, Windows(tuple(
            dataclasses.replace(f, airframe=moved_positions(f.airframe, pos))
            for f in windows), windows.names), tools, theta_only=True, holds=holds).theta)
