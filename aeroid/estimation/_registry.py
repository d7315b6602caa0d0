"""The estimator registry: method name -> :class:`aeroid.estimation.Estimator` subclass.

Built-ins register in code with the :func:`register` class decorator (the paper's
methods are registered when :mod:`aeroid.estimation` is imported); other installed
packages register classes through the entry-point group ``aeroid.estimators`` (the name
of the entry point is the method name). A name given twice is an error that names both
sources. The registry imports no estimator: it only knows what registered itself.
"""

from __future__ import annotations

from collections.abc import Mapping
from importlib import metadata
from typing import Any

from aeroid.errors import EstimatorError
from aeroid.estimation._estimator import Estimator

__all__ = ["ENTRY_POINT_GROUP", "available", "get_estimator", "load_errors", "make_estimator",
           "register"]

ENTRY_POINT_GROUP = "aeroid.estimators"

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


def available(*, refresh: bool = False) -> dict[str, type[Estimator]]:
    """Return every estimator: built-ins and the ``aeroid.estimators`` entry points.

    An entry point that fails to import is left out and its error is kept
    (:func:`load_errors`); a name given by two sources raises :class:`EstimatorError`.
    """
    global _cache
    if _cache is not None and not refresh:
        return dict(_cache)
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
