"""Study files: load, validate and describe a Monte Carlo study design.

A study file is TOML with three parts::

    [study]
    name = "quick"              # optional, default: the file's stem
    description = "..."         # optional
    runs = 3                    # required, >= 1
    seed = 20240611             # required, >= 0: the root of every random draw
    scenario = "reference"      # optional: "reference" (embedded) or a scenario file,
                                # relative to the study file

    [[noise]]                   # optional, repeatable; default: one "paper" condition
    label = "paper xi=0.05"     # unique
    model = "paper"             # "paper" | "gaussian" | "none" (aeroid.make_noise)
    accelerations_xi = 0.05     # any further key is an option of that model

    [[estimators]]              # required, repeatable
    label = "SEBM-PSO"          # unique; the same method may appear under two labels
    method = "sebm-pso"         # a registered estimator (aeroid.available())
    options = { n_iterations = 100 }

Everything is checked on load, before any run starts: malformed TOML, a missing or
unknown key, an unknown noise model or option, an unknown estimator or option each
raise :class:`aeroid.errors.StudyError` with one line naming the file, what is wrong
and where. Every estimator is built on load with ``make_estimator(method, options)``.

Decisions the notes leave open:

- A noise model's options default to the scenario's ``[noise.<model>]`` table (the
  reference scenario: the paper's xi = 0.05 / 0.05 / 0.1), overridden by the keys given
  in the study file.
- The study's *fingerprint* (scenario, seed, noise conditions, estimators and their
  options, but not ``runs``, ``name`` or ``description``) guards ``--resume``: results
  of another design are never mixed in.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from aeroid.errors import AirframeError, EstimatorError, StudyError
from aeroid.estimation import Estimator
from aeroid.flights._noise import NOISE_MODELS, NoiseModel, make_noise
from aeroid.flights._scenario import Scenario, scenario_from_dict
from aeroid.model._airframe import read_toml, reference_scenario_data

STUDY_KEYS = ("name", "description", "runs", "seed", "scenario")
NOISE_KEYS = ("label", "model")
ESTIMATOR_KEYS = ("label", "method", "options")
TOP_LEVEL = ("study", "noise", "estimators")


@dataclass(frozen=True, kw_only=True)
class NoiseCondition:
    """One sensor-noise condition of a study.

    Attributes
    ----------
    label : str
        Unique name used in tables and file names.
    model : NoiseModel
        The built noise model (:func:`aeroid.make_noise`).
    """

    label: str
    model: NoiseModel

    def describe(self) -> dict[str, Any]:
        """Return the label and the model's full settings (JSON-ready)."""
        return {"label": self.label, **self.model.to_dict()}


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

    def __post_init__(self) -> None:
        if isinstance(self.runs, bool) or not isinstance(self.runs, int) or self.runs < 1:
            raise StudyError(f"{self.source}: [study] runs must be an integer >= 1, "
                             f"got {self.runs!r}")
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
            "skipped": list(self.skipped), "fingerprint": self.fingerprint(),
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
        text = json.dumps(key, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def _jsonable(value: Any) -> Any:
    """Return ``value`` with tuples as lists and unknown objects as text."""
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if value is None or isinstance(value, bool | int | float | str):
        return value
    return str(value)


def quick_study_path() -> Path:
    """Return the path of the embedded default study (``aeroid/data/quick_study.toml``)."""
    return Path(str(resources.files("aeroid") / "data" / "quick_study.toml"))


def _registry() -> Mapping[str, type[Estimator]]:
    from aeroid.estimation import available

    try:
        return available()
    except ImportError as exc:
        raise StudyError(f"the estimator registry failed to load: {exc}") from None


def load_study(path: str | Path | None = None, *,
               registry: Mapping[str, type[Estimator]] | None = None,
               skip_missing: bool | None = None) -> Study:
    """Load and validate a study file; ``None`` gives the quick default study.

    Parameters
    ----------
    path : path-like, optional
        The study TOML file (default: :func:`quick_study_path`).
    registry : mapping of str to Estimator subclass, optional
        Method name -> class (default: :func:`aeroid.available`). Tests and embedding
        programs inject their own.
    skip_missing : bool, optional
        Leave out estimators whose method is not installed (with their label in
        ``Study.skipped``) instead of failing. Default: True for the quick study only.

    Raises
    ------
    StudyError
        One line: the file, what is wrong and where.
    """
    quick = path is None
    path = quick_study_path() if quick else Path(path)
    try:
        data = read_toml(path)
    except AirframeError as exc:
        raise StudyError(str(exc).replace("malformed TOML", "invalid TOML")) from None
    return study_from_dict(data, source=str(path), base_dir=path.parent, registry=registry,
                           skip_missing=quick if skip_missing is None else skip_missing)


def loads_study(text: str, *, base_dir: str | Path = ".", source: str = "<string>",
                registry: Mapping[str, type[Estimator]] | None = None,
                skip_missing: bool = False) -> Study:
    """Parse and validate a study given as TOML text (see :func:`load_study`)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise StudyError(f"{source}: invalid TOML ({exc})") from None
    return study_from_dict(data, source=source, base_dir=Path(base_dir), registry=registry,
                           skip_missing=skip_missing)


def _check_keys(table: Any, allowed: tuple[str, ...], where: str, source: str,
                required: tuple[str, ...] = ()) -> None:
    if not isinstance(table, Mapping):
        raise StudyError(f"{source}: {where} must be a table")
    missing = [k for k in required if k not in table]
    if missing:
        raise StudyError(f"{source}: {where} is missing {', '.join(missing)}")
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise StudyError(f"{source}: {where} has unknown key(s) {', '.join(unknown)} "
                         f"(allowed: {', '.join(allowed)})")


def _label(entry: Mapping[str, Any], where: str, source: str) -> str:
    label = entry["label"]
    if not isinstance(label, str) or not label.strip():
        raise StudyError(f"{source}: {where} label must be a non-empty string")
    return label.strip()


def _load_scenario(ref: Any, base_dir: Path, source: str) -> tuple[Scenario, dict, str]:
    if not isinstance(ref, str) or not ref:
        raise StudyError(f"{source}: [study] scenario must be \"reference\" or a file path")
    try:
        if ref == "reference":
            data = reference_scenario_data()
            return scenario_from_dict(data, source="reference"), data, ref
        path = Path(ref) if Path(ref).is_absolute() else base_dir / ref
        data = read_toml(path)
        return scenario_from_dict(data, source=str(path)), data, str(path)
    except AirframeError as exc:
        raise StudyError(f"{source}: [study] scenario: {exc}") from None


def study_from_dict(data: Mapping[str, Any], *, source: str = "<memory>",
                    base_dir: str | Path = ".",
                    registry: Mapping[str, type[Estimator]] | None = None,
                    skip_missing: bool = False) -> Study:
    """Validate the parsed form of a study file and build the :class:`Study`.

    See :func:`load_study` for the parameters and the module docstring for the format.
    """
    base_dir = Path(base_dir)
    unknown = sorted(set(data) - set(TOP_LEVEL))
    if unknown:
        raise StudyError(f"{source}: unknown table(s) {', '.join(unknown)} "
                         f"(allowed: {', '.join(TOP_LEVEL)})")
    if "study" not in data:
        raise StudyError(f"{source}: no [study] table")
    head = data["study"]
    _check_keys(head, STUDY_KEYS, "[study]", source, required=("runs", "seed"))
    name = head.get("name", Path(source).stem)
    if not isinstance(name, str) or not name.strip() or "/" in name:
        raise StudyError(f"{source}: [study] name must be a non-empty string without '/'")
    scenario, scenario_data, scenario_ref = _load_scenario(
        head.get("scenario", "reference"), base_dir, source)

    noise_entries = data.get("noise", [{"label": "paper", "model": "paper"}])
    if not isinstance(noise_entries, list):
        raise StudyError(f"{source}: noise must be an array of tables ([[noise]])")
    noise = []
    for k, entry in enumerate(noise_entries):
        where = f"[[noise]] #{k + 1}"
        if not isinstance(entry, Mapping):
            raise StudyError(f"{source}: {where} must be a table")
        missing = [key for key in NOISE_KEYS if key not in entry]
        if missing:
            raise StudyError(f"{source}: {where} is missing {', '.join(missing)}")
        label = _label(entry, where, source)
        model = entry["model"]
        if model not in NOISE_MODELS:
            raise StudyError(f"{source}: {where} ({label}): unknown noise model {model!r} "
                             f"(expected one of {', '.join(NOISE_MODELS)})")
        options = {**scenario_data.get("noise", {}).get(model, {}),
                   **{key: v for key, v in entry.items() if key not in NOISE_KEYS}}
        try:
            noise.append(NoiseCondition(label=label, model=make_noise(model, **options)))
        except ValueError as exc:
            raise StudyError(f"{source}: {where} ({label}): {exc}") from None

    est_entries = data.get("estimators")
    if not isinstance(est_entries, list) or not est_entries:
        raise StudyError(f"{source}: no [[estimators]] entry")
    classes = _registry() if registry is None else dict(registry)
    estimators, skipped = [], []
    for k, entry in enumerate(est_entries):
        where = f"[[estimators]] #{k + 1}"
        _check_keys(entry, ESTIMATOR_KEYS, where, source, required=("label", "method"))
        label = _label(entry, where, source)
        method, options = entry["method"], entry.get("options", {})
        if not isinstance(options, Mapping):
            raise StudyError(f"{source}: {where} ({label}): options must be a table")
        if method not in classes:
            if skip_missing:
                skipped.append(f"{label} ({method})")
                continue
            raise StudyError(f"{source}: {where} ({label}): unknown method {method!r} "
                             f"(available: {', '.join(sorted(classes)) or 'none'})")
        try:
            estimator = classes[method].from_options(options)
        except EstimatorError as exc:
            raise StudyError(f"{source}: {where} ({label}): {exc}") from None
        estimators.append(EstimatorSpec(label=label, estimator=estimator))
    if not estimators:
        raise StudyError(f"{source}: none of the estimators is installed "
                         f"(skipped: {', '.join(skipped)})")
    return Study(name=name.strip(), runs=head["runs"], seed=head["seed"], scenario=scenario,
                 noise=tuple(noise), estimators=tuple(estimators),
                 description=str(head.get("description", "")), scenario_ref=scenario_ref,
                 source=source, skipped=tuple(skipped))


__all__ = ["EstimatorSpec", "NoiseCondition", "Study", "load_study", "loads_study",
           "quick_study_path", "study_from_dict"]
