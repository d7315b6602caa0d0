"""What every estimator returns: :class:`EstimationResult`, and its warnings.

A result is data: failure is ``success=False`` with a one-line ``message``; a result that
succeeded but should not be trusted blindly carries ``warnings``, one line each (an
estimate on the edge of its search box, for example). :func:`box_edge_warnings` is the
shared test for box-bounded methods (the paper's PSO methods and any plug-in with a box).
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from aeroid.model import NAMES

if TYPE_CHECKING:
    import pandas as pd

    from aeroid.flights import Flight

__all__ = ["EDGE_FRACTION", "EstimationResult", "box_edge_warnings", "failed_result"]

#: An estimate closer to a wall of its search box than this fraction of the box's width
#: is reported as on the edge. The modified PSO clips every particle to the box, so a
#: swarm pressed against a wall ends exactly on it (distance 0); 1e-3 of the width (0.1 %
#: of the prior with the default box, prior x [0.5, 1.5]) also catches a swarm still
#: sliding onto the wall, and flags an interior optimum only when it is so close to the
#: wall that the box may well cut the true optimum off.
EDGE_FRACTION = 1e-3


def _one_line(text: Any) -> str:
    return " ".join(str(text).split())


@dataclass(frozen=True, kw_only=True, eq=False)
class EstimationResult:
    """What every estimator returns.

    Attributes
    ----------
    estimator : str
        Registered name of the method.
    names : tuple of str
        Coefficient names (:data:`aeroid.model.NAMES`).
    theta : ndarray, shape (9,)
        Estimates (NaN where the method failed).
    stderr, covariance : ndarray or None
        Standard errors (9,) and covariance (9, 9) when the method has them; with
        :attr:`consider`, they include the uncertain mass constants' share.
    cost : float
        Final cost of the method's own objective; NaN for methods without one (the
        Kalman filters).
    success : bool
    message : str
        Why the method stopped, or why it failed (one line).
    warnings : tuple of str
        Reasons to doubt a successful result, one line each (e.g. an estimate on the edge
        of its search box); empty when there are none. Shown by :meth:`summary`,
        :meth:`to_row` and :meth:`to_json_dict`.
    n_evaluations, n_iterations : int
        Objective (or model) evaluations and iterations.
    wall_time_s : float
        Set by :meth:`aeroid.estimation.Estimator.fit`.
    history : dict of str -> ndarray
        ``axis`` ("iteration" or "time") plus ``step`` (n,), ``theta`` (n, 9) and,
        where defined, ``cost`` (n,) and ``theta_sd`` (n, 9): the convergence history
        of the paper's Figs. 4-8 and 13-16.
    info : dict
        Method-specific extras (e.g. reconstructed forces, options used, weighting).
        ``info["compiled"]`` (bool), where a method has a compiled and an interpreted
        path, is shown by :meth:`summary` and :meth:`to_json_dict`.
    input : str or None
        The fin deflection between samples the method integrated the model with, ``auto``
        resolved (:data:`aeroid.flights.INPUTS`); None for a method that integrates no
        model. Set by :meth:`aeroid.estimation.Estimator.fit`.
    noise_model : str or None
        The method's measurement-noise model: ``"channel"`` (one level per channel) or
        ``"signal"`` (per sample, ``a + b yhat^2``); None for a method without a
        ``noise_model`` option (one level per channel, or no noise model). Set by
        :meth:`aeroid.estimation.Estimator.fit`.
    held : dict of str -> float
        Coefficients held at a value (not estimated: standard error NaN, zero covariance
        rows; :class:`aeroid.estimation.CoefficientSpec`); empty when all are free.
    priors : dict of str -> (float, float)
        Coefficients estimated with a Gaussian prior ``(mean, sd)``: their standard
        errors and covariance include the prior's information.
    consider : ConsiderCovariance or None
        The airframe's uncertain mass constants (consider parameters), their sensitivity
        and share of the covariance, and the method's own standard errors without them
        (:mod:`aeroid.estimation._consider`); None when every constant was exact.
    """

    estimator: str
    theta: np.ndarray
    names: tuple[str, ...] = NAMES
    stderr: np.ndarray | None = None
    covariance: np.ndarray | None = None
    cost: float = math.nan
    success: bool = True
    message: str = ""
    warnings: tuple[str, ...] = ()
    n_evaluations: int = 0
    n_iterations: int = 0
    wall_time_s: float = 0.0
    history: dict[str, Any] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)
    input: str | None = None
    noise_model: str | None = None
    held: dict[str, float] = field(default_factory=dict)
    priors: dict[str, tuple[float, float]] = field(default_factory=dict)
    consider: Any = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "theta", np.asarray(self.theta, dtype=float).reshape(-1))
        if self.stderr is not None:
            object.__setattr__(self, "stderr", np.asarray(self.stderr, dtype=float).reshape(-1))
        found = (self.warnings,) if isinstance(self.warnings, str) else tuple(self.warnings)
        object.__setattr__(self, "warnings", tuple(_one_line(w) for w in found))

    def as_dict(self) -> dict[str, float]:
        """Return estimates as name -> value."""
        return {n: float(v) for n, v in zip(self.names, self.theta, strict=True)}

    def predict(self, flight: Flight, *, substeps: int | None = None,
                initial_state: np.ndarray | None = None) -> pd.DataFrame:
        """Return the model's outputs at the flight's samples, a DataFrame indexed by ``t``.

        Both triads' accelerations and p, q, r simulated at :attr:`theta` with the fit's
        input between samples, delay, sensor positions and initial state
        (:func:`aeroid.estimation.predict`; what was used is in the frame's ``attrs``).
        """
        from aeroid.estimation._predict import predict

        return predict(self, flight, substeps=substeps, initial_state=initial_state)

    def to_frame(self, flight: Flight | None = None, *,
                 floor: np.ndarray | None = None) -> pd.DataFrame:
        """Return one row per coefficient: ``estimate``, ``stderr`` and, given the flight,
        ``prior`` and (simulated flights) ``truth``, ``error_pct``; ``floor`` when given,
        e.g. ``aeroid.estimation.data_floor(flight, result.theta)``, the Cramér-Rao floor
        from the data (:func:`aeroid.estimation.coefficient_frame`)."""
        from aeroid.estimation._predict import coefficient_frame

        return coefficient_frame(self, flight, floor=floor)

    def __repr__(self) -> str:
        """Return one line: method, status, counts (not the arrays)."""
        status = "ok" if self.success else f"FAILED: {self.message}"
        extra = f", {len(self.warnings)} warning(s)" if self.warnings else ""
        cost = f", cost={self.cost:.6g}" if math.isfinite(self.cost) else ""
        return (f"<EstimationResult {self.estimator}: {status}; {len(self.names)} "
                f"coefficients{cost}, {self.wall_time_s:.3g} s{extra}>")

    def _repr_html_(self) -> str:
        """Return the status and the coefficient table as HTML (notebooks)."""
        status = "ok" if self.success else f"FAILED ({html.escape(self.message)})"
        head = f"<p><b>{html.escape(self.estimator)}</b>: {status}"
        if self.message and self.success:
            head += f" ({html.escape(self.message)})"
        head += f"; {self.wall_time_s:.3g} s</p>"
        warned = "".join(f"<p>warning: {html.escape(w)}</p>" for w in self.warnings)
        check = self.info.get("fit_check") if isinstance(self.info, dict) else None
        if check:
            worst = check["worst"]
            warned += (f"<p>fit check: residual RMS / data noise {check['ratio'][worst]:.3g} "
                       f"at worst ({html.escape(str(worst))}; limit {check['limit']:g})</p>")
        return head + warned + self.to_frame().to_html(float_format="{:.6g}".format)

    def relative_error_pct(self, truth: np.ndarray) -> np.ndarray:
        """Return ``|theta - truth| / |truth| * 100`` per coefficient (the paper's figure)."""
        truth = np.asarray(truth, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):  # a truth of 0: no relative
            out = np.abs(self.theta - truth) / np.abs(truth) * 100.0  # figure (a held fin
        return np.where(truth == 0, np.nan, out)  # term of a passive fin), NaN

    def _compiled_text(self) -> str | None:
        compiled = self.info.get("compiled") if isinstance(self.info, dict) else None
        if compiled is None:
            return None
        return "model evaluated compiled" if compiled else "model evaluated interpreted"

    def summary(self, truth: np.ndarray | None = None) -> str:
        """Return a table for people: estimate, standard error and, given truth, error %.

        The head says ``ok`` or ``FAILED`` with the message, then one ``warning:`` line per
        warning, then the counts (and the cost, for methods that have one), then the fit
        check's worst channel where the method reports residuals.
        """
        status = "ok" if self.success else "FAILED"
        lines = [f"{self.estimator}: {status}" + (f" ({self.message})" if self.message else "")]
        lines += [f"warning: {w}" for w in self.warnings]
        counts = (f"{self.n_evaluations} evaluations, {self.n_iterations} iterations, "
                  f"{self.wall_time_s:.3f} s")
        if math.isfinite(self.cost):
            counts = f"cost {self.cost:.6g}, " + counts
        compiled = self._compiled_text()
        lines.append(counts + (f", {compiled}" if compiled else ""))
        left_out = self.info.get("saturated_left_out") if isinstance(self.info, dict) else None
        if left_out:
            lines.append("saturated samples left out of the likelihood: "
                         + ", ".join(f"{c} {n}" for c, n in left_out.items()))
        passes = self.info.get("passes") if isinstance(self.info, dict) else None
        if passes is not None:
            lines.append(f"filter passes: {passes} (of at most "
                         f"{self.info.get('options', {}).get('max_passes', '?')})")
        check = self.info.get("fit_check") if isinstance(self.info, dict) else None
        if check:
            worst = check["worst"]
            lines.append(f"fit check: residual RMS / data noise {check['ratio'][worst]:.3g} "
                         f"at worst ({worst}; limit {check['limit']:g}, about 1 when the "
                         "model fits)")
            tests = check.get("whiteness") or {}
            if tests:
                p = min(min(t.values()) for t in tests.values())
                lines.append(f"whiteness: {len(tests)} channels tested, smallest p {p:.2g} "
                             f"(limit {check['white_limit']:.2g})")
        w = max([5, *map(len, self.names)])  # table points: Cx@M1.925
        head = f"{'coef':>{w}} {'estimate':>14} {'std err':>12}"
        plain = None if self.consider is None else self.consider.stderr_without
        if self.consider is not None:
            lines.append(self.consider.describe())
            head += f" {'w/o mass sd':>12}" if plain is not None else ""
        if truth is not None:
            head += f" {'truth':>12} {'error %':>9}"
        lines.append(head)
        errors = self.relative_error_pct(truth) if truth is not None else None
        for j, name in enumerate(self.names):
            se = "" if self.stderr is None else f"{self.stderr[j]:.4g}"
            se = "held" if name in self.held else se
            row = f"{name:>{w}} {self.theta[j]:>14.6g} {se:>12}"
            row += f" {plain[j]:>12.4g}" if plain is not None else ""
            if truth is not None and errors is not None:
                row += f" {truth[j]:>12.6g} {errors[j]:>9.3f}"
            if name in self.priors:
                row += "  prior N({:g}, {:g}^2)".format(*self.priors[name])
            lines.append(row)
        imu = self.info.get("imu_errors") if isinstance(self.info, dict) else None
        if imu:  # a method that fitted the IMU's errors (output-error's imu_errors)
            sd = self.info.get("imu_error_stderr") or {}
            lines.append("IMU errors, reading = (1 + s) model + b [m/s^2, rad/s, -]:")
            lines += [f"{name:>5} {value:>14.6g} {sd.get(name, math.nan):>12.4g}"
                      for name, value in imu.items()]
        return "\n".join(lines)

    def to_row(self) -> dict[str, Any]:
        """Return one flat row for tables: scalars, then each estimate and standard error.

        ``warnings`` is one string, the warnings joined by ``"; "`` (empty when none).
        """
        row: dict[str, Any] = {
            "estimator": self.estimator,
            "success": bool(self.success),
            "message": self.message,
            "warnings": "; ".join(self.warnings),
            "cost": float(self.cost),
            "n_evaluations": int(self.n_evaluations),
            "n_iterations": int(self.n_iterations),
            "wall_time_s": float(self.wall_time_s),
        }
        for j, name in enumerate(self.names):
            row[name] = float(self.theta[j])
            row[f"{name}_stderr"] = math.nan if self.stderr is None else float(self.stderr[j])
        if self.held or self.priors:
            row["held"] = " ".join(self.held)
            row["priors"] = " ".join(self.priors)
        return row

    def to_json_dict(self) -> dict[str, Any]:
        """Return the CLI's JSON form (non-finite numbers become ``null``).

        ``info`` is :attr:`info` as JSON types (:func:`aeroid.estimation.json_safe_info`:
        the fit check, delay, positions, filter passes, noise law, correlations; per-sample
        series are left out and named in ``info["omitted"]``).
        """
        def clean(x: float) -> float | None:
            return None if not math.isfinite(x) else float(x)

        out: dict[str, Any] = {
            "method": self.estimator,
            "coefficients": {n: clean(v) for n, v in self.as_dict().items()},
            "stderr": None if self.stderr is None else
            {n: clean(float(v)) for n, v in zip(self.names, self.stderr, strict=True)},
            "success": bool(self.success),
            "message": self.message,
            "warnings": list(self.warnings),
            "cost": clean(float(self.cost)),
            "n_evaluations": int(self.n_evaluations),
            "n_iterations": int(self.n_iterations),
            "wall_time_s": float(self.wall_time_s),
        }
        if self.held or self.priors:
            out["held"] = {n: float(v) for n, v in self.held.items()}
            out["priors"] = {n: {"mean": float(m), "sd": float(s)}
                             for n, (m, s) in self.priors.items()}
        compiled = self.info.get("compiled") if isinstance(self.info, dict) else None
        if compiled is not None:
            out["compiled"] = bool(compiled)
        from aeroid.estimation._predict import json_safe, json_safe_info

        out["info"] = json_safe_info(self)
        if self.consider is not None:
            out["consider"] = json_safe(self.consider.to_json_dict())
        return out


def failed_result(estimator: str, message: str, **fields: Any) -> EstimationResult:
    """Return a ``success=False`` result with NaN estimates."""
    return EstimationResult(estimator=estimator, theta=np.full(len(NAMES), np.nan),
                            success=False, message=message, **fields)


def box_edge_warnings(theta: np.ndarray, bounds: np.ndarray,
                      names: Sequence[str] = NAMES, *,
                      fraction: float = EDGE_FRACTION) -> tuple[str, ...]:
    """Return a warning when an estimate lies on (or next to) a wall of its search box.

    Parameters
    ----------
    theta : ndarray, shape (d,)
        Estimates, in the box's units.
    bounds : ndarray, shape (d, 2)
        The box, ``[low, high]`` per estimate.
    names : sequence of str, length d
        Names of the estimates (default the nine coefficients).
    fraction : float
        Distance to a wall, as a fraction of the box's width, at or below which an
        estimate counts as on the edge (:data:`EDGE_FRACTION`).

    Returns
    -------
    tuple of str
        Empty, or one line naming every estimate on an edge, which edge and the box: the
        method's optimum may lie outside the box, so widen it (option ``box``) or move
        the prior.
    """
    theta = np.asarray(theta, dtype=float).reshape(-1)
    bounds = np.asarray(bounds, dtype=float).reshape(-1, 2)
    if theta.size != bounds.shape[0] or len(names) != theta.size:
        raise ValueError(f"box_edge_warnings: {theta.size} estimates, {bounds.shape[0]} "
                         f"bounds and {len(names)} names")
    low, high = bounds[:, 0], bounds[:, 1]
    margin = fraction * (high - low)
    found = []
    for j, name in enumerate(names):
        if not math.isfinite(theta[j]):
            continue
        if theta[j] - low[j] <= margin[j]:
            found.append(f"{name} = {theta[j]:.6g} at low end of [{low[j]:.6g}, {high[j]:.6g}]")
        elif high[j] - theta[j] <= margin[j]:
            found.append(f"{name} = {theta[j]:.6g} at high end of [{low[j]:.6g}, {high[j]:.6g}]")
    if not found:
        return ()
    return (f"on the edge of the search box (the optimum may lie outside it; widen the "
            f"box or move the prior): {', '.join(found)}",)
