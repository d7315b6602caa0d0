"""The true air temperature of a simulated flight: the scenario's ``[air]`` (optional).

The model has no position equations, so the simulator's air is the airframe's
``[atmosphere]`` throughout; ``[air]`` makes its TEMPERATURE differ from the ISA's, so
that Mach (``V / sqrt(gamma R T)``, :func:`aeroid.model.speed_of_sound_at`) differs from
the ISA Mach a fit would assume::

    [air]
    delta_T_K = 20.0                 # ISA + 20 K at [atmosphere] altitude_m (a hot day)
    # temperature_K = [[0.0, 268.0], [20.5, 258.0]]   # or rows [time_s, K]: linear
    #                                                  # between them, held beyond
    log_temperature = true           # write the air_temperature channel [K] (default false)

Only the speed of sound of the true coefficient tables (``[coefficients]`` rows in Mach)
changes: the density stays the airframe's ``[atmosphere]`` (ISA at its altitude, or its
given density), and the simulator says so in the flight's metadata (``air``). With
constant coefficients nothing in the truth depends on the temperature; the column is still
written when asked. ``log_temperature`` writes the true temperature (no sensor noise).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from aeroid.errors import AirframeError
from aeroid.model import MachTables, check_air_temperature, fileform, isa_temperature

#: Keys of ``[air]``.
AIR_KEYS = ("delta_T_K", "temperature_K", "log_temperature")
#: What the simulator says of the density under a non-ISA temperature (metadata).
DENSITY_NOTE = ("the air temperature sets the speed of sound of the true Mach tables only; "
                "the density is the airframe's [atmosphere]")


@dataclass(frozen=True)
class Air:
    """The true air temperature: an offset from the ISA's, or a profile in time.

    Attributes
    ----------
    delta_t_k : float
        Offset [K] from the ISA temperature at the airframe's ``altitude_m``.
    profile : tuple of (time_s, temperature_K) pairs
        The temperature against time from t = 0 (empty: the offset applies).
    log_temperature : bool
        Whether the simulated flight has the ``air_temperature`` channel.
    """

    delta_t_k: float = 0.0
    profile: tuple[tuple[float, float], ...] = ()
    log_temperature: bool = False

    def temperature(self, t: np.ndarray, altitude_m: float | None) -> np.ndarray:
        """Return the air temperature [K] at times ``t`` [s], shape of ``t``.

        Raises
        ------
        AirframeError
            An offset without an ISA altitude, or a temperature outside
            :data:`aeroid.model.AIR_TEMPERATURE_RANGE_K`.
        """
        t = np.asarray(t, dtype=float)
        if self.profile:
            times, values = np.array(self.profile).T
            return np.interp(t, times, values)
        if altitude_m is None:
            raise AirframeError("[air] delta_T_K is an offset from the ISA temperature: the "
                                "airframe's [atmosphere] needs altitude_m")
        value = float(isa_temperature(altitude_m)) + self.delta_t_k
        try:
            check_air_temperature(value, f"[air] ISA {value - self.delta_t_k:g} K + delta_T_K")
        except ValueError as exc:
            raise AirframeError(str(exc)) from None
        return np.full(t.shape, value)

    def describe(self) -> dict[str, Any]:
        """Return the ``[air]`` table with the density note (a flight's metadata)."""
        out: dict[str, Any] = ({"temperature_K": [list(r) for r in self.profile]}
                               if self.profile else {"delta_T_K": self.delta_t_k})
        return {**out, "log_temperature": self.log_temperature, "density": DENSITY_NOTE}


def flown_tables(tables: MachTables | None, air: Air | None, altitude_m: float | None
                 ) -> tuple[MachTables | None, Callable[[Any], np.ndarray | None]]:
    """Return the true tables the simulator flies and the air temperature as a function of
    time [s] -> [K]: with ``air``, Mach from that temperature at every RK4 stage
    (``per_sample_temperature``); without, the tables as given and no temperature."""
    if air is None or tables is None:
        return tables, lambda _t: None
    return (dataclasses.replace(tables, per_sample_temperature=True),
            lambda t: air.temperature(t, altitude_m))


def air_from_table(table: Any, where: str) -> Air:
    """Read ``[air]`` (module docstring); one-line :class:`AirframeError` naming ``where``."""
    table = fileform.check_table(table, where)
    fileform.check_keys(table, AIR_KEYS, where)
    if ("delta_T_K" in table) == ("temperature_K" in table):
        raise AirframeError(f"{where}: give exactly one of delta_T_K (an offset from the "
                            "ISA) and temperature_K (rows [time_s, K])")
    log = table.get("log_temperature", False)
    if not isinstance(log, bool):
        raise AirframeError(f"{where} log_temperature must be true or false, got {log!r}")
    if "delta_T_K" in table:
        return Air(delta_t_k=fileform.number(table["delta_T_K"], f"{where} delta_T_K"),
                   log_temperature=log)
    rows = table["temperature_K"]
    if not isinstance(rows, list) or not rows:
        raise AirframeError(f"{where} temperature_K must be rows [[time_s, K], ...], "
                            f"got {rows!r}")
    profile = tuple(tuple(fileform.numbers(row, 2, f"{where} temperature_K (rows "
                                                    "[time_s, K])")) for row in rows)
    times = [row[0] for row in profile]
    if any(b <= a for a, b in zip(times, times[1:], strict=False)):
        raise AirframeError(f"{where} temperature_K: the times must increase, got {times}")
    try:
        check_air_temperature([row[1] for row in profile], f"{where} temperature_K")
    except ValueError as exc:
        raise AirframeError(str(exc)) from None
    return Air(profile=profile, log_temperature=log)  # type: ignore[arg-type]


__all__ = ["AIR_KEYS", "Air", "DENSITY_NOTE", "air_from_table", "flown_tables"]
