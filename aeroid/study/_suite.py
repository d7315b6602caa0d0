"""Sensor-suite noise conditions: a study's flights logged by a flight-test logger.

A ``[[noise]]`` entry with ``model = "suite"`` logs every run's flight through a
:class:`aeroid.flights.SensorSuite` (IMU with biases and scale factors, GNSS, barometer,
wrapped INS; no air data), reconstructs it (:func:`aeroid.reconstruction.reconstruct`)
and gives the estimators the reconstruction's single-rate flight::

    [[noise]]
    label = "suite, raw IMU"
    model = "suite"
    imu = "raw"                 # "raw" (default) or "corrected": to_flight(imu=...)
    gnss_rate_hz = 10.0         # any further key is a SensorSuite field (lists for ranges)

The suite draws from the run's flight seed (:func:`aeroid.study.flight_seed`), like every
other condition: the same seed gives the same flights in any number of processes. The
truth of a suite flight is integrated at the IMU's rate by ``simulate_suite`` itself (the
same flight as the scenario's: the relay keeps the manoeuvre's clock), so it is not the
per-process cached truth of the other conditions. Each process keeps its latest suite
flight, because every estimator of a run fits the same one and the reconstruction costs
about 1.5 s per second of flight.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from aeroid.errors import AirframeError, StudyError
from aeroid.flights import Scenario, SensorSuite, make_noise
from aeroid.study._spec import NoiseCondition

#: Keys of a suite ``[[noise]]`` entry besides the SensorSuite fields.
SUITE_KEYS = ("label", "model", "imu")
IMU_CHOICES = ("raw", "corrected")
#: SensorSuite fields given as text or lists of names (the others are numbers).
TEXT_FIELDS = ("imu_mounting",)
NAME_LISTS = ("baro_channels", "gnss_channels", "offsets_s")
#: The issue's check: every fitted IMU error within this many standard errors of the truth.
Z_LIMIT = 3.0


def suite_fields() -> tuple[str, ...]:
    """Return the names of :class:`aeroid.flights.SensorSuite`'s fields (study keys)."""
    return tuple(f.name for f in dataclasses.fields(SensorSuite))


def _tuples(value: Any) -> Any:
    """Return TOML lists as tuples (nested), the form SensorSuite's ranges take."""
    return tuple(_tuples(v) for v in value) if isinstance(value, list) else value


def suite_condition(entry: Mapping[str, Any], label: str, scenario: Scenario,
                    where: str) -> NoiseCondition:
    """Build the :class:`NoiseCondition` of a ``model = "suite"`` entry.

    Raises
    ------
    StudyError
        One line naming ``where``: an unknown key, a bad ``imu``, a suite option the
        :class:`SensorSuite` refuses, or a barometer without the airframe's altitude.
    """
    allowed = suite_fields()
    unknown = sorted(set(entry) - set(SUITE_KEYS) - set(allowed))
    if unknown:
        raise StudyError(f"{where}: unknown sensor-suite option(s) {', '.join(unknown)} "
                         f"(allowed: imu, {', '.join(allowed)})")
    imu = entry.get("imu", "raw")
    if imu not in IMU_CHOICES:
        raise StudyError(f"{where}: imu must be one of {', '.join(IMU_CHOICES)}, got {imu!r}")
    options = {k: _tuples(v) for k, v in entry.items() if k in allowed}
    for key, value in options.items():
        if isinstance(value, bool | Mapping) or (isinstance(value, str)
                                                 and key not in TEXT_FIELDS):
            raise StudyError(f"{where}: sensor-suite option {key} = {value!r} has the "
                             "wrong type")
    for key, value in options.items():  # rates, ranges and sd: finite numbers >= 0
        if key in NAME_LISTS + TEXT_FIELDS:
            continue
        numbers = value if isinstance(value, tuple) else (value,)
        if not all(isinstance(v, int | float) and not isinstance(v, bool)
                   and math.isfinite(v) and v >= 0 for v in numbers):
            raise StudyError(f"{where}: sensor-suite option {key} must be finite numbers "
                             f">= 0, got {value!r}")
    try:
        suite = SensorSuite(**options)
        noise = make_noise("gaussian", accel_sd_mps2=suite.accel_noise_mps2,
                           rate_sd_radps=suite.gyro_noise_radps, position_sd_m=0.0)
    except (AirframeError, TypeError, ValueError) as exc:
        raise StudyError(f"{where}: {' '.join(str(exc).split())}") from None
    if suite.baro_rate_hz > 0 and scenario.airframe.altitude_m is None:
        raise StudyError(f"{where}: the suite's barometer needs the scenario airframe's "
                         "[atmosphere] altitude_m (or baro_rate_hz = 0)")
    return NoiseCondition(label=label, model=noise, suite=suite, imu=imu)


_LATEST: dict[str, Any] = {}


def suite_flight(scenario: Scenario, condition: NoiseCondition,
                 seed: np.random.SeedSequence, scenario_id: str) -> Any:
    """Return the reconstruction's flight of one run under a suite condition.

    ``simulate_suite(airframe, coefficients, manoeuvre, suite, rng=default_rng(seed))``,
    ``reconstruct(sim.log).to_flight(imu=condition.imu)``. With ``imu = "raw"`` the
    flight's metadata gains ``suite_errors``: the drawn biases and scale factors
    (``b``/``s`` + IMU channel), the truth of a fit of the IMU's errors. A corrected IMU
    has none: what remains in it is the drawn errors less the reconstruction's estimate,
    which the study does not score.
    ``scenario_id`` (:func:`aeroid.study.scenario_key`) keys the per-process cache.
    """
    from aeroid.flights import simulate_suite
    from aeroid.reconstruction import reconstruct

    key = repr((scenario_id, condition.describe(), seed.entropy, seed.spawn_key))
    if key not in _LATEST:
        sim = simulate_suite(scenario.airframe, scenario.coefficient_vector,
                             scenario.manoeuvre, condition.suite,
                             rng=np.random.default_rng(seed))
        flight = reconstruct(sim.log).to_flight(imu=condition.imu)
        mounting = condition.suite.mounting() if condition.suite else None
        truth = true_errors(sim.errors, None if mounting is None else mounting.rotation)
        if condition.imu == "raw" and truth is not None:  # corrected: what the correction
            flight = dataclasses.replace(flight, metadata={  # left; not scored
                **flight.metadata, "suite_errors": truth})
        _LATEST.clear()
        _LATEST[key] = flight
    return _LATEST[key]


def true_errors(errors: Mapping[str, np.ndarray], rotation: np.ndarray | None = None
                ) -> dict[str, float] | None:
    """Return the drawn IMU errors by the estimators' names (``b``/``s`` + channel).

    The errors are drawn per sensor axis; with a board mounting (``rotation`` ``C``, sensor
    to body) the body reading is ``C (1 + S) C^T truth + C b``: an axis map (a signed
    permutation) gives the body biases ``C b`` and scale factors ``|C| s``. A rotation that
    mixes axes has no body-axis scale factors: None (not scored).
    """
    from aeroid.model import OUTPUT_CHANNELS

    c = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
    if not np.allclose(np.abs(c).sum(axis=1), 1.0, atol=1e-12):
        return None
    parts = {k: np.asarray(v, dtype=float) for k, v in errors.items()}
    bias = {k: parts[k] @ c.T for k in ("accel_bias", "gyro_bias")}  # rows: C b
    scale = {k: parts[k] @ np.abs(c).T for k in ("accel_scale", "gyro_scale")}
    values = np.concatenate([np.ravel(bias["accel_bias"]), np.ravel(bias["gyro_bias"]),
                             np.ravel(scale["accel_scale"]), np.ravel(scale["gyro_scale"])])
    names = [f"{p}{c}" for p in ("b", "s") for c in OUTPUT_CHANNELS]
    return dict(zip(names, values.tolist(), strict=True))


def imu_error_fields(flight: Any, info: Mapping[str, Any] | None) -> dict[str, Any]:
    """Return a suite record's extra fields: true, fitted and sd of the IMU errors."""
    truth = (flight.metadata or {}).get("suite_errors")
    if truth is None:
        return {}
    info = info or {}
    return {"imu_errors_true": truth,
            "imu_errors": {k: float(v) for k, v in (info.get("imu_errors") or {}).items()},
            "imu_error_stderr": {k: float(v) for k, v in
                                 (info.get("imu_error_stderr") or {}).items()}}




def suite_lines(records: Sequence[Mapping[str, Any]]) -> list[str]:
    """Return the report's section on the fitted IMU errors (markdown lines; [] if none).

    Per (noise, estimator) of the suite conditions whose fits estimated the IMU errors:
    over its successful fits, the largest ``|fitted - true| / sd`` of the biases and of
    the scale factors, and how many fits hold all 18 within 3 sd.
    """
    cells: dict[tuple[str, str], list[tuple[float, float]]] = {}
    for r in records:
        fitted, sd, true = (r.get("imu_errors"), r.get("imu_error_stderr"),
                            r.get("imu_errors_true"))
        if not (r.get("success") and fitted and sd and true):
            continue
        z = {k: abs(v - true[k]) / sd[k] for k, v in fitted.items() if sd.get(k)}
        cells.setdefault((str(r["noise"]), str(r["estimator"])), []).append(
            (max((v for k, v in z.items() if k[0] == "b"), default=math.nan),
             max((v for k, v in z.items() if k[0] == "s"), default=math.nan)))
    if not cells:
        return []
    lines = ["## Sensor-suite conditions: the fitted IMU errors", "",
             f"|fitted - true| / standard error of the {Z_LIMIT:g}-sd check, over the "
             "successful fits that estimated the IMU's biases and scale factors "
             "(the suite's drawn errors are the truth; raw-IMU conditions only: a "
             "corrected IMU keeps what the reconstruction's correction left, which is "
             "not scored).", "",
             "| noise | estimator | fits | max bias \\|z\\| | max scale-factor \\|z\\| | "
             f"fits with every IMU error within {Z_LIMIT:g} sd |", "|---|---|---|---|---|---|"]
    for (noise, label), zs in cells.items():
        bias, scale = np.array(zs).T
        inside = int(np.sum((bias <= Z_LIMIT) & (scale <= Z_LIMIT)))
        lines.append(f"| {noise} | {label} | {len(zs)} | {np.nanmax(bias):.2f} | "
                     f"{np.nanmax(scale):.2f} | {inside} of {len(zs)} |")
    return [*lines, ""]


__all__ = ["IMU_CHOICES", "SUITE_KEYS", "Z_LIMIT", "imu_error_fields", "suite_condition",
           "suite_fields", "suite_flight", "suite_lines", "true_errors"]
