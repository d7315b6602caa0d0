"""The air a flight's metadata declares: still air, or a wind (issue 26).

``metadata["wind"]`` says what air the flight was flown in:

- ``"still"``: still air (a user's sidecar may say so);
- a table in the scenario's ``[wind]`` form (:data:`aeroid.flights.WIND_KEYS`:
  ``north_mps``, ``east_mps``, ``down_mps``, ``turbulence_sd_mps``, ``scale_length_m``;
  missing keys 0, the scale length MIL-F-8785C's): the simulator writes the one it flew,
  all zeros in still air (:func:`wind_metadata`). A table whose steady components and
  turbulence are all zero is still air; any other is a wind.

No ``"wind"`` key: the log declares nothing (a real log, a flight made from arrays), and
nothing is assumed about its air here (:func:`aeroid.estimation.log_air` decides what the
estimators do). The key is ``"wind"`` and not ``"air"``: ``metadata["air"]`` is the
simulated atmosphere's temperature (the scenario's ``[air]`` table).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from aeroid.errors import AirframeError, FlightError
from aeroid.flights._turbulence import WIND_KEYS, Wind, wind_from_table

#: The metadata key that declares the air.
DECLARED_WIND_KEY = "wind"
#: Its value for still air.
STILL = "still"


def declared_wind(metadata: Mapping[str, Any], where: str = "flight") -> Wind | None:
    """Return the wind ``metadata`` declares (a zero :class:`Wind` for still air), or None
    when it declares nothing.

    Raises
    ------
    FlightError
        One line naming ``where``: a ``wind`` that is neither ``"still"`` nor a
        ``[wind]`` table of numbers with known keys.
    """
    value = metadata.get(DECLARED_WIND_KEY)
    if value is None:
        return None
    if isinstance(value, str):
        if value.strip().lower() == STILL:
            return Wind()
        raise FlightError(f"{where}: metadata wind must be \"still\" or a table of "
                          f"{', '.join(WIND_KEYS)}, got {value!r}")
    if not isinstance(value, Mapping):
        raise FlightError(f"{where}: metadata wind must be \"still\" or a table of "
                          f"{', '.join(WIND_KEYS)}, got {value!r}")
    try:
        return wind_from_table(dict(value), f"{where}: metadata wind")
    except AirframeError as exc:
        raise FlightError(str(exc)) from None


def is_still(wind: Wind) -> bool:
    """Whether ``wind`` is still air: no steady component, no turbulence."""
    return not wind.turbulent and not any(wind.steady_ned_mps)


def describe_wind(wind: Wind) -> str:
    """``wind`` in words: ``still air`` or ``a steady wind N +3, E +4, D +0 m/s`` (with its
    turbulence)."""
    if is_still(wind):
        return "still air"
    steady = ", ".join(f"{a} {w:+.3g}" for a, w in zip("NED", wind.steady_ned_mps,
                                                        strict=True))
    gusts = (f" with Dryden turbulence of sd {wind.turbulence_sd_mps:g} m/s"
             if wind.turbulent else "")
    return f"a steady wind {steady} m/s{gusts}"


def wind_metadata(wind: Wind | None) -> dict[str, dict[str, float]]:
    """The ``metadata["wind"]`` a simulator writes for the air it flew (``None``: still
    air, written as the zero table)."""
    return {DECLARED_WIND_KEY: (wind or Wind()).describe()}


__all__ = ["DECLARED_WIND_KEY", "STILL", "declared_wind", "describe_wind", "is_still",
           "wind_metadata"]
