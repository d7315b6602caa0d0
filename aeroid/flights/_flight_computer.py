"""What a flight computer's log says differently (issue 25): a board's temperature, GNSS.

A flight computer's barometer logs its own (the board's) temperature, not the outside
air's; its GNSS may give positions without velocities. The suite log says so:
``[groups.baro] temperature = "board"`` (the channel is the board's: the reconstruction
does not take it for the air's density) or ``"air"`` (the default: it is the outside air's
and ``rho = p / (R T)`` uses it; the reconstruction's note says which). A GNSS group logs
all six NED channels or the three positions only (:data:`GNSS_CHANNELS`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from aeroid.errors import AirframeError, FlightError

#: What a baro group's ``temperature`` channel measures (``[groups.baro] temperature``).
TEMPERATURE_SOURCES = ("air", "board")
#: Keys only the ``baro`` group takes.
BARO_KEYS = ("temperature",)
#: What a simulated barometer may log: a pressure altitude, or the static pressure with or
#: without a temperature (the air's: ISA of the true altitude; or the board's).
BARO_CHANNELS: tuple[tuple[str, ...], ...] = (("altitude",), ("pressure",),
                                              ("pressure", "temperature"))
#: The channels a simulated GNSS logs: velocity and position, or position only.
GNSS_CHANNELS: tuple[tuple[str, ...], ...] = (("vn", "ve", "vd", "pn", "pe", "pd"),
                                              ("pn", "pe", "pd"))


def read_temperature_source(table: Mapping[str, Any], channels: Mapping[str, Any],
                            where: str) -> str:
    """Return what the baro group's temperature measures, ``"air"`` (default) or ``"board"``.

    Raises
    ------
    FlightError
        One line naming ``where``: a value that is not one of :data:`TEMPERATURE_SOURCES`,
        or a declaration without a temperature column.
    """
    if "temperature" not in table:
        return "air"
    value = table["temperature"]
    if value not in TEMPERATURE_SOURCES:
        raise FlightError(f"{where}: temperature must be \"air\" (the outside air's) or "
                          f"\"board\" (the flight computer's own), got {value!r}")
    if "temperature" not in channels:
        raise FlightError(f"{where}: temperature = {value!r} but the group has no "
                          "temperature column")
    return str(value)


def check_flight_computer(gnss_channels: tuple[str, ...], baro_channels: tuple[str, ...],
                          board_temperature_k: float | None) -> None:
    """Check a simulated suite's GNSS channels and board temperature.

    Raises
    ------
    AirframeError
        One line: GNSS channels not in :data:`GNSS_CHANNELS`, or a board temperature
        with a barometer that logs no temperature (it would be ignored).
    """
    if tuple(gnss_channels) not in GNSS_CHANNELS:
        raise AirframeError(f"sensor suite: gnss_channels must be one of {GNSS_CHANNELS}, "
                            f"got {gnss_channels}")
    if board_temperature_k is not None and "temperature" not in baro_channels:
        raise AirframeError(f"sensor suite: baro_board_temperature_k needs a temperature "
                            f"channel (baro_channels = (\"pressure\", \"temperature\")), got "
                            f"{baro_channels}")
