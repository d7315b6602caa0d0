"""Study files: load, validate and describe a Monte Carlo study design.

A study file is TOML with three parts::

    [study]
    name = "quick"              # optional, default: the file's stem
    description = "..."         # optional
    runs = 3                    # required, >= 1
    seed = 20240611             # required, >= 0: the root of every random draw
    scenario = "reference"      # optional: "reference" (embedded) or a scenario file,
                                # relative to the study file
    prior_offset = [0.10, 0.25] # optional: each run's estimators start from a prior
                                # truth x (1 +- U(lo, hi)); default: the airframe's prior
    windows = "5-6,7-8"         # optional: fit these time ranges [s] of each flight
                                # together (shared coefficients); default: the flight

    [perturb]                   # optional: mass_rel_sd = 0.03 draws each run's flown
                                # mass (aeroid.study._perturb)

    [[noise]]                   # optional, repeatable; default: one "paper" condition
    label = "paper xi=0.05"     # unique
    model = "paper"             # "paper" | "gaussian" | "none" (aeroid.make_noise)
    accelerations_xi = 0.05     # any further key is an option of that model
                                # model = "suite": a SensorSuite log, reconstructed
                                # (aeroid.study._suite: imu = "raw" | "corrected")

    [[estimators]]              # required, repeatable
    label = "SEBM-PSO"          # unique; the same method may appear under two labels
    method = "sebm-pso"         # a registered estimator (aeroid.available())
    options = { n_iterations = 100 }

Everything is checked on load, before any run starts: malformed TOML, a missing or
unknown key, an unknown noise model, option or option value (a noise model is tried
on a few samples, so an option of the wrong type fails here, not mid-study), an
unknown estimator or option each raise :class:`aeroid.errors.StudyError` with one line
naming the file, what is wrong and where. Every estimator is built on load with
``make_estimator(method, options)``. The study file and a scenario file must be
regular files of at most :data:`MAX_FILE_BYTES` (``/dev/zero`` or a FIFO is refused
before reading); sizes are bounded (:data:`aeroid.study._spec.MAX_RUNS`, ``MAX_FITS``).

Decision the notes leave open: a noise model's options default to the scenario's
``[noise.<model>]`` table (the reference scenario: the paper's xi = 0.05 / 0.05 / 0.1),
overridden by the keys given in the study file.
"""

from __future__ import annotations

import stat
import tomllib
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from aeroid.errors import AirframeError, EstimatorError, FlightError, StudyError
from aeroid.estimation import Estimator
from aeroid.flights import (
    ACCEL_CHANNELS,
    RATE_CHANNELS,
    NoiseModel,
    Scenario,
    check_window_ranges,
    make_noise,
    scenario_from_dict,
)
from aeroid.model import read_toml, reference_scenario_data
from aeroid.study._perturb import check_perturb
from aeroid.study._spec import EstimatorSpec, NoiseCondition, Study, check_prior_offset
from aeroid.study._suite import suite_condition

#: Largest study or scenario file read [bytes] (the shipped ones are a few kB).
MAX_FILE_BYTES = 1_000_000

STUDY_KEYS = ("name", "description", "runs", "seed", "scenario", "prior_offset", "windows")
NOISE_KEYS = ("label", "model")
ESTIMATOR_KEYS = ("label", "method", "options")
TOP_LEVEL = ("study", "noise", "estimators", "perturb")


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
    data = read_study_toml(path)
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


def read_study_toml(path: Path, what: str = "") -> dict[str, Any]:
    """Read a TOML file after checking it is a regular file of at most MAX_FILE_BYTES.

    Raises
    ------
    StudyError
        One line: ``[what: ]path: reason``.
    """
    where = f"{what}: {path}" if what else str(path)
    try:
        info = path.stat()
    except FileNotFoundError:
        raise StudyError(f"{where}: no such file") from None
    except OSError as exc:
        raise StudyError(f"{where}: cannot read ({exc.strerror})") from None
    if not stat.S_ISREG(info.st_mode):
        kind = "a folder" if stat.S_ISDIR(info.st_mode) else "not a regular file"
        raise StudyError(f"{where}: {kind} (a TOML file is expected)")
    if info.st_size > MAX_FILE_BYTES:
        raise StudyError(f"{where}: {info.st_size} bytes, over the limit of "
                         f"{MAX_FILE_BYTES} for a TOML file")
    try:
        return read_toml(path)
    except AirframeError as exc:
        text = str(exc).replace("malformed TOML", "invalid TOML")
        raise StudyError(f"{what}: {text}" if what else text) from None


def _check_name(name: Any, source: str) -> str:
    if (not isinstance(name, str) or not name.strip() or name.strip().strip(".") == ""
            or any(c in name for c in "/\\") or not name.isprintable()):
        raise StudyError(f"{source}: [study] name must be a non-empty printable string "
                         f"without '/', '\\' and not only dots, got {name!r}")
    return name.strip()


def _check_noise(model: NoiseModel, where: str) -> None:
    """Check the model on a few samples (errors must not wait for a run).

    The option values themselves (finite numbers >= 0) are checked when the model is
    built (:func:`aeroid.make_noise`).
    """
    rng = np.random.default_rng(0)
    channels = {c: np.ones(4) for c in (*ACCEL_CHANNELS, *RATE_CHANNELS)}
    try:
        out = model.corrupt(channels, rng)
        positions = model.perturb_positions(np.full((2, 3), 0.1), rng)
        ok = (all(np.all(np.isfinite(np.asarray(out[c], dtype=float))) for c in channels)
              and np.shape(positions) == (2, 3) and np.all(np.isfinite(positions)))
    except Exception as exc:  # any failure of the model on good data is a bad option
        raise StudyError(f"{where}: the noise model fails with these options "
                         f"({type(exc).__name__}: {' '.join(str(exc).split())})") from None
    if not ok:
        raise StudyError(f"{where}: the noise model gives non-finite values with these "
                         "options")


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
        data = read_study_toml(path, f"{source}: [study] scenario")
        scenario = scenario_from_dict(data, source=str(path))
        return scenario, data, str(path)
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
    name = _check_name(head.get("name", Path(source).stem), source)
    prior_offset = (None if "prior_offset" not in head
                    else check_prior_offset(head["prior_offset"], source))
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
        if not isinstance(model, str):
            raise StudyError(f"{source}: {where} ({label}): model must be a string, "
                             f"got {model!r}")
        if model == "suite":  # log through a SensorSuite, fit its reconstruction
            noise.append(suite_condition(entry, label, scenario,
                                         f"{source}: {where} ({label})"))
            continue
        options = {**scenario_data.get("noise", {}).get(model, {}),
                   **{key: v for key, v in entry.items() if key not in NOISE_KEYS}}
        try:
            built = make_noise(model, **options)
        except (TypeError, ValueError) as exc:
            raise StudyError(f"{source}: {where} ({label}): {exc}") from None
        _check_noise(built, f"{source}: {where} ({label})")
        noise.append(NoiseCondition(label=label, model=built))

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
        if not isinstance(method, str):
            raise StudyError(f"{source}: {where} ({label}): method must be a string "
                             f"(see aeroid methods), got {method!r}")
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
    windows = None if "windows" not in head else check_study_windows(
        head["windows"], scenario, estimators, source)
    check_study_tables(scenario, estimators, noise, prior_offset, source)
    return Study(name=name.strip(), runs=head["runs"], seed=head["seed"], scenario=scenario,
                 noise=tuple(noise), estimators=tuple(estimators),
                 description=str(head.get("description", "")), scenario_ref=scenario_ref,
                 source=source, skipped=tuple(skipped), prior_offset=prior_offset,
                 windows=windows, mass_rel_sd=check_perturb(data.get("perturb", {}), scenario,
                                                            source))


def check_study_windows(value: Any, scenario: Any, estimators: list[EstimatorSpec],
                        source: str) -> str:
    """Return ``[study] windows`` after checking it against the scenario's recorded window
    and the estimators (each must fit several windows).

    Raises
    ------
    StudyError
        One line naming the file, the key and what is wrong.
    """
    where = f"{source}: [study] windows"
    if not isinstance(value, str):
        raise StudyError(f"{where} must be a string of time ranges like \"5-6,7-8\", "
                         f"got {value!r}")
    first, last = scenario.manoeuvre.window_s
    try:
        check_window_ranges(value, float(first), float(last), "the scenario's recording")
    except FlightError as exc:
        raise StudyError(f"{where}: {exc}") from None
    unable = [e.label for e in estimators
              if not getattr(e.estimator, "supports_windows", False)]
    if unable:
        raise StudyError(f"{where}: {', '.join(unable)} cannot fit several windows "
                         "(methods that can: output-error, ekf, ukf, equation-error)")
    return value


__all__ = ["EstimatorSpec", "NoiseCondition", "Study", "load_study", "loads_study",
           "quick_study_path", "study_from_dict"]


def check_study_tables(scenario: Any, estimators: list[EstimatorSpec], noise: list[Any],
                       prior_offset: Any, source: str) -> None:
    """Refuse in one line what a study of coefficient tables cannot do.

    A scenario whose true coefficients are tables needs the fits' ``[tables]`` (else
    each fit would score constants against a truth that varies); the fits' tables
    need estimators that fit them (``fits_tables``), no ``prior_offset`` (drawn per
    constant coefficient) and no sensor-suite condition when the truth is tables (its
    simulator flies constant coefficients; a constant truth fitted as tables is allowed).
    """
    if scenario.airframe.tables is None:
        if scenario.tables is not None:
            raise StudyError(f"{source}: the scenario's true coefficients are tables in Mach "
                             "and its airframe has no [tables]: give the fits' knots there")
        return
    where = f"{source}: [study] scenario with [tables]"
    unable = [e.label for e in estimators if not getattr(e.estimator, "fits_tables", False)]
    if unable:
        raise StudyError(f"{where}: {', '.join(unable)} cannot fit tables (output-error, "
                         "equation-error, ekf and ukf can)")
    if prior_offset is not None:
        raise StudyError(f"{where}: prior_offset draws one prior per constant coefficient; "
                         "it is not available with tables")
    suites = [n.label for n in noise if n.suite is not None]
    if suites and scenario.tables is not None:  # constant truth: the suite flies it
        raise StudyError(f"{where}: sensor-suite condition(s) {', '.join(suites)} are not "
                         "available with tables")
