"""Output-error over several windows with shared coefficients (private).

One record model per window (:class:`baselines._oe_record.RecordModel`, built by the
estimator's own :meth:`~baselines.output_error.OutputErrorEstimator.problem` of that
window) stacked behind the Gauss-Newton ``OutputModel`` protocol
(:mod:`baselines._gauss_newton`): the samples of all windows one after the other, one
noise model (the sensors are the same), and the parameter vector

``[coefficients, position components, window 1's own, window 2's own, ...]``

where a window's own parameters are its free initial-state components, its fin delay
(``estimate_delay``) and its IMU errors (``imu_errors``). The Jacobian is block sparse:
each window's rows depend on the shared columns and on its own block only; it is filled
block by block from each window's own (local) Jacobian. The information of the stack is
the sum of the windows' informations (each mapped into the global columns), so the
standard errors and the Cramér-Rao bound of the shared coefficients are those of all the
windows' data together. Per-window parameters are reported per window
(``info['window_parameters']``, ``info['window_parameter_stderr']``), named by window in
``info['parameter_names']`` (``"w1:p0"``).

Not for several windows: the PSO warm start (``pso_warm_start``), the staged start
(``staged_start``) and the consider analysis of the positions (``positions="consider"``):
refused in one line.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

import aeroid
from aeroid.errors import EstimatorError
from aeroid.estimation import EstimationResult
from aeroid.flights import Windows, imu_error_names
from aeroid.model import OUTPUT_CHANNELS
from baselines import _held, _oe_wind, _wind_auto
from baselines._gauss_newton import (
    Fit,
    Problem,
    SmoothRegion,
    posterior_information,
    sandwich,
)
from baselines._oe_constants import MAX_SAMPLES  # output-error's: the stacked record costs as much
from baselines._oe_record import RecordModel
from baselines._oe_sensors import HELD_VELOCITY_WARNING, imu_error_report
from baselines._oe_starts import (
    EQUATION_ERROR_OPTIONS,
    Start,
    best_end,
    start_report,
)
from baselines._tables_fit import coefficient_layout, mach_notes
from baselines._tables_windows import shared_tables

__all__ = ["MAX_SAMPLES", "OutputErrorWindows", "WindowsLayout", "WindowsModel", "run_windows",
           "windows_problem"]



class OutputErrorWindows:
    """Output-error's fit of several windows (a mixin of its estimator; not registered)."""

    #: :meth:`aeroid.estimation.Estimator.fit` accepts :class:`aeroid.flights.Windows`.
    supports_windows: ClassVar[bool] = True

    def run_windows(self, windows: Windows, rng: np.random.Generator, holds: Any = None
                    ) -> EstimationResult:
        """Fit several windows with shared coefficients (module docstring; ``holds``:
        :mod:`baselines._held`, the coefficients lead the stacked vector as one flight's)."""
        if _wind_auto.is_auto(self):  # estimate_wind = auto resolved on the windows, said
            return _wind_auto.run_auto(self, windows, _oe_wind.blocked(self, windows),
                                       lambda est: est.run_windows(windows, rng, holds))
        return run_windows(self, windows, rng, holds)


class WindowsLayout:
    """Where each window's local parameters sit in the stacked vector.

    A window's local vector (its :class:`RecordModel`'s) is ``[coefficients, x0 free,
    positions, wind, delay, IMU errors]``; the stacked one ``[coefficients, positions,
    (x0 free, wind, delay, IMU errors) per window]``: each window has its own steady
    wind (``estimate_wind``; issue 26: "per window where there are several").
    """

    def __init__(self, n_windows: int, n_x0: int, n_pos: int, n_delay: int,
                 n_imu: int, n_c: int = aeroid.model.N_COEFFICIENTS, n_wind: int = 0) -> None:
        self.n_shared = n_c + n_pos
        self.n_own = n_x0 + n_wind + n_delay + n_imu
        self.n_x0, self.n_pos, self.n_wind = n_x0, n_pos, n_wind
        self.size = self.n_shared + n_windows * self.n_own
        self.index = []
        for w in range(n_windows):
            base = self.n_shared + w * self.n_own
            self.index.append(np.concatenate([
                np.arange(n_c), base + np.arange(n_x0), n_c + np.arange(n_pos),
                base + n_x0 + np.arange(n_wind + n_delay + n_imu)]).astype(int))

    def own(self, w: int) -> np.ndarray:
        """Stacked indices of window ``w``'s own parameters."""
        base = self.n_shared + w * self.n_own
        return np.arange(base, base + self.n_own)


class WindowsModel:
    """``y(p)`` (N, m) and ``dy/dp`` (m, N, n_p) of the windows' records stacked in time."""

    edge_note: str = RecordModel.edge_note

    def __init__(self, models: list[RecordModel], layout: WindowsLayout,
                 scale: np.ndarray) -> None:
        self.models, self.layout, self.scale = models, layout, scale
        stops = np.cumsum([m.t.size for m in models])
        self.rows = [(int(b - m.t.size), int(b)) for b, m in zip(stops, models, strict=True)]
        self.n_samples = int(stops[-1])
        self.compiled = all(m.compiled for m in models)

    def outputs(self, p: np.ndarray) -> np.ndarray:
        """Return the stacked outputs, shape (N, m)."""
        return np.vstack([m.outputs(p[idx]) for m, idx in zip(self.models, self.layout.index,
                                                                strict=True)])

    def outputs_jacobian(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return the stacked outputs (N, m) and the block-sparse ``dy/dp`` (m, N, n_p)."""
        y = np.empty((self.n_samples, len(OUTPUT_CHANNELS)))
        J = np.zeros((len(OUTPUT_CHANNELS), self.n_samples, p.size))
        for model, idx, (a, b) in zip(self.models, self.layout.index, self.rows, strict=True):
            y[a:b], J[:, a:b, idx] = model.outputs_jacobian(p[idx])
        return y, J

    def smooth_region(self, p: np.ndarray) -> SmoothRegion:
        """Each window's delay region at its own column; smooth everywhere else."""
        lo, hi = np.full(p.size, -np.inf), np.full(p.size, np.inf)
        below, above = lo.copy(), hi.copy()
        for model, idx in zip(self.models, self.layout.index, strict=True):
            region = model.smooth_region(p[idx])
            for dst, src in ((lo, region.lo), (hi, region.hi), (below, region.below),
                             (above, region.above)):
                finite = np.isfinite(src)
                dst[idx[finite]] = src[finite]
        return SmoothRegion(lo, hi, below, above)


def windows_problem(est: Any, windows: Windows) -> tuple[Problem, WindowsModel]:
    """Return the stacked fit of ``windows``: measurements, model, noise model, priors.

    Each window's part is the estimator's own problem of that window
    (``est.problem(flight, position_free)``); its scales and prior weights are mapped into
    the stacked vector (the shared ones agree across windows: the airframes' shared fields
    do, :class:`aeroid.flights.Windows`). The floor of each variance is the windows'
    floors averaged over their samples: each is ``R_FLOOR_REL`` of its window's mean
    square (+1e-300), so the average is that fraction of the stack's mean square.
    """
    est = _oe_wind.resolved(est, windows)  # estimate_wind = auto: once, on all windows
    position_free = est.position_free(windows.flights[0])
    parts = [est.problem(flight, position_free) for flight in windows]
    models: list[RecordModel] = [prob.model for prob in parts]  # type: ignore[misc]
    layout = WindowsLayout(len(parts), len(est.x0_free()), len(position_free),
                           int(est.estimate_delay), models[0].n_imu,
                           len(coefficient_layout(windows.flights[0])[0]),
                           len(_oe_wind.wind_names(est)))
    scale = np.zeros(layout.size)
    weight = np.zeros(layout.size)
    for prob, model, idx in zip(parts, models, layout.index, strict=True):
        scale[idx] = model.scale
        if prob.prior_weight is not None:
            weight[idx] = prob.prior_weight
    z = np.vstack([prob.z for prob in parts])
    has_prior = bool(np.any(weight > 0))
    model = WindowsModel(models, layout, scale)
    counts = np.array([prob.z.shape[0] for prob in parts], dtype=float)
    r_floor = counts @ np.array([prob.r_floor for prob in parts]) / counts.sum()
    return Problem(z=z, model=model, r_floor=r_floor,
                   noise_model=est.noise_model,
                   prior_mean=np.zeros(layout.size) if has_prior else None,
                   prior_weight=weight if has_prior else None), model


def _local_names(est: Any, position_free: tuple[int, ...]) -> tuple[str, ...]:
    """The names of a window's own parameters, in local order."""
    names = est.parameter_names(position_free)
    n_c, n_x0 = aeroid.model.N_COEFFICIENTS, len(est.x0_free())
    return names[n_c:n_c + n_x0] + names[n_c + n_x0 + len(position_free):]


def _starts(est: Any, windows: Windows, model: WindowsModel, first: np.ndarray,
            rng: np.random.Generator) -> list[Start]:
    """The prior start, equation-error's over the windows, ``n_starts - 1`` random draws."""
    names, prior = coefficient_layout(windows.flights[0])  # with tables: their parameters
    n_c = len(names)
    scale = model.scale
    starts = [Start("prior", first)]
    if est.equation_error_start:
        try:
            ee = aeroid.make_estimator("equation-error", EQUATION_ERROR_OPTIONS)
            theta = np.asarray(ee.run_windows(windows, rng).theta, dtype=float)
            if theta.shape != (n_c,) or not np.all(np.isfinite(theta)):
                raise FloatingPointError("no finite estimate")
            p0 = first.copy()
            p0[:n_c] = theta / scale[:n_c]
            starts.append(Start("equation-error", p0))
        except Exception as exc:  # failure is data: the fit goes on from its other starts
            starts.append(Start("equation-error", None, " ".join(str(exc).split())))
    for k in range(est.n_starts - 1):
        p = first.copy()
        p[:n_c] = prior * (1.0 + 0.2 * rng.standard_normal(n_c)) / scale[:n_c]
        starts.append(Start(f"random {k + 1}", p))
    return starts


def run_windows(est: Any, windows: Windows, rng: np.random.Generator, holds: Any = None
                ) -> EstimationResult:
    """Fit the windows with shared coefficients (output-error's ``run_windows``).

    ``holds``: held coefficients and priors, applied to the stacked problem as to one
    flight's (:func:`baselines._held.with_priors`, :func:`~baselines._held.held_fit`,
    :func:`~baselines._held.held_inverse`): the coefficients lead both vectors.
    """
    owner = est.name
    if est.pso_warm_start:
        raise EstimatorError(f"{owner}: pso_warm_start is not available for several windows; "
                             "set pso_warm_start = false")
    if getattr(est, "staged_start", False):
        raise EstimatorError(f"{owner}: staged_start is not available for several windows; "
                             "set staged_start = false")
    if getattr(est, "air_data", "inertial") != "inertial":
        raise EstimatorError(f"{owner}: air_data = {est.air_data} is not available for several "
                             "windows yet (one flight at a time); set air_data = inertial")
    if getattr(est, "aiding", "none") != "none":
        raise EstimatorError(f"{owner}: aiding = {est.aiding} is not available for several "
                             "windows yet (one flight at a time); set aiding = none")
    if est.positions == "consider":
        raise EstimatorError(f"{owner}: positions = consider is not available for several "
                             "windows; use estimate or known")
    if est.estimate_wind and windows.airframe.tables is not None:
        raise EstimatorError(f"{owner}: estimate_wind with coefficient tables ([tables]) is "
                             "not built (Mach needs the airspeed)")
    if windows.n_samples > MAX_SAMPLES:
        raise EstimatorError(f"{owner}: {windows.n_samples} samples over the windows; it fits "
                             f"at most {MAX_SAMPLES} at once")
    if windows.airframe.tables is not None:  # shared points: baselines._tables_windows
        windows, _ = shared_tables(windows)
    prob, model = windows_problem(est, windows)
    prob = _held.with_priors(est, windows.flights[0], prob, holds)
    layout, scale = model.layout, model.scale
    _, prior = coefficient_layout(windows.flights[0])
    n_c = prior.size
    first = np.zeros(layout.size)
    first[:n_c] = prior / scale[:n_c]
    if est.estimate_delay:
        for w in range(len(windows)):
            i = layout.own(w)[layout.n_x0 + layout.n_wind]
            first[i] = est.delay_s / scale[i]
    starts = _starts(est, windows, model, first, rng)
    fits: list[Fit] = []
    labels, failures = [], []
    for start in starts:
        try:
            if start.p0 is None:
                raise FloatingPointError(start.failure)
            fits.append(_held.held_fit(est, prob, start.p0, holds))
            labels.append(start.label)
        except FloatingPointError as exc:
            failures.append(f"{start.label}: {exc}")
    if not fits:
        return aeroid.failed_result(owner, failures[0])
    best = fits[k_best := best_end(fits)]
    M, _ = posterior_information(prob, best.J, best.e, best.r_diag, best.p)
    try:
        cov_p = _held.held_inverse(M, holds)
    except np.linalg.LinAlgError:
        cov_p = np.full_like(M, np.nan)
    if est.covariance == "sandwich":
        cov_p = sandwich(cov_p, best.J, best.e, best.r_diag)
    cov_phys = cov_p * np.outer(scale, scale)
    phys = best.p * scale
    stderr_phys = np.sqrt(np.abs(np.diag(cov_phys)))
    cov = cov_phys[:n_c, :n_c]
    return _result(est, windows, model, prob, best, fits, labels, k_best, failures, M,
                   phys, stderr_phys, cov_phys, cov, len(starts))


def _result(est: Any, windows: Windows, model: WindowsModel, prob: Problem, best: Fit,
            fits: list[Fit], labels: list[str], k_best: int, failures: list[str],
            M: np.ndarray, phys: np.ndarray, stderr_phys: np.ndarray,
            cov_phys: np.ndarray, cov: np.ndarray, n_starts: int) -> EstimationResult:
    """The result: shared coefficients, their covariance, each window's own parameters."""
    layout, scale = model.layout, model.scale
    n_9 = aeroid.model.N_COEFFICIENTS  # est.parameter_names' coefficients: the nine
    coefficients = model.models[0].tables
    shared = aeroid.NAMES if coefficients is None else coefficients.parameter_names()
    n_c = len(shared)
    position_free = model.models[0].position_free
    local = _local_names(est, position_free)
    window_names = (*shared, *est.parameter_names(position_free)[n_9:])
    names = list(shared) + [est.parameter_names(position_free)[n_9 + layout.n_x0 + j]
                            for j in range(layout.n_pos)]
    per_window, per_window_sd, window_imu = {}, {}, {}
    window_wind: dict[str, dict[str, Any]] = {}
    warnings: list[str] = []
    imu_names = imu_error_names(est.imu_errors)
    for w, (name, flight) in enumerate(windows.items()):
        own = layout.own(w)
        names += [f"{name}:{n}" for n in local]
        per_window[name] = dict(zip(local, phys[own].tolist(), strict=True))
        per_window_sd[name] = dict(zip(local, stderr_phys[own].tolist(), strict=True))
        start = model.models[w].x0.copy()
        start[list(est.x0_free())] += phys[own[:layout.n_x0]]
        per_window[name]["initial_state"] = start.tolist()
        if imu_names:
            idx = layout.index[w]
            imu_info, found = imu_error_report(
                window_names, imu_names, phys[idx], stderr_phys[idx],
                cov_phys[np.ix_(idx, idx)])
            window_imu[name] = imu_info
            warnings += [f"window {name}: {text}" for text in found]
        if "initial_state_sd" in flight.metadata and not est.estimate_initial_velocity:
            warnings.append(f"window {name}: {HELD_VELOCITY_WARNING}")
        if est.estimate_wind:  # each window's own steady wind
            idx = layout.index[w]
            window_wind[name] = {}
            warnings += [f"window {name}: {text}" for text in _oe_wind.wind_report(
                est, position_free, phys[idx], stderr_phys[idx], window_wind[name])]
    positions = model.models[0].pos.copy()
    position_sd = np.zeros(positions.size)
    for j, c in enumerate(position_free):
        positions[c] += phys[n_c + j]
        position_sd[c] = stderr_phys[n_c + j]
    hist_p = np.array(best.history_p)
    history = {"axis": "iteration", "step": np.arange(len(hist_p)),
               "theta": hist_p[:, :n_c] * scale[:n_c], "cost": np.array(best.history_cost)}
    info: dict[str, Any] = {
        "R": best.r_diag, "fisher": M, "parameter_names": tuple(names), "parameters": phys,
        "parameter_stderr": stderr_phys, "parameter_covariance": cov_phys,
        "iterations": best.n_iterations, "starts": n_starts, "failed_starts": failures,
        "compiled": model.compiled, "start_costs": [f.nll for f in fits], "input": est.input,
        "fit_residuals": {c: best.e[:, j] for j, c in enumerate(OUTPUT_CHANNELS)},
        "window_parameters": per_window, "window_parameter_stderr": per_window_sd,
        "accel_positions_m": positions.reshape(2, 3),
        "accel_position_stderr_m": position_sd.reshape(2, 3)}
    if window_imu:
        info["window_imu_errors"] = window_imu
    if window_wind:  # name -> {"wind_ned_mps": [n, e, d], "wind_stderr_mps": [...]}
        info["window_wind"] = window_wind
    if coefficients is not None:
        info["tables"] = coefficients.to_table()
        warnings += [f"window {name}: {note}" for name, flight in windows.items()
                     for note in mach_notes(flight, flight.airframe.mach_tables())]
    start_info, found = start_report(labels, fits, k_best, stderr_phys / np.abs(scale),
                                     failures, n_c)
    info.update(start_info)
    warnings = list(found) + warnings
    return EstimationResult(
        estimator=est.name, names=tuple(shared), theta=phys[:n_c],
        stderr=np.sqrt(np.abs(np.diag(cov))),
        covariance=cov, cost=best.nll, success=best.converged, message=best.message,
        n_evaluations=sum(f.n_evaluations for f in fits),
        n_iterations=sum(f.n_iterations for f in fits), history=history, info=info,
        warnings=tuple(warnings))
