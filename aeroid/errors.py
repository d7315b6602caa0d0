"""The error types that mean "bad input" (the CLI prints them in one line, exit 2)."""

from __future__ import annotations

from aeroid.airframe import AirframeError
from aeroid.flight import FlightError


class UsageError(ValueError):
    """Bad command-line input (exit status 2)."""


class StudyError(ValueError):
    """A study file is malformed or names an unknown estimator or option."""


def _user_errors() -> tuple[type[BaseException], ...]:
    from aeroid.estimators.base import EstimatorError

    return (AirframeError, FlightError, EstimatorError, StudyError, UsageError,
            FileNotFoundError, IsADirectoryError, PermissionError)


USER_ERRORS: tuple[type[BaseException], ...] = _user_errors()
