"""The estimator interface, the result type and the registry.

An estimator is a frozen, keyword-only dataclass that holds options only (no state is
kept on ``self``: one instance serves many runs and processes). Subclasses implement
:meth:`Estimator.run`; callers use :meth:`Estimator.fit`, which validates the flight,
times the run and turns any failure inside the method into ``success=False`` with a
message (failure is data: a study records it and goes on).

Registry: built-ins register in code with :func:`register`; other installed packages
register classes through the entry-point group ``aeroid.estimators`` (the name of the
entry point is the method name). A name given twice is an error that names both
sources.
"""

from __future__ import annotations

import abc
import dataclasses
import math
import time
import tomllib
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import metadata
from typing import Any, ClassVar

import numpy as np

from aeroid.errors import EstimatorError, FlightError
from aeroid.flights._flight import Flight
from aeroid.model._airframe import Airframe
from aeroid.model._coefficients import NAMES

ENTRY_POINT_GROUP = "aeroid.estimators"



# --------------------------------------------------------------------------------------
# Result
# --------------------------------------------------------------------------------------
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
        Standard errors (9,) and covariance (9, 9) when the method has them.
    cost : float
        Final cost of the method's own objective.
    success : bool
    message : str
    n_evaluations, n_iterations : int
        Objective (or model) evaluations and iterations.
    wall_time_s : float
        Set by :meth:`Estimator.fit`.
    history : dict of str -> ndarray
        ``axis`` ("iteration" or "time") plus ``step`` (n,), ``theta`` (n, 9) and,
        where defined, ``cost`` (n,) and ``theta_sd`` (n, 9): the convergence history
        of the paper's Figs. 4-8 and 13-16.
    info : dict
        Method-specific extras (e.g. reconstructed forces, options used, weighting).
    """

    estimator: str
    theta: np.ndarray
    names: tuple[str, ...] = NAMES
    stderr: np.ndarray | None = None
    covariance: np.ndarray | None = None
    cost: float = math.nan
    success: bool = True
    message: str = ""
    n_evaluations: int = 0
    n_iterations: int = 0
    wall_time_s: float = 0.0
    history: dict[str, Any] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "theta", np.asarray(self.theta, dtype=float).reshape(-1))
        if self.stderr is not None:
            object.__setattr__(self, "stderr", np.asarray(self.stderr, dtype=float).reshape(-1))

    def as_dict(self) -> dict[str, float]:
        """Return estimates as name -> value."""
        return {n: float(v) for n, v in zip(self.names, self.theta, strict=True)}

    def relative_error_pct(self, truth: np.ndarray) -> np.ndarray:
        """Return ``|theta - truth| / |truth| * 100`` per coefficient (the paper's figure)."""
        truth = np.asarray(truth, dtype=float)
        return np.abs(self.theta - truth) / np.abs(truth) * 100.0

    def summary(self, truth: np.ndarray | None = None) -> str:
        """Return a table for people: estimate, standard error and, given truth, error %."""
        status = "ok" if self.success else "FAILED"
        lines = [
            f"{self.estimator}: {status}" + (f" ({self.message})" if self.message else ""),
            f"cost {self.cost:.6g}, {self.n_evaluations} evaluations, "
            f"{self.n_iterations} iterations, {self.wall_time_s:.3f} s",
        ]
        head = f"{'coef':>5} {'estimate':>14} {'std err':>12}"
        if truth is not None:
            head += f" {'truth':>12} {'error %':>9}"
        lines.append(head)
        errors = self.relative_error_pct(truth) if truth is not None else None
        for j, name in enumerate(self.names):
            se = "" if self.stderr is None else f"{self.stderr[j]:.4g}"
            row = f"{name:>5} {self.theta[j]:>14.6g} {se:>12}"
            if truth is not None and errors is not None:
                row += f" {truth[j]:>12.6g} {errors[j]:>9.3f}"
            lines.append(row)
        return "\n".join(lines)

    def to_row(self) -> dict[str, Any]:
        """Return one flat row for tables: scalars, then each estimate and standard error."""
        row: dict[str, Any] = {
            "estimator": self.estimator,
            "success": bool(self.success),
            "message": self.message,
            "cost": float(self.cost),
            "n_evaluations": int(self.n_evaluations),
            "n_iterations": int(self.n_iterations),
            "wall_time_s": float(self.wall_time_s),
        }
        for j, name in enumerate(self.names):
            row[name] = float(self.theta[j])
            row[f"{name}_stderr"] = math.nan if self.stderr is None else float(self.stderr[j])
        return row

    def to_json_dict(self) -> dict[str, Any]:
        """Return the CLI's JSON form."""
        def clean(x: float) -> float | None:
            return None if not math.isfinite(x) else float(x)

        return {
            "method": self.estimator,
            "coefficients": {n: clean(v) for n, v in self.as_dict().items()},
            "stderr": None if self.stderr is None else
            {n: clean(float(v)) for n, v in zip(self.names, self.stderr, strict=True)},
            "success": bool(self.success),
            "message": self.message,
            "cost": clean(float(self.cost)),
            "n_evaluations": int(self.n_evaluations),
            "n_iterations": int(self.n_iterations),
            "wall_time_s": float(self.wall_time_s),
        }


def failed_result(estimator: str, message: str, **fields: Any) -> EstimationResult:
    """Return a ``success=False`` result with NaN estimates."""
    return EstimationResult(estimator=estimator, theta=np.full(len(NAMES), np.nan),
                            success=False, message=message, **fields)


# --------------------------------------------------------------------------------------
# Estimator
# --------------------------------------------------------------------------------------
def _parse_value(text: str) -> Any:
    """Parse an option value given as text: a TOML value, else the plain string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def _coerce(name: str, value: Any, hint: Any, owner: str) -> Any:
    """Check/convert ``value`` against a simple type hint; one-line error if it does not fit."""
    origin = typing.get_origin(hint)
    if origin is typing.Union or isinstance(hint, types.UnionType):
        args = typing.get_args(hint)
        is_none = value is None or (isinstance(value, str) and value.lower() == "none")
        if is_none and type(None) in args:
            return None
        errors = []
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _coerce(name, value, arg, owner)
            except EstimatorError as exc:
                errors.append(str(exc))
        raise EstimatorError(errors[0] if errors else f"{owner}: bad value for {name}")
    if origin is typing.Literal:
        allowed = typing.get_args(hint)
        if value not in allowed:
            raise EstimatorError(
                f"{owner}: option {name}={value!r} not one of {', '.join(map(repr, allowed))}"
            )
        return value
    if hint is bool:
        if isinstance(value, bool):
            return value
        if isinstance(value, str) and value.lower() in ("true", "yes", "on", "1", "false",
                                                        "no", "off", "0"):
            return value.lower() in ("true", "yes", "on", "1")
        raise EstimatorError(f"{owner}: option {name} expects true/false, got {value!r}")
    if hint is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        raise EstimatorError(f"{owner}: option {name} expects an integer, got {value!r}")
    if hint is float:
        if isinstance(value, int | float) and not isinstance(value, bool):
            return float(value)
        raise EstimatorError(f"{owner}: option {name} expects a number, got {value!r}")
    if hint is str:
        return str(value)
    if origin in (tuple, list):
        if not isinstance(value, list | tuple):
            raise EstimatorError(f"{owner}: option {name} expects a list, got {value!r}")
        args = [a for a in typing.get_args(hint) if a is not Ellipsis]
        if len(args) == 1:
            value = [_coerce(name, v, args[0], owner) for v in value]
        return tuple(value) if origin is tuple else list(value)
    return value


@dataclass(frozen=True, kw_only=True)
class Estimator(abc.ABC):
    """Base class of every estimator: a frozen keyword-only dataclass of options.

    Subclasses set the class variables :attr:`name` and :attr:`description`, declare
    their options as dataclass fields with defaults and type hints (used to parse
    ``--option key=value`` and study files), and implement :meth:`run`.
    """

    name: ClassVar[str] = ""
    description: ClassVar[str] = ""

    @abc.abstractmethod
    def run(self, flight: Flight, rng: np.random.Generator) -> EstimationResult:
        """Estimate the nine coefficients from a validated ``flight``.

        Implementations read the airframe from ``flight.airframe`` and never read
        ``flight.metadata["true_coefficients"]``. They may raise on failure:
        :meth:`fit` turns that into ``success=False``.
        """

    def fit(self, flight: Flight, *, rng: np.random.Generator | int | None = None
            ) -> EstimationResult:
        """Validate ``flight``, run the method, time it; never raise for a numerical failure.

        Raises
        ------
        FlightError
            When the flight is invalid (missing channel, NaN, bad time base...).
        """
        flight.validate()
        generator = np.random.default_rng(rng)
        start = time.perf_counter()
        try:
            with np.errstate(all="ignore"):
                result = self.run(flight, generator)
        except FlightError:
            raise
        except Exception as exc:  # failure is data (module docstring)
            text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
            result = failed_result(self.name, f"{type(exc).__name__}: {text}".rstrip(": "))
        elapsed = time.perf_counter() - start
        if result.success and not np.all(np.isfinite(result.theta)):
            result = dataclasses.replace(result, success=False,
                                         message=result.message or "non-finite estimate")
        info = dict(result.info)
        info.setdefault("options", self.options())
        return dataclasses.replace(result, wall_time_s=elapsed, info=info)

    def options(self) -> dict[str, Any]:
        """Return the options as a dict (field name -> value)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @classmethod
    def option_names(cls) -> tuple[str, ...]:
        """Return the names of the options."""
        return tuple(f.name for f in dataclasses.fields(cls))

    @classmethod
    def from_options(cls, options: Mapping[str, Any] | None = None) -> Estimator:
        """Build the estimator from options given as values or as text (``"450"``).

        Raises
        ------
        EstimatorError
            One line naming the estimator and the unknown or invalid option.
        """
        options = dict(options or {})
        owner = cls.name or cls.__name__
        allowed = cls.option_names()
        unknown = sorted(set(options) - set(allowed))
        if unknown:
            raise EstimatorError(
                f"{owner}: unknown option(s) {', '.join(unknown)} "
                f"(options: {', '.join(allowed) or 'none'})"
            )
        hints = typing.get_type_hints(cls)
        kwargs = {}
        for key, value in options.items():
            if isinstance(value, str):
                value = _parse_value(value)
            kwargs[key] = _coerce(key, value, hints.get(key, Any), owner)
        try:
            return cls(**kwargs)
        except (TypeError, ValueError) as exc:
            raise EstimatorError(f"{owner}: {exc}") from None


def prior_bounds(airframe: Airframe, box: Any = None,
                 scale: tuple[float, float] = (0.5, 1.5)) -> np.ndarray:
    """Return the PSO search box, shape (9, 2) [low, high] per coefficient.

    The box is the airframe's prior (nominal values when it has none) times ``scale``,
    sorted per coefficient (negative coefficients flip), or ``box`` when given: a
    (9, 2) array-like, or a flat list of 18 numbers ``[low0, high0, low1, ...]``.
    The true coefficients are never read.
    """
    if box is not None:
        arr = np.asarray(box, dtype=float).reshape(9, 2)
        if not (np.all(np.isfinite(arr)) and np.all(arr[:, 0] < arr[:, 1])):
            raise EstimatorError("search box: need 9 finite [low, high] pairs with low < high")
        return arr
    prior = airframe.prior_vector()
    ends = np.stack([prior * scale[0], prior * scale[1]], axis=1)
    return np.sort(ends, axis=1)


# --------------------------------------------------------------------------------------
# Registry
# --------------------------------------------------------------------------------------
_BUILTIN: dict[str, type[Estimator]] = {}
_cache: dict[str, type[Estimator]] | None = None
_load_errors: dict[str, str] = {}


def _source(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def register(cls: type[Estimator]) -> type[Estimator]:
    """Class decorator registering a built-in estimator under ``cls.name``."""
    if not cls.name:
        raise EstimatorError(f"{_source(cls)}: estimator class has no name")
    other = _BUILTIN.get(cls.name)
    if other is not None and other is not cls:
        raise EstimatorError(
            f"estimator name {cls.name!r} registered twice: {_source(other)} and {_source(cls)}"
        )
    _BUILTIN[cls.name] = cls
    global _cache
    _cache = None
    return cls


def _load_builtins() -> None:
    # importing the modules runs their @register decorators
    from aeroid.estimation import _eam, _ebm, _sebm  # noqa: F401


def available(*, refresh: bool = False) -> dict[str, type[Estimator]]:
    """Return every estimator: built-ins and the ``aeroid.estimators`` entry points.

    An entry point that fails to import is left out and its error is kept
    (:func:`load_errors`); a name given by two sources raises :class:`EstimatorError`.
    """
    global _cache
    if _cache is not None and not refresh:
        return dict(_cache)
    _load_builtins()
    found: dict[str, type[Estimator]] = dict(_BUILTIN)
    sources = {name: _source(cls) for name, cls in found.items()}
    _load_errors.clear()
    for ep in metadata.entry_points(group=ENTRY_POINT_GROUP):
        where = f"entry point {ep.value}"
        try:
            cls = ep.load()
        except Exception as exc:  # a broken plug-in must not break the others
            _load_errors[ep.name] = f"{where}: {type(exc).__name__}: {exc}"
            continue
        if ep.name in found and found[ep.name] is not cls:
            raise EstimatorError(
                f"estimator name {ep.name!r} registered twice: {sources[ep.name]} and {where}"
            )
        if not (isinstance(cls, type) and issubclass(cls, Estimator)):
            _load_errors[ep.name] = f"{where}: not an aeroid Estimator subclass"
            continue
        found[ep.name] = cls
        sources[ep.name] = where
    _cache = found
    return dict(found)


def load_errors() -> dict[str, str]:
    """Return entry points that failed to load: name -> one-line reason."""
    available()
    return dict(_load_errors)


def get_estimator(name: str) -> type[Estimator]:
    """Return the estimator class registered as ``name``.

    Raises
    ------
    EstimatorError
        ``unknown method 'x' (available: ...)``.
    """
    classes = available()
    if name not in classes:
        hint = f"; {_load_errors[name]}" if name in _load_errors else ""
        raise EstimatorError(
            f"unknown method {name!r} (available: {', '.join(sorted(classes))}){hint}"
        )
    return classes[name]


def make_estimator(name: str, options: Mapping[str, Any] | None = None) -> Estimator:
    """Return ``get_estimator(name).from_options(options)``."""
    return get_estimator(name).from_options(options)
