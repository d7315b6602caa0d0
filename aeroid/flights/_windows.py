"""Several windows or flights of one airframe, fitted together: :class:`Windows`.

A coefficient is constant only over a short window; a fit of several windows (of one
log, :func:`cut_windows`, or of several logs) shares the coefficients and gives each
window its own start (initial state), atmosphere, inputs and, where the method
estimates them, IMU errors and fin delay (``Estimator.fit`` accepts a :class:`Windows`).

What the windows share is the airframe's: the coefficients' prior (the start and the
scale of every method), the accelerometer positions and their sd, the reference
diameter. Windows whose airframes differ in any of those are refused; mass, inertias,
thrust and atmosphere may differ from window to window.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from aeroid.errors import FlightError
from aeroid.flights._flight import Flight
from aeroid.model import Airframe

__all__ = ["SHARED_AIRFRAME_FIELDS", "Windows", "check_window_ranges", "cut_windows",
           "parse_window_spec"]

#: Airframe fields every window must agree on (the shared parameters' meaning and scale).
SHARED_AIRFRAME_FIELDS: tuple[str, ...] = (
    "diameter_m", "prior", "accel1_position_m", "accel2_position_m",
    "accel1_position_sd_m", "accel2_position_sd_m")

_NUMBER = r"(\d+(?:\.\d*)?(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?)"
_RANGE = re.compile(rf"^\s*{_NUMBER}\s*-\s*{_NUMBER}\s*$")


@dataclass(frozen=True)
class Windows:
    """Several flights (windows of one log, or several logs) fitted with shared coefficients.

    Attributes
    ----------
    flights : tuple of Flight
        One per window, each with its own time base, channels, airframe (see the module
        docstring for what must agree) and metadata.
    names : tuple of str
        One unique, non-empty name per window (results name the per-window parameters
        with them: ``"w1:p0"``).

    Raises
    ------
    FlightError
        No window, a name missing, empty or repeated, or airframes that disagree on a
        shared field (:data:`SHARED_AIRFRAME_FIELDS`).
    """

    flights: tuple[Flight, ...]
    names: tuple[str, ...]

    def __post_init__(self) -> None:
        flights, names = tuple(self.flights), tuple(str(n) for n in self.names)
        object.__setattr__(self, "flights", flights)
        object.__setattr__(self, "names", names)
        if not flights:
            raise FlightError("windows: no window given")
        if not all(isinstance(f, Flight) for f in flights):
            raise FlightError("windows: every window must be a Flight")
        if len(names) != len(flights):
            raise FlightError(f"windows: {len(names)} names for {len(flights)} windows")
        if not all(n.strip() for n in names):
            raise FlightError("windows: a window has an empty name")
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise FlightError(f"windows: name(s) {', '.join(repeated)} given twice")
        first = flights[0].airframe
        for name, flight in zip(names[1:], flights[1:], strict=True):
            for key in SHARED_AIRFRAME_FIELDS:
                if getattr(flight.airframe, key) != getattr(first, key):
                    raise FlightError(
                        f"windows: window {name!r} has another airframe {key} than "
                        f"{names[0]!r} ({getattr(flight.airframe, key)} against "
                        f"{getattr(first, key)}); the windows share it")

    @classmethod
    def of(cls, flights: Sequence[Flight], names: Sequence[str] | None = None) -> Windows:
        """Return the windows of ``flights``, named ``w1, w2, ...`` unless ``names`` given."""
        flights = tuple(flights)
        names = tuple(names) if names is not None else tuple(
            f"w{k + 1}" for k in range(len(flights)))
        return cls(flights, names)

    def __len__(self) -> int:
        """Number of windows."""
        return len(self.flights)

    def __iter__(self) -> Iterator[Flight]:
        """The windows' flights, in order."""
        return iter(self.flights)

    def items(self) -> Iterator[tuple[str, Flight]]:
        """``(name, flight)`` per window, in order."""
        return iter(zip(self.names, self.flights, strict=True))

    @property
    def airframe(self) -> Airframe:
        """The first window's airframe (every shared field agrees with it)."""
        return self.flights[0].airframe

    @property
    def n_samples(self) -> int:
        """Samples over all windows."""
        return sum(f.n_samples for f in self.flights)

    @property
    def metadata(self) -> dict:
        """Metadata of the set: ``source`` naming the windows, ``windows`` their names."""
        sources = [str(f.metadata.get("source", n)) for n, f in self.items()]
        return {"source": "windows " + ", ".join(sources), "windows": list(self.names)}

    @property
    def true_coefficients(self) -> np.ndarray | None:
        """The first window's true coefficients (simulated flights), else None."""
        return self.flights[0].true_coefficients

    def bounds(self) -> list[tuple[int, int]]:
        """``(start, stop)`` of each window's rows in the stacked samples."""
        stops = np.cumsum([f.n_samples for f in self.flights])
        return [(int(b - f.n_samples), int(b)) for b, f in zip(stops, self.flights,
                                                               strict=True)]

    def joined(self) -> Flight:
        """One flight of the windows one after the other (for checks of stacked residuals).

        The channels all windows have, in order; each window's time moved to follow the
        previous window's last sample by its own first interval, so the time base
        increases. Not a flight to integrate across: the state jumps at each join.
        """
        common = [c for c in self.flights[0].channels
                  if all(c in f.channels for f in self.flights[1:])]
        parts, end = [], None
        for flight in self.flights:
            frame = flight.data[common].copy()
            t = flight.t
            if end is not None:
                step = float(t[1] - t[0]) if t.size > 1 else 1.0
                frame["t"] = t - t[0] + end + step
            parts.append(frame)
            end = float(frame["t"].iloc[-1])
        metadata = self.metadata
        metadata["window_bounds"] = self.bounds()
        return Flight(pd.concat(parts, ignore_index=True), self.airframe, metadata)


def parse_window_spec(spec: str) -> list[tuple[float, float]]:
    """Return the time ranges of ``"5-6,8-9"`` (seconds), in the order given.

    Raises
    ------
    FlightError
        A malformed range, an empty spec, or a range whose end is not after its start.
    """
    if not str(spec).strip():
        raise FlightError("--windows: no time range given (expected START-END[,START-END...] "
                          "in seconds, e.g. 5-6,8-9)")
    ranges = []
    for part in str(spec).split(","):
        match = _RANGE.match(part)
        if match is None:
            raise FlightError(f"--windows {spec!r}: {part.strip()!r} is not START-END in "
                              "seconds (e.g. 5-6,8-9)")
        start, stop = float(match.group(1)), float(match.group(2))
        if not stop > start:
            raise FlightError(f"--windows {spec!r}: range {part.strip()!r} ends before it "
                              "starts")
        ranges.append((start, stop))
    return ranges


def check_window_ranges(spec: str | Sequence[tuple[float, float]], first: float,
                        last: float, where: str) -> list[tuple[float, float]]:
    """Return the ranges of ``spec`` after checking them against a log from ``first`` to
    ``last`` [s]: each ends after it starts, lies inside the log, and none overlap.

    Raises
    ------
    FlightError
        One line naming ``where`` and the range.
    """
    ranges = parse_window_spec(spec) if isinstance(spec, str) else [
        (float(a), float(b)) for a, b in spec]
    text = [f"{a:g}-{b:g}" for a, b in ranges]
    for (start, stop), label in zip(ranges, text, strict=True):
        if not stop > start:
            raise FlightError(f"{where}: window {label} ends before it starts")
        if start < first or stop > last:
            raise FlightError(f"{where}: window {label} s lies outside the log "
                              f"({first:g}-{last:g} s)")
    order = sorted(range(len(ranges)), key=lambda k: ranges[k][0])
    for a, b in zip(order, order[1:], strict=False):
        if ranges[b][0] <= ranges[a][1]:
            raise FlightError(f"{where}: windows {text[a]} and {text[b]} s overlap (they "
                              "would share samples); give ranges that do not")
    return ranges


def cut_windows(flight: Flight, spec: str | Sequence[tuple[float, float]]) -> Windows:
    """Cut windows out of one log by time ranges on its clock [s] (``"5-6,8-9"``).

    Each window holds the samples with ``start <= t <= stop``, its metadata the log's with
    ``source`` naming the range (``"log.csv [5-6 s]"``) and ``window_s`` the range; its
    name is the range (``"5-6"``).

    Raises
    ------
    FlightError
        A malformed spec (:func:`parse_window_spec`), a range outside the log, ranges that
        overlap (share a sample), or a range with fewer than two samples.
    """
    where = flight.metadata.get("source", "flight")
    t = flight.t
    ranges = check_window_ranges(spec, float(t[0]), float(t[-1]), where)
    text = [f"{a:g}-{b:g}" for a, b in ranges]
    flights = []
    for (start, stop), label in zip(ranges, text, strict=True):
        rows = np.flatnonzero((t >= start) & (t <= stop))
        if rows.size < 2:
            raise FlightError(f"{where}: window {label} s holds {rows.size} sample(s)")
        metadata = dict(flight.metadata)
        metadata["source"] = f"{where} [{label} s]"
        metadata["window_s"] = [start, stop]
        if flight.metadata.get("saturated"):  # sample indices: the window's own
            metadata["saturated"] = {
                c: [int(k) - int(rows[0]) for k in ks if rows[0] <= int(k) <= rows[-1]]
                for c, ks in dict(flight.metadata["saturated"]).items()}
            metadata["saturated"] = {c: ks for c, ks in metadata["saturated"].items() if ks}
        flights.append(Flight(flight.data.iloc[rows].reset_index(drop=True),
                              flight.airframe, metadata, notes=flight.notes))
    return Windows(tuple(flights), tuple(text))
