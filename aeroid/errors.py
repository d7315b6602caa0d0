"""The user-facing error types (the ground floor: this module imports nothing of aeroid).

Every error that means "bad input" derives from :class:`AeroidError`; the command line
prints it as one line (what and where) and exits with status 2.
"""

from __future__ import annotations


class AeroidError(ValueError):
    """Bad input to aeroid: the message is one line saying what and where."""


class AirframeError(AeroidError):
    """An airframe or scenario file or value is invalid."""


class FlightError(AeroidError):
    """Flight data are missing, unreadable or invalid."""


class EstimatorError(AeroidError):
    """Unknown estimator, unknown or invalid option, or a registry conflict."""


class StudyError(AeroidError):
    """A study file is malformed or names an unknown estimator or option."""


class UsageError(AeroidError):
    """Bad command-line input."""


class AeroidWarning(UserWarning):
    """Input that is accepted but probably not what the user meant (one line: what, where)."""


#: What the command line reports in one line with exit status 2.
USER_ERRORS: tuple[type[BaseException], ...] = (
    AeroidError, FileNotFoundError, IsADirectoryError, PermissionError)
