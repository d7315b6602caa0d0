"""``aeroid estimate`` and ``aeroid methods`` (dispatched from :mod:`aeroid.cli`).

User errors (unreadable or invalid flight, unknown method or option, malformed
``--option``) raise the classes of :data:`aeroid.errors.USER_ERRORS`; the CLI prints
them as one line and exits with status 2.
"""

from __future__ import annotations

import argparse
import json

from aeroid.errors import EstimatorError
from aeroid.estimation._interface import available, load_errors, make_estimator
from aeroid.flights._files import read_column_map, read_flight
from aeroid.model._airframe import load_airframe

__all__ = ["estimate", "methods", "parse_options", "read_column_map"]


def parse_options(pairs: list[str] | None) -> dict[str, str]:
    """Return ``{key: value text}`` from ``["key=value", ...]``.

    Raises
    ------
    EstimatorError
        ``--option 'x': expected KEY=VALUE`` for a malformed pair or a repeated key.
    """
    options: dict[str, str] = {}
    for pair in pairs or []:
        key, sep, value = pair.partition("=")
        key = key.strip()
        if not sep or not key or not value.strip():
            raise EstimatorError(f"--option {pair!r}: expected KEY=VALUE")
        if key in options:
            raise EstimatorError(f"--option {key!r} given twice")
        options[key] = value.strip()
    return options


def estimate(args: argparse.Namespace) -> int:
    """Run ``aeroid estimate``: read, fit (which validates), print a table or JSON.

    Returns 0, or 1 when the method failed (``success=False``: the result, with its
    message, is still printed), so scripts can tell.
    """
    options = parse_options(getattr(args, "option", None))
    estimator = make_estimator(args.method, options)
    airframe = load_airframe(args.airframe) if getattr(args, "airframe", None) else None
    columns = read_column_map(args.columns) if getattr(args, "columns", None) else None
    flight = read_flight(args.flight, airframe=airframe, columns=columns,
                         angles_in_degrees=bool(getattr(args, "degrees", False)))
    result = estimator.fit(flight, rng=getattr(args, "seed", None))
    if getattr(args, "json", False):
        print(json.dumps(result.to_json_dict(), indent=2))
    else:
        print(result.summary(flight.true_coefficients))
    return 0 if result.success else 1


def methods(args: argparse.Namespace) -> int:
    """Run ``aeroid methods``: list every estimator and any plug-in that failed to load."""
    classes = available(refresh=True)
    width = max((len(n) for n in classes), default=0)
    for name in sorted(classes):
        cls = classes[name]
        print(f"{name:<{width}}  {cls.description or cls.__doc__ or ''}".rstrip())
    errors = load_errors()
    if errors:
        print("\nplug-ins that failed to load:")
        for name in sorted(errors):
            print(f"  {name}: {errors[name]}")
    return 0
