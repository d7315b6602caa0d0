"""A motor's thrust curve on its own clock, used only inside the burn window the user states.

A rocket motor's thrust curve (a test stand's or the maker's, e.g. RASP ``.eng`` data) is
a table of thrust [N] against time [s] on the curve's own clock, whose zero is not the
flight log's. :class:`ThrustCurve` holds the curve, the log-clock time of the curve's
zero (``origin_s``: ignition on the log's clock) and the **burn window** ``burn_s`` on
the log's clock: the thrust is the curve's (linear between its points, zero beyond
them) inside the window and zero outside it, whatever the curve says there. The vehicle's
mass along the burn is an optional column (``mass_kg`` at the curve's times); without
it a fit of samples inside the burn is refused (:func:`aeroid.flights.with_thrust_curve`):
thrust without the mass it burns would change the physics quietly.

The file form (a CSV, or the ``[thrust_curve]`` table of an airframe or scenario file)::

    time_s,thrust_N,mass_kg          # mass_kg optional: the vehicle's mass [kg]
    0.0,0.0,14.0
    0.1,400.0,13.9
    ...

    [thrust_curve]
    file = "motor.csv"               # or time_s = [...], thrust_N = [...], mass_kg = [...]
    origin_s = 1.20                  # the log-clock time of the curve's t = 0
    burn_s = [1.20, 4.70]            # log clock: where the motor burns (both ends in)

Every bad value is a one-line :class:`aeroid.errors.AirframeError` naming the file (or
table) and the column, row or key.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aeroid.errors import AirframeError
from aeroid.model._curve_csv import read_curve_csv
from aeroid.model._fileform import check_keys, check_table, number, numbers, text

#: Columns of a thrust curve file (matched without case and surrounding blanks); the
#: last is optional.
CURVE_COLUMNS = ("time_s", "thrust_n", "mass_kg")
#: Keys of the ``[thrust_curve]`` table.
TABLE_KEYS = ("file", "time_s", "thrust_N", "mass_kg", "origin_s", "burn_s")
#: Largest thrust [N] accepted: a launch vehicle's first stage (Saturn V: 35 MN) with
#: margin; beyond it the column is in another unit (mN?).
MAX_THRUST_N = 1e8


def _column(values: Any, name: str, where: str) -> np.ndarray:
    array = np.asarray(values, dtype=object).reshape(-1)
    out = np.empty(array.size)
    for i, v in enumerate(array):
        try:
            out[i] = float(v)
        except (TypeError, ValueError):
            out[i] = math.nan
        if isinstance(v, bool) or not math.isfinite(out[i]):
            raise AirframeError(f"{where}: {name} value {i + 1} is not a finite number ({v!r})")
    return out


@dataclass(frozen=True, eq=False)
class ThrustCurve:
    """A thrust curve on its own clock with the log-clock burn window (module docstring).

    Attributes
    ----------
    time_s : ndarray, shape (m,)
        The curve's times on its own clock [s], strictly increasing, m >= 2.
    thrust_n : ndarray, shape (m,)
        Thrust along body +x [N], >= 0.
    origin_s : float
        The log-clock time of the curve's t = 0 [s].
    burn_s : tuple of 2 float
        The burn window on the log's clock [s], start < end; it overlaps the curve.
    mass_kg : ndarray, shape (m,), or None
        The vehicle's mass at the curve's times [kg], > 0; None: not given.
    source : str
        Where it came from (file or table), for messages.
    """

    time_s: np.ndarray
    thrust_n: np.ndarray
    origin_s: float
    burn_s: tuple[float, float]
    mass_kg: np.ndarray | None = None
    source: str = "thrust curve"

    def __post_init__(self) -> None:
        where = self.source
        time = _column(self.time_s, "time_s", where)
        thrust = _column(self.thrust_n, "thrust_N", where)
        if time.size < 2 or thrust.size != time.size:
            raise AirframeError(f"{where}: a thrust curve needs >= 2 points and as many thrust "
                                f"values as times (got {time.size} times, {thrust.size} "
                                "thrusts)")
        if np.any(np.diff(time) <= 0):
            k = int(np.flatnonzero(np.diff(time) <= 0)[0])
            raise AirframeError(f"{where}: time_s must increase strictly (value {k + 2}: "
                                f"{time[k + 1]:g} after {time[k]:g})")
        if np.any(thrust < 0) or np.any(thrust > MAX_THRUST_N):
            k = int(np.flatnonzero((thrust < 0) | (thrust > MAX_THRUST_N))[0])
            raise AirframeError(f"{where}: thrust_N value {k + 1} is {thrust[k]:g}: thrust "
                                f"acts along body +x, 0..{MAX_THRUST_N:g} N")
        object.__setattr__(self, "time_s", time)
        object.__setattr__(self, "thrust_n", thrust)
        if self.mass_kg is not None:
            mass = _column(self.mass_kg, "mass_kg", where)
            if mass.size != time.size or np.any(mass <= 0):
                raise AirframeError(f"{where}: mass_kg needs one positive value per time "
                                    f"(got {mass.size} values for {time.size} times)")
            object.__setattr__(self, "mass_kg", mass)
        origin = number(self.origin_s, f"{where}: origin_s")
        burn = numbers(self.burn_s, 2, f"{where}: burn_s")
        if not burn[0] < burn[1]:
            raise AirframeError(f"{where}: burn_s must be [start, end] with start < end [s, "
                                f"log clock], got {list(burn)}")
        span = (origin + time[0], origin + time[-1])
        if burn[1] <= span[0] or burn[0] >= span[1]:
            raise AirframeError(f"{where}: the burn window {burn[0]:g}..{burn[1]:g} s (log "
                                f"clock) is outside the curve, {span[0]:g}..{span[1]:g} s "
                                f"on the log clock (its {time[0]:g}..{time[-1]:g} s + "
                                f"origin_s {origin:g} s)")
        object.__setattr__(self, "origin_s", origin)
        object.__setattr__(self, "burn_s", burn)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, ThrustCurve) and self.to_table() == other.to_table()

    def __hash__(self) -> int:
        return hash(repr(self.to_table()))

    # Values on the log's clock ----------------------------------------------------
    def burning(self, t: np.ndarray) -> np.ndarray:
        """Return whether each log-clock time [s] is inside the burn window (ends included)."""
        t = np.asarray(t, dtype=float)
        return (t >= self.burn_s[0]) & (t <= self.burn_s[1])

    def thrust(self, t: np.ndarray) -> np.ndarray:
        """Return the thrust [N] at log-clock times ``t`` [s]: the curve inside the burn, else 0."""
        t = np.asarray(t, dtype=float)
        curve = np.interp(t - self.origin_s, self.time_s, self.thrust_n, left=0.0, right=0.0)
        return np.where(self.burning(t), curve, 0.0)

    def mass(self, t: np.ndarray) -> np.ndarray:
        """Return the mass [kg] at log-clock times ``t`` [s] (the burn's ends' beyond it).

        Raises
        ------
        AirframeError
            When the curve has no mass.
        """
        if self.mass_kg is None:
            raise AirframeError(f"{self.source}: no mass_kg along the burn")
        inside = np.clip(np.asarray(t, dtype=float), *self.burn_s) - self.origin_s
        return np.interp(inside, self.time_s, self.mass_kg)

    def impulse(self, start: float = -math.inf, end: float = math.inf) -> float:
        """Return the curve's total impulse [N s] between log-clock ``start`` and ``end``.

        The exact integral of the piecewise-linear curve (zero beyond its points), burn
        window NOT applied: ``impulse(*burn_s)`` is the share the burn window uses.
        """
        lo = max(start - self.origin_s, self.time_s[0])
        hi = min(end - self.origin_s, self.time_s[-1])
        if hi <= lo:
            return 0.0
        inner = (self.time_s > lo) & (self.time_s < hi)
        t = np.concatenate([[lo], self.time_s[inner], [hi]])
        f = np.interp(t, self.time_s, self.thrust_n)
        return float(np.sum(np.diff(t) * (f[1:] + f[:-1]) / 2.0))

    def describe(self) -> str:
        """Return one line: the curve, its origin, the burn window, the impulse used and not."""
        total, used = self.impulse(), self.impulse(*self.burn_s)
        ends = None if self.mass_kg is None else self.mass(np.array(self.burn_s))
        mass = ("no mass along the burn (a fit of samples inside the burn is refused)"
                if ends is None else f"mass {ends[0]:.6g} -> {ends[1]:.6g} kg along the burn "
                "(the curve's mass_kg)")
        return (f"{self.source}: thrust curve of {self.time_s.size} points, its t = 0 at "
                f"{self.origin_s:g} s on the log clock; used inside the burn window "
                f"{self.burn_s[0]:g}..{self.burn_s[1]:g} s only (zero outside): impulse "
                f"{used:.6g} of the curve's {total:.6g} N s; {mass}")

    # File forms -------------------------------------------------------------------
    def to_table(self) -> dict[str, Any]:
        """Return the ``[thrust_curve]`` table with the points inline (:meth:`from_table`)."""
        table: dict[str, Any] = {"time_s": self.time_s.tolist(),
                                 "thrust_N": self.thrust_n.tolist(),
                                 "origin_s": self.origin_s, "burn_s": list(self.burn_s)}
        if self.mass_kg is not None:
            table["mass_kg"] = self.mass_kg.tolist()
        return table

    @classmethod
    def from_table(cls, table: Mapping[str, Any], where: str = "[thrust_curve]",
                   base: str | Path | None = None) -> ThrustCurve:
        """Read a ``[thrust_curve]`` table: ``file`` (a CSV, relative to ``base``) or inline
        ``time_s``, ``thrust_N`` (and ``mass_kg``), with ``origin_s`` and ``burn_s``."""
        table = check_table(table, where)
        check_keys(table, TABLE_KEYS, where, required=("origin_s", "burn_s"))
        inline = [k for k in ("time_s", "thrust_N", "mass_kg") if k in table]
        if ("file" in table) == bool(inline):
            raise AirframeError(f"{where}: give either file = \"curve.csv\" or the points "
                                "inline (time_s, thrust_N, optional mass_kg), not "
                                f"{'both' if inline else 'neither'}")
        origin = number(table["origin_s"], f"{where} origin_s")
        start, end = numbers(table["burn_s"], 2, f"{where} burn_s")
        burn = (start, end)
        if "file" in table:
            path = Path(text(table["file"], f"{where} file"))
            if base is not None and not path.is_absolute():
                path = Path(base) / path
            return read_thrust_curve(path, origin_s=origin, burn_s=burn)
        if "time_s" not in table or "thrust_N" not in table:
            raise AirframeError(f"{where}: inline points need both time_s and thrust_N")
        return cls(time_s=table["time_s"], thrust_n=table["thrust_N"], origin_s=origin,
                   burn_s=burn, mass_kg=table.get("mass_kg"), source=where)


def read_thrust_curve(path: str | Path, *, origin_s: float, burn_s: Any) -> ThrustCurve:
    """Read a CSV with columns ``time_s``, ``thrust_N`` and optional ``mass_kg``.

    Parameters
    ----------
    path : str or Path
        The CSV file; any other column is refused (not silently ignored).
    origin_s : float
        The log-clock time of the curve's t = 0 [s].
    burn_s : pair of float
        The burn window on the log's clock [s].

    Raises
    ------
    AirframeError
        One line naming the file and what is wrong.
    """
    values = read_curve_csv(path, required=CURVE_COLUMNS[:2], optional=CURVE_COLUMNS[2:],
                            kind="thrust curve", row_word="line", error=AirframeError,
                            columns_text="the columns time_s, thrust_N and optionally mass_kg")
    where = str(path)
    return ThrustCurve(time_s=values["time_s"], thrust_n=values["thrust_n"], origin_s=origin_s,
                       burn_s=burn_s, mass_kg=values.get("mass_kg"), source=where)


__all__ = ["ThrustCurve", "read_thrust_curve"]
