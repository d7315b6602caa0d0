"""Several windows in one fit: what :meth:`Estimator.fit` does with a :class:`Windows`.

Each window is validated and its deflection input resolved and checked as a single
flight's is; the method's :meth:`Estimator.run_windows` fits the windows with shared
coefficients; the fit check then judges the stacked residuals against the windows'
noise levels (each window's levels from its own samples, pooled as a mean square
weighted by the samples) on the windows joined one after the other
(:meth:`aeroid.flights.Windows.joined`). The Cramér-Rao floor warning of a single flight
(:func:`floor_warnings`) is not computed for windows: its record would integrate across
the joins; a result says so in ``info['floor_check']``.

A method that cannot fit several windows (``supports_windows`` False: the paper's PSO
methods, pyswarms) refuses in one line.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import numpy as np

from aeroid.errors import AeroidError, EstimatorError
from aeroid.estimation._fitcheck import apply_fit_check, data_noise_levels
from aeroid.estimation._progress import ProgressCallback, progress_listener
from aeroid.estimation._result import EstimationResult, failed_result
from aeroid.flights import Windows

__all__ = ["FLOOR_CHECK_NOTE", "fit_windows", "pooled_noise_levels"]

#: What ``info['floor_check']`` says of a fit of several windows.
FLOOR_CHECK_NOTE = ("not computed for several windows (the floor's record would integrate "
                    "across the joins)")


def pooled_noise_levels(windows: Windows) -> dict[str, float]:
    """Each channel's noise level over the windows: ``sqrt(sum n_w s_w^2 / sum n_w)``.

    ``s_w`` is the level of window ``w`` from its own samples
    (:func:`aeroid.estimation.data_floor`'s yardstick, :func:`data_noise_levels`).
    """
    totals: dict[str, float] = {}
    counts: dict[str, int] = {}
    for flight in windows:
        for name, level in data_noise_levels(flight).items():
            totals[name] = totals.get(name, 0.0) + flight.n_samples * level * level
            counts[name] = counts.get(name, 0) + flight.n_samples
    return {name: float(np.sqrt(totals[name] / counts[name])) for name in totals}


def fit_windows(estimator: Any, windows: Windows, *, rng: Any = None,
                progress: ProgressCallback | None = None) -> EstimationResult:
    """Validate every window, run ``estimator.run_windows``, time it, check the fit.

    Raises
    ------
    EstimatorError
        A method that cannot fit several windows, or a bad ``rng``.
    FlightError
        An invalid window (its message names the window's source).
    """
    owner = estimator.name or type(estimator).__name__
    if not getattr(estimator, "supports_windows", False):
        raise EstimatorError(f"{owner}: fits one flight at a time; it cannot fit several "
                             "windows (methods that can: output-error, ekf, ukf, "
                             "equation-error)")
    choices = []
    for name, flight in windows.items():
        flight.validate()
        if flight.metadata.get("saturated"):
            raise EstimatorError(f"{owner}: window {name!r} has saturated samples (metadata "
                                 "'saturated'); several windows cannot leave them out yet: "
                                 "fit that window alone")
        choices.append(estimator.input_choice(flight))
    try:
        generator = np.random.default_rng(rng)
    except (TypeError, ValueError) as exc:
        raise EstimatorError(f"{owner}: bad seed {rng!r}: {' '.join(str(exc).split())}"
                             ) from None
    start = time.perf_counter()
    try:
        with np.errstate(all="ignore"), progress_listener(progress):
            result = estimator.run_windows(windows, generator)
    except AeroidError:
        raise
    except Exception as exc:  # failure is data
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        result = failed_result(estimator.name, f"{type(exc).__name__}: {text}".rstrip(": "))
    elapsed = time.perf_counter() - start
    if result.success and not np.all(np.isfinite(result.theta)):
        result = dataclasses.replace(result, success=False,
                                     message=result.message or "non-finite estimate")
    used = {c.input for c in choices if c is not None}
    result = dataclasses.replace(
        result, input=None if not used else ",".join(sorted(used)),
        noise_model=estimator.noise_model_used())
    levels = pooled_noise_levels(windows) if result.success else None
    result = apply_fit_check(result, windows.joined(), levels, estimator.options())
    info = dict(result.info)
    info.setdefault("options", estimator.options())
    info["windows"] = list(windows.names)
    info["window_bounds"] = windows.bounds()
    info["floor_check"] = FLOOR_CHECK_NOTE
    for name, choice in zip(windows.names, choices, strict=True):
        if choice is not None:
            info.setdefault("window_input", {})[name] = choice.as_info()
    extra: tuple[str, ...] = ()
    for choice in choices:
        if choice is not None:
            extra += tuple(w for w in choice.warnings if w not in extra)
    if any("initial_state_sd" in f.metadata for f in windows) and not estimator.uses_state_sd:
        extra += (f"{owner}: the windows' states are a reconstruction's, with sd "
                  "(metadata initial_state_sd); this method takes them as exact, so "
                  "its standard errors leave their uncertainty out",)
    result = dataclasses.replace(result, wall_time_s=elapsed, info=info,
                                 warnings=tuple(result.warnings) + extra)
    return result
