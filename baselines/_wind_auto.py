"""``estimate_wind = "auto"`` (the default of output-error, the EKF and the UKF; issue 26).

The steady wind is estimated unless the log says still air (:func:`aeroid.estimation.
log_air`: its metadata declares still air, the simulators' flights among them, or its
air data see all three components and call them still); where the method cannot
estimate a wind in that combination (coefficient tables, GNSS aiding, several windows
for the filters, ...), still air is assumed there instead of refusing a fit that works
without it. The choice is said in one line, with why: in the result's warnings when the
log does not say still air (the wind estimated, or still air assumed), else on the
logger ``aeroid`` (INFO); and in ``info["estimate_wind"]`` (``option``, ``used``,
``reason``, ``log_air``). ``true`` and ``false`` are taken as given.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from aeroid.estimation import EstimationResult, LogAir, log_air
from aeroid.flights import Flight, Windows

#: The ``estimate_wind`` choice resolved on the log.
AUTO = "auto"


def check_wind_option(est: Any) -> None:
    """Raise ValueError (one line) for an ``estimate_wind`` other than true, false, auto."""
    value = est.estimate_wind
    if not (isinstance(value, bool) or value == AUTO):
        raise ValueError(f"estimate_wind must be true, false or auto, got {value!r}")


def is_auto(est: Any) -> bool:
    """Whether ``est``'s ``estimate_wind`` is ``"auto"`` (to be resolved on the log)."""
    value = getattr(est, "estimate_wind", False)
    return isinstance(value, str) and value == AUTO


@dataclass(frozen=True)
class WindChoice:
    """``estimate_wind = auto`` resolved on a log: ``used`` (estimate the wind), the line
    that says so and why, and what the log said."""

    used: bool
    line: str
    air: LogAir

    def as_info(self) -> dict[str, object]:
        """As ``info["estimate_wind"]``."""
        return {"option": AUTO, "used": self.used, "reason": self.line,
                "log_air": self.air.as_info()}


def choose(owner: str, data: Flight | Windows, blocked: str) -> WindChoice:
    """Resolve ``auto`` on ``data``: off where the log says still air; else on, unless
    ``blocked`` (why the method cannot estimate a wind here, "" when it can)."""
    air = log_air(data, owner)
    if air.still:
        return WindChoice(False, f"{owner}: estimate_wind: off (auto): {air.reason}; pass "
                          "estimate_wind=true to estimate a steady wind", air)
    if blocked:
        return WindChoice(False, f"{owner}: estimate_wind: off (auto): {air.reason}, but "
                          f"{blocked}: still air assumed; pass estimate_wind=false to say so",
                          air)
    return WindChoice(True, f"{owner}: estimate_wind: on (auto): {air.reason}; pass "
                      "estimate_wind=false to assume still air", air)


def run_auto(est: Any, data: Flight | Windows, blocked: str,
             run: Callable[[Any], EstimationResult]) -> EstimationResult:
    """Run ``run`` on ``est`` with ``estimate_wind`` resolved on ``data`` (:func:`choose`),
    the choice in the result (module docstring)."""
    choice = choose(est.name, data, blocked)
    result = run(dataclasses.replace(est, estimate_wind=choice.used))
    said: tuple[str, ...] = ()
    if choice.air.still:
        logging.getLogger("aeroid").info(choice.line)
    else:
        said = (choice.line,)
    return dataclasses.replace(result, info={**result.info, "estimate_wind": choice.as_info()},
                               warnings=(*said, *result.warnings))


__all__ = ["AUTO", "WindChoice", "check_wind_option", "choose", "is_auto", "run_auto"]
