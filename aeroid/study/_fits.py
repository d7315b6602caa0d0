"""One fit of a study: its seeds, its flight and its JSON record (runs in any worker).

Seeding: run ``i`` owns the stream ``SeedSequence(seed, spawn_key=(i,))``. Its flights
draw from the child ``spawn_key=(i, 0)``, its estimators from ``spawn_key=(i, 1)`` and,
with ``prior_offset``, its prior from ``spawn_key=(i, 2)`` and, with ``[perturb]``, its
drawn airframe constants from ``spawn_key=(i, 3)`` (:mod:`aeroid.study._perturb`), so a
fit depends only on (seed, run index, noise condition, estimator), never on the number or
kind of workers.
Decisions:

- Every estimator of a run gets a fresh generator from the same seed, so all of them
  draw the same starting guess (and the same first random numbers).
- With ``prior_offset = [lo, hi]`` every estimator of a run (under every noise
  condition) starts from the same prior, ``truth (1 + s U(lo, hi))`` per coefficient
  with a random sign ``s`` (:func:`run_prior`), given to it as the flight's
  ``airframe.prior``: estimators start from the prior or centre their search box on it.
  Its own seed child leaves the flights and the estimators' draws as they were.
- All noise conditions of a run use the same flight seed (common random numbers): in
  a sweep of the paper's xi the same uniform draws are scaled, so the conditions
  differ by the noise level only, not by luck.

The noise-free truth of the scenario is deterministic, so each worker process
integrates it once and caches it; a fit then costs the sensor noise plus the
estimator. Convergence histories (and the reconstructed forces of EBM-type methods)
are kept for run :data:`HISTORY_RUN` only.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import math
import os
import pickle
import socket
from typing import Any

import numpy as np

from aeroid.errors import StudyError
from aeroid.flights import cut_windows
from aeroid.model import compile_clock
from aeroid.study._perturb import perturb_fields, run_scenario
from aeroid.study._provenance import code_id
from aeroid.study._spec import Study
from aeroid.study._suite import imu_error_fields, suite_flight
from aeroid.study._tables import has_tables, parameter_names, parameter_truth

HISTORY_RUN = 0
#: ``EstimationResult.info`` arrays kept with the history (EBM reconstructions).
INFO_ARRAYS = ("t", "fm_raw", "fm_smooth")

Task = tuple[int, int, int]
"""(run index, noise index, estimator index)."""


def flight_seed(seed: int, run: int) -> np.random.SeedSequence:
    """Return the seed of run ``run``'s flights (every noise condition)."""
    return np.random.SeedSequence(seed, spawn_key=(run, 0))


def estimator_seed(seed: int, run: int) -> np.random.SeedSequence:
    """Return the seed every estimator of run ``run`` starts from."""
    return np.random.SeedSequence(seed, spawn_key=(run, 1))


def prior_seed(seed: int, run: int) -> np.random.SeedSequence:
    """Return the seed of run ``run``'s prior (studies with ``prior_offset``)."""
    return np.random.SeedSequence(seed, spawn_key=(run, 2))


def run_prior(study: Study, run: int) -> np.ndarray | None:
    """Return the prior every estimator of run ``run`` starts from, shape (9,), or None.

    ``truth_j (1 + s_j u_j)`` with ``u_j ~ U(lo, hi)`` and signs ``s_j = +-1`` with equal
    probability, drawn (first the nine ``u``, then the nine signs) from
    :func:`prior_seed`; None without ``study.prior_offset`` (the airframe's prior).
    """
    if study.prior_offset is None:
        return None
    lo, hi = study.prior_offset
    rng = np.random.default_rng(prior_seed(study.seed, run))
    u = rng.uniform(lo, hi, len(study.scenario.coefficients))
    sign = np.where(rng.random(u.size) < 0.5, -1.0, 1.0)
    return np.asarray(study.scenario.coefficient_vector, dtype=float) * (1.0 + sign * u)


_TRUTH_CACHE: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def scenario_key(scenario: Any) -> str:
    """Return a hash of what decides a scenario's truth (airframe, coefficients, manoeuvre)."""
    return hashlib.sha256(pickle.dumps((scenario.airframe, scenario.coefficients,
                                        scenario.manoeuvre))).hexdigest()


def scenario_truth(scenario: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return (t, states, delta) of the scenario's noise-free truth, cached per process.

    Shapes (n,) [s], (n, 9) [m/s, rad/s, rad] and (n,) [rad]
    (:func:`aeroid.flights.simulate_truth`).
    """
    from aeroid.flights import simulate_truth

    key = scenario_key(scenario)
    if key not in _TRUTH_CACHE:
        _TRUTH_CACHE.clear()
        _TRUTH_CACHE[key] = simulate_truth(scenario.airframe, scenario.coefficient_vector,
                                           scenario.manoeuvre, tables=scenario.tables)
    return _TRUTH_CACHE[key]


def turbulent(scenario: Any) -> bool:
    """Whether the scenario's ``[wind]`` has Dryden turbulence (then each run's truth is
    its own: the gusts are drawn from the run's flight seed, before the sensor noise)."""
    wind = getattr(scenario.manoeuvre, "wind", None)
    return wind is not None and bool(wind.turbulent)


def simulate_run(study: Study, run: int, noise_index: int) -> Any:
    """Return the flight of ``run`` under noise condition ``noise_index``.

    Equal to ``aeroid.simulate(airframe, coefficients, manoeuvre, noise,
    rng=default_rng(flight_seed(seed, run)))`` (a test checks it), but the truth is
    integrated once per process (:func:`aeroid.flights.record_flight` does the rest).
    A sensor-suite condition's flight is the reconstruction of the run's suite log
    (:func:`aeroid.study._suite.suite_flight`, from the same flight seed). In a
    turbulent scenario (:func:`turbulent`) the whole flight, gusts then sensor noise, is
    ``aeroid.simulate`` with the run's flight generator: no truth is shared.
    """
    from aeroid.flights import record_flight

    scenario = run_scenario(study, run)  # with [perturb]: the run's drawn mass
    if study.noise[noise_index].suite is not None:  # a sensor-suite log, reconstructed
        return suite_flight(scenario, study.noise[noise_index],
                            flight_seed(study.seed, run), scenario_key(scenario))
    noise = study.noise[noise_index].model
    rng = np.random.default_rng(flight_seed(study.seed, run))
    if turbulent(scenario):  # each run flies its own gusts: no shared truth
        from aeroid.flights import simulate

        return simulate(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                        noise, rng=rng)
    return record_flight(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         scenario_truth(scenario), noise, rng=rng, tables=scenario.tables)


def _clean(x: Any) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _vector(x: Any) -> list[float | None] | None:
    return None if x is None else [_clean(v) for v in np.asarray(x, dtype=float).ravel()]


@functools.lru_cache(maxsize=16)
def _code(classes: tuple[type, ...]) -> str:
    return code_id(classes)


def study_code_id(study: Study) -> str:
    """Return the code identity (:func:`aeroid.study.code_id`) of this process for a study."""
    return _code(tuple(type(e.estimator) for e in study.estimators))


def base_record(study: Study, task: Task, truth: Any = None) -> dict[str, Any]:
    """Return the record of a fit that produced nothing (``success: false``, no message)."""
    run, k_noise, k_est = task
    spec = study.estimators[k_est]
    n = len(study.scenario.coefficients) if truth is None else len(truth)
    prior = run_prior(study, run)
    return {
        "run": run, "noise": study.noise[k_noise].label, "estimator": spec.label,
        "method": spec.method,
        "truth": _vector(study.scenario.coefficient_vector if truth is None else truth),
        "prior": _vector(prior), "theta": [None] * n, "stderr": None, "success": False,
        "message": "", "cost": None,
        "n_evaluations": 0, "n_iterations": 0, "wall_time_s": None, "compile_time_s": None,
        "worker": f"{socket.gethostname()}:{os.getpid()}", "code": study_code_id(study),
        **perturb_fields(study, run),
    }


def fit_times(wall_time_s: float, compile_s: float) -> dict[str, float | None]:
    """Return a record's ``wall_time_s`` (the fit without compilation) and
    ``compile_time_s`` (numba compiling kernels during the fit) [s].

    The first fit in a process that needs a kernel compiles it once (~10-50 s); counted
    in its runtime, one UKF fit showed 30 s beside a median of 0.84 s.
    """
    return {"wall_time_s": _clean(max(float(wall_time_s) - compile_s, 0.0)),
            "compile_time_s": _clean(compile_s)}


def consider_fields(result: Any) -> dict[str, Any]:
    """Return a record's fields of a fit's consider share and fitted attitude offset.

    ``consider`` (a fit whose airframe gives a mass or inertia sd,
    :mod:`aeroid.estimation._consider`): the method's own standard errors
    (``stderr_without``), the constants' share (``stderr_share``) and the re-fits that
    ended unsuccessful (``refit_messages``), so that a study can tell a widened interval
    from a failed re-fit. ``attitude_offset``: output-error's ``attitude_prior``
    (``{"phi": [offset, se], "theta": [offset, se]}`` [rad]). ``{}`` when neither.
    """
    out: dict[str, Any] = {}
    consider = getattr(result, "consider", None)
    if consider is not None:
        out["consider"] = {"names": list(consider.names),
                           "stderr_without": _vector(consider.stderr_without),
                           "stderr_share": _vector(consider.stderr_share),
                           "refit_messages": [str(m) for m in consider.refit_messages]}
    offset = (result.info or {}).get("attitude_offset_rad")
    if offset:
        se = result.info.get("attitude_offset_stderr_rad", {})
        out["attitude_offset"] = {k: [_clean(v), _clean(se.get(k, math.nan))]
                                  for k, v in offset.items()}
    return out


def failed_record(study: Study, task: Task, message: str) -> dict[str, Any]:
    """Return the record of a fit that failed outside the estimator (a worker died)."""
    record = base_record(study, task)
    record.update(message=message, worker="")
    return record


def fit_task(study: Study, task: Task) -> tuple[dict[str, Any], dict[str, np.ndarray] | None]:
    """Run one fit; return its JSON record and, for run 0, its history arrays.

    An estimator that raises (anything but ``KeyboardInterrupt``/``SystemExit``) or
    returns ``success=False`` gives a record with ``success: false`` and the message.
    With ``study.prior_offset`` the estimator sees the flight with the run's prior
    (:func:`run_prior`) as its airframe's ``prior``; the record keeps it (``prior``).
    """
    run, k_noise, k_est = task
    spec = study.estimators[k_est]
    try:
        flight = simulate_run(study, run, k_noise)
    except Exception as exc:  # the design was checked on load: this is not the estimator's
        text = " ".join(str(exc).split())
        raise StudyError(f"run {run}, noise {study.noise[k_noise].label!r}: the flight "
                         f"simulation failed: {type(exc).__name__}: {text}") from None
    names = None
    if has_tables(study):  # scored per parameter: aeroid/study/_tables.py
        names = parameter_names(flight)
        record = base_record(study, task, parameter_truth(study.scenario, names))
        record["names"] = list(names)
    else:
        record = base_record(study, task, flight.true_coefficients)
    prior = run_prior(study, run)
    if prior is not None:
        flight = dataclasses.replace(flight, airframe=dataclasses.replace(
            flight.airframe, prior=tuple(float(v) for v in prior)))
    try:
        data = flight if study.windows is None else cut_windows(flight, study.windows)
        with compile_clock() as clock:  # the one-time numba compilation of a process
            result = spec.estimator.fit(data, rng=np.random.default_rng(
                estimator_seed(study.seed, run)))
    except Exception as exc:  # failure is data: record it, the study goes on
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        record.update(message=f"{type(exc).__name__}: {text}".rstrip(": "))
        return record, None
    if names is not None and tuple(result.names) != names:  # knots over the windows
        record.update(names=list(result.names),
                      truth=_vector(parameter_truth(study.scenario, result.names)))
    record.update(theta=_vector(result.theta), stderr=_vector(result.stderr),
                  success=bool(result.success), message=str(result.message),
                  cost=_clean(result.cost), n_evaluations=int(result.n_evaluations),
                  n_iterations=int(result.n_iterations),
                  **fit_times(result.wall_time_s, clock.seconds),
                  **imu_error_fields(flight, result.info), **consider_fields(result))
    if run != HISTORY_RUN:
        return record, None
    history = {}
    for key, value in (result.history or {}).items():
        history[f"history_{key}"] = np.asarray(value)
    for key in INFO_ARRAYS:
        if key in (result.info or {}):
            history[f"info_{key}"] = np.asarray(result.info[key], dtype=float)
    return record, history


__all__ = ["HISTORY_RUN", "Task", "base_record", "consider_fields", "estimator_seed",
           "failed_record",
           "fit_task", "fit_times", "flight_seed", "prior_seed", "run_prior", "scenario_key",
           "scenario_truth", "simulate_run", "study_code_id", "turbulent"]
