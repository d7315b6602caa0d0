"""A validated study design: noise conditions, estimators, and the study itself.

These are the types :func:`aeroid.study.load_study` builds; constructing a
:class:`Study` checks what does not need the file (sizes, duplicate labels). The
*fingerprint* (scenario, seed, noise conditions, estimators and their options, but not
``runs``, ``name`` or ``description``) guards ``--resume``: results of another design
are never mixed in.

Size limits (checked before anything is allocated): :data:`MAX_RUNS` runs and
:data:`MAX_FITS` fits per study. The paper's Table 5 is 100 runs, 800 fits; a million
fits of the fastest estimator is already days of computing and a results file of
gigabytes.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from aeroid.errors import StudyError
from aeroid.estimation import Estimator
from aeroid.flights import NoiseModel, Scenario, SensorSuite

MAX_RUNS = 100_000
MAX_FITS = 1_000_000


@dataclass(frozen=True, kw_only=True)
class NoiseCondition:
    """One sensor-noise condition of a study.

    Attributes
    ----------
    label : str
        Unique name used in tables and file names.
    model : NoiseModel
        The built noise model (:func:`aeroid.make_noise`). For a sensor-suite condition:
        the suite's white IMU noise as Gaussian noise (what :attr:`suite` adds to every
        reading besides its biases and scale factors); no flight is drawn from it.
    suite : SensorSuite, optional
        None (default): the run's flight is the scenario's single-rate log with
        :attr:`model`'s noise. Given: the flight is logged through this suite
        (:func:`aeroid.flights.simulate_suite`), reconstructed
        (:func:`aeroid.reconstruction.reconstruct`) and fitted as the reconstruction's
        ``to_flight(imu=...)``.
    imu : {"raw", "corrected"}
        The reconstruction's IMU channels the estimators see (suite conditions only).
    """

    label: str
    model: NoiseModel
    suite: SensorSuite | None = None
    imu: str = "raw"

    def describe(self) -> dict[str, Any]:
        """Return the label and the model's (or the suite's) full settings (JSON-ready)."""
        if self.suite is None:
            return {"label": self.label, **self.model.to_dict()}
        return {"label": self.label, "model": "suite", "imu": self.imu,
                **_jsonable(dataclasses.asdict(self.suite))}


@dataclass(frozen=True, kw_only=True)
class EstimatorSpec:
    """One estimator of a study: a label and a built (frozen, option-only) estimator.

    Attributes
    ----------
    label : str
        Unique name used in tables and file names (e.g. ``"EBM-PSO forces"``).
    estimator : Estimator
        The estimator instance; ``estimator.name`` is its method name.
    """

    label: str
    estimator: Estimator

    @property
    def method(self) -> str:
        """The registered method name (``estimator.name``)."""
        return self.estimator.name or type(self.estimator).__name__

    def describe(self) -> dict[str, Any]:
        """Return label, method and the options in use (JSON-ready)."""
        return {"label": self.label, "method": self.method,
                "options": _jsonable(self.estimator.options())}


@dataclass(frozen=True, kw_only=True)
class Study:
    """A validated study design.

    Attributes
    ----------
    name : str
    runs : int
        Number of Monte Carlo runs (each run: one flight per noise condition).
    seed : int
        Root seed; run ``i`` draws from ``SeedSequence(seed, spawn_key=(i, ...))``.
    scenario : Scenario
        Airframe, true coefficients and manoeuvre of every simulated flight.
    noise : tuple of NoiseCondition
    estimators : tuple of EstimatorSpec
    description : str
    scenario_ref : str
        ``"reference"`` or the scenario file path as resolved on load.
    source : str
        The study file (or ``"<memory>"``).
    skipped : tuple of str
        Estimators of the file left out because they are not installed (quick study only).
    prior_offset : tuple of 2 float, optional
        ``(lo, hi)`` with ``0 <= lo <= hi < 1``: every run starts its estimators from a
        prior off the truth, each coefficient ``truth (1 + s U(lo, hi))`` with a random
        sign ``s`` (:func:`aeroid.study.run_prior`). None (default): the prior is the
        scenario airframe's (the nominal set, i.e. the truth, for the reference).
    windows : str, optional
        ``"5-6,7-8"``: every run's flight is cut into these time ranges [s] and each
        estimator fits them together, coefficients shared
        (:func:`aeroid.flights.cut_windows`). None (default): the whole flight.
    mass_rel_sd : float, optional
        ``[perturb] mass_rel_sd``: each run's truth flies its own mass, the scenario's
        times ``1 + mass_rel_sd z`` (:mod:`aeroid.study._perturb`); the estimators are
        told the file's. None (default): every run flies the scenario's mass.
    """

    name: str
    runs: int
    seed: int
    scenario: Scenario
    noise: tuple[NoiseCondition, ...]
    estimators: tuple[EstimatorSpec, ...]
    description: str = ""
    scenario_ref: str = "reference"
    source: str = "<memory>"
    skipped: tuple[str, ...] = field(default=())
    prior_offset: tuple[float, float] | None = None
    windows: str | None = None
    mass_rel_sd: float | None = None

    def __post_init__(self) -> None:
        if self.prior_offset is not None:
            object.__setattr__(self, "prior_offset",
                               check_prior_offset(self.prior_offset, self.source))
        if isinstance(self.runs, bool) or not isinstance(self.runs, int) or self.runs < 1:
            raise StudyError(f"{self.source}: [study] runs must be an integer >= 1, "
                             f"got {self.runs!r}")
        if self.runs > MAX_RUNS:
            raise StudyError(f"{self.source}: [study] runs = {self.runs} is over the limit "
                             f"of {MAX_RUNS}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise StudyError(f"{self.source}: [study] seed must be an integer >= 0, "
                             f"got {self.seed!r}")
        if not self.noise:
            raise StudyError(f"{self.source}: no noise condition")
        if not self.estimators:
            raise StudyError(f"{self.source}: no [[estimators]] entry")
        for what, labels in (("noise", [n.label for n in self.noise]),
                             ("estimators", [e.label for e in self.estimators])):
            dup = sorted({x for x in labels if labels.count(x) > 1})
            if dup:
                raise StudyError(f"{self.source}: [[{what}]] label(s) given twice: "
                                 f"{', '.join(dup)}")
        if self.n_fits > MAX_FITS:
            raise StudyError(f"{self.source}: {self.runs} runs x {len(self.noise)} noise x "
                             f"{len(self.estimators)} estimators = {self.n_fits} fits is over "
                             f"the limit of {MAX_FITS}")

    def with_runs(self, runs: int) -> Study:
        """Return a copy with another number of runs (``--runs``)."""
        return dataclasses.replace(self, runs=runs)

    @property
    def n_fits(self) -> int:
        """Fits in the whole study: runs x noise conditions x estimators."""
        return self.runs * len(self.noise) * len(self.estimators)

    def describe(self) -> dict[str, Any]:
        """Return the design as a JSON-ready dict (written beside the results)."""
        return {
            "name": self.name, "description": self.description, "runs": self.runs,
            "seed": self.seed, "scenario": self.scenario_ref, "source": self.source,
            "true_coefficients": list(self.scenario.coefficients),
            "noise": [n.describe() for n in self.noise],
            "estimators": [e.describe() for e in self.estimators],
            "skipped": list(self.skipped),
            "prior_offset": None if self.prior_offset is None else list(self.prior_offset),
            "windows": self.windows,
            **({} if self.mass_rel_sd is None else {"perturb": {"mass_rel_sd": self.mass_rel_sd}}),
            "fingerprint": self.fingerprint(),
        }

    def fingerprint(self) -> str:
        """Return a hash of what decides the results (not runs, name or description)."""
        key = {
            "seed": self.seed,
            "scenario": {"coefficients": list(self.scenario.coefficients),
                         "airframe": _jsonable(self.scenario.airframe.to_dict()),
                         "manoeuvre": _jsonable(self.scenario.manoeuvre.describe())},
            "noise": [n.describe() for n in self.noise],
            "estimators": [e.describe() for e in self.estimators],
        }
        if self.prior_offset is not None:  # absent: the fingerprint of earlier studies
            key["prior_offset"] = list(self.prior_offset)
        if self.windows is not None:  # absent: the fingerprint of earlier studies
            key["windows"] = self.windows
        if self.mass_rel_sd is not None:  # absent: the fingerprint of earlier studies
            key["perturb"] = {"mass_rel_sd": self.mass_rel_sd}
        text = json.dumps(key, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def check_prior_offset(value: Any, source: str = "<memory>") -> tuple[float, float]:
    """Return ``[lo, hi]`` as a tuple after checking ``0 <= lo <= hi < 1``.

    Raises
    ------
    StudyError
        One line naming the file and the key.
    """
    where = f"{source}: [study] prior_offset"
    if (not isinstance(value, list | tuple) or len(value) != 2
            or any(isinstance(v, bool) or not isinstance(v, int | float) for v in value)
            or any(isinstance(v, int) and abs(v) > 1e308 for v in value)):  # float() overflows
        raise StudyError(f"{where} must be two numbers [lo, hi], got {value!r}")
    lo, hi = (float(v) for v in value)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 <= lo <= hi < 1.0):
        raise StudyError(f"{where} = [{lo:g}, {hi:g}]: need 0 <= lo <= hi < 1 (fractions "
                         "of each true coefficient)")
    return lo, hi


def _jsonable(value: Any) -> Any:
    """Return ``value`` with tuples as lists and unknown objects as text."""
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if value is None or isinstance(value, bool | int | float | str):
        return value
    return str(value)




__all__ = ["MAX_FITS", "MAX_RUNS", "EstimatorSpec", "NoiseCondition", "Study",
           "check_prior_offset"]
