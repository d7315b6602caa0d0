"""Flight data: a time series of named channels, its airframe and metadata.

Channels (SI, radians): ``t, ax1, ay1, az1, ax2, ay2, az2, p, q, r, delta, u, v, w,
alpha, beta, phi, theta, psi``; optional per-sample ``mass`` [kg] and ``thrust`` [N].

The airframe a flight carries is the *estimator's* view of it: its accelerometer
positions are the ones the estimator is given (with the paper's position error when
the flight was simulated with it); the true positions, when known, stay in
``metadata["true_accel_positions_m"]``.

Files: CSV (or Parquet when pyarrow is installed, by the ``.parquet`` suffix) with a
JSON sidecar ``<name>.json`` holding the airframe and the metadata. A user's own log
has no sidecar: :func:`read_flight` takes the airframe, a column-name mapping and the
angle unit instead.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from aeroid.errors import AirframeError, FlightError
from aeroid.model._airframe import Airframe
from aeroid.model._coefficients import NAMES

STATE_CHANNELS: tuple[str, ...] = ("u", "v", "w", "p", "q", "r", "phi", "theta", "psi")
REQUIRED_CHANNELS: tuple[str, ...] = (
    "t", "ax1", "ay1", "az1", "ax2", "ay2", "az2", "p", "q", "r", "delta",
    "u", "v", "w", "alpha", "beta", "phi", "theta", "psi",
)
OPTIONAL_CHANNELS: tuple[str, ...] = ("mass", "thrust")
#: Channels converted by ``angles_in_degrees`` (rates in deg/s).
ANGLE_CHANNELS: tuple[str, ...] = ("p", "q", "r", "delta", "alpha", "beta", "phi", "theta", "psi")
FORMAT = "aeroid-flight/1"
MAX_ALPHA_DEG = 60.0
#: Relative spread of the sample interval accepted as a uniform time base.
TIME_UNIFORMITY_RTOL = 1e-6



def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    return value


@dataclass(frozen=True, eq=False)
class Flight:
    """Recorded (or simulated) flight data.

    Attributes
    ----------
    data : pandas.DataFrame
        One column per channel, one row per sample, time in column ``t`` [s].
    airframe : Airframe
        The estimator's view of the airframe (sensor positions as given to estimators).
    metadata : dict
        Free-form, JSON-serialisable: ``noise``, ``seed``, ``true_coefficients``
        (name -> value), ``true_accel_positions_m``, ``source``.
    """

    data: pd.DataFrame
    airframe: Airframe
    metadata: dict[str, Any] = field(default_factory=dict)

    # Access ----------------------------------------------------------------------
    def __getitem__(self, name: str) -> np.ndarray:
        """Return a copy of channel ``name`` as a float array."""
        if name not in self.data.columns:
            raise FlightError(f"flight has no channel {name!r}")
        return np.array(self.data[name].to_numpy(dtype=float), copy=True)

    @property
    def channels(self) -> tuple[str, ...]:
        """The channel names present."""
        return tuple(str(c) for c in self.data.columns)

    @property
    def t(self) -> np.ndarray:
        """Time [s], shape (n,)."""
        return self["t"]

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return len(self.data)

    @property
    def dt(self) -> float:
        """Mean sample interval [s]."""
        t = self.t
        return float((t[-1] - t[0]) / (len(t) - 1))

    def states(self) -> np.ndarray:
        """Return the measured state ``[u, v, w, p, q, r, phi, theta, psi]``, shape (n, 9)."""
        return self._columns(STATE_CHANNELS)

    def accelerations(self) -> np.ndarray:
        """Return both triads' readings, shape (n, 2, 3) [m/s^2]."""
        return self._columns(("ax1", "ay1", "az1", "ax2", "ay2", "az2")).reshape(-1, 2, 3)

    def _columns(self, names: tuple[str, ...]) -> np.ndarray:
        """Return a float copy of several channels, shape (n, len(names))."""
        missing = [c for c in names if c not in self.data.columns]
        if missing:
            raise FlightError(f"flight has no channel {missing[0]!r}")
        return np.array(self.data[list(names)].to_numpy(dtype=float), copy=True)

    @property
    def true_coefficients(self) -> np.ndarray | None:
        """The true coefficients (simulated flights), shape (9,), else None."""
        truth = self.metadata.get("true_coefficients")
        if truth is None:
            return None
        return np.array([truth[n] for n in NAMES], dtype=float)

    # Validation ------------------------------------------------------------------
    def problems(self) -> list[str]:
        """Return every problem found, one line each (empty when the flight is valid)."""
        found: list[str] = []
        missing = [c for c in REQUIRED_CHANNELS if c not in self.data.columns]
        if missing:
            found.append(f"missing required column(s): {', '.join(missing)}")
        present = [c for c in (*REQUIRED_CHANNELS, *OPTIONAL_CHANNELS) if c in self.data]
        if all(pd.api.types.is_numeric_dtype(self.data[c]) for c in present):
            finite = np.isfinite(self.data[present].to_numpy(dtype=float))  # one pass
        else:
            finite = np.column_stack([
                np.isfinite(pd.to_numeric(self.data[c], errors="coerce").to_numpy(dtype=float))
                for c in present]) if present else np.ones((len(self.data), 0), bool)
        for j, name in enumerate(present):
            bad = np.flatnonzero(~finite[:, j])
            if bad.size:
                found.append(
                    f"column {name!r} has {bad.size} NaN/inf or non-numeric value(s), "
                    f"first at row {bad[0]}"
                )
        if len(self.data) < 3:
            found.append(f"too few samples ({len(self.data)}; need at least 3)")
            return found
        if "t" in self.data and not any(p.startswith("column 't'") for p in found):
            t = self.data["t"].to_numpy(dtype=float)
            steps = np.diff(t)
            nonpos = np.flatnonzero(steps <= 0)
            if nonpos.size:
                found.append(f"time is not increasing at row {nonpos[0] + 1}")
            else:
                dt = float(np.median(steps))
                off = np.flatnonzero(np.abs(steps - dt) > TIME_UNIFORMITY_RTOL * dt + 1e-12)
                if off.size:
                    found.append(
                        f"time base is not uniform: step {steps[off[0]]:.6g} s at row "
                        f"{off[0] + 1} (median {dt:.6g} s)"
                    )
        if all(c in self.data for c in ("u", "v", "w")):
            uvw = self.data[["u", "v", "w"]].to_numpy(dtype=float)
            speed = np.sqrt((uvw**2).sum(axis=1))
            low = np.flatnonzero(~(speed > 0) & np.isfinite(speed))
            if low.size:
                found.append(f"implausible airspeed V <= 0 at row {low[0]}")
        if "alpha" in self.data:
            alpha = np.abs(self.data["alpha"].to_numpy(dtype=float))
            high = np.flatnonzero(alpha > math.radians(MAX_ALPHA_DEG))
            if high.size:
                found.append(
                    f"implausible |alpha| > {MAX_ALPHA_DEG:g} deg at row {high[0]} "
                    f"({math.degrees(alpha[high[0]]):.1f} deg; angles in degrees? use --degrees)"
                )
        return found

    def validate(self) -> Flight:
        """Raise :class:`FlightError` listing every problem (``"; "``-joined) or return self."""
        found = self.problems()
        if found:
            where = self.metadata.get("source", "flight")
            raise FlightError(f"{where}: " + "; ".join(found))
        return self

    # Files -----------------------------------------------------------------------
    def write(self, path: str | Path) -> Path:
        """Write CSV (or Parquet for a ``.parquet`` path) plus the JSON sidecar.

        CSV values are written with 17 significant digits, so a round trip is lossless.
        Returns the sidecar path.
        """
        path = Path(path)
        if path.suffix == ".parquet":
            self.data.to_parquet(path, index=False)
        else:
            self.data.to_csv(path, index=False, float_format="%.17g")
        sidecar = sidecar_path(path)
        meta = {k: v for k, v in self.metadata.items() if k != "source"}
        payload = {"format": FORMAT, "airframe": self.airframe.to_dict(),
                   "metadata": _jsonable(meta)}
        sidecar.write_text(json.dumps(payload, indent=2))
        return sidecar


def sidecar_path(path: str | Path) -> Path:
    """Return the JSON sidecar path of a flight file (``f.csv`` -> ``f.json``)."""
    return Path(path).with_suffix(".json")


def make_flight(data: Mapping[str, np.ndarray] | pd.DataFrame, airframe: Airframe,
                metadata: Mapping[str, Any] | None = None) -> Flight:
    """Build a :class:`Flight` from channel arrays; ``alpha``/``beta`` derived if absent."""
    frame = pd.DataFrame({k: np.asarray(v, dtype=float) for k, v in dict(data).items()})
    if all(c in frame for c in ("u", "v", "w")):
        u, v, w = (frame[c].to_numpy(dtype=float) for c in ("u", "v", "w"))
        with np.errstate(all="ignore"):
            if "alpha" not in frame:
                frame["alpha"] = np.arctan2(w, u)
            if "beta" not in frame:
                frame["beta"] = np.arcsin(v / np.sqrt(u * u + v * v + w * w))
    ordered = [c for c in (*REQUIRED_CHANNELS, *OPTIONAL_CHANNELS) if c in frame]
    others = [c for c in frame.columns if c not in ordered]
    return Flight(frame[ordered + others], airframe, dict(metadata or {}))


def read_flight(
    path: str | Path,
    *,
    airframe: Airframe | None = None,
    columns: Mapping[str, str] | None = None,
    angles_in_degrees: bool = False,
) -> Flight:
    """Read a flight file (CSV or Parquet) and its sidecar when present.

    Parameters
    ----------
    path : path
        The data file.
    airframe : Airframe, optional
        Overrides the sidecar's airframe; required when there is no sidecar.
    columns : mapping, optional
        ``{name in the file: aeroid channel name}`` for a user's own log.
    angles_in_degrees : bool
        The file's angles are in degrees and its rates in deg/s
        (channels :data:`ANGLE_CHANNELS`); they are converted to radians.

    Raises
    ------
    FlightError
        One line naming the file and what is wrong. The data are not validated here:
        call :meth:`Flight.validate`.
    """
    path = Path(path)
    try:
        frame = pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
    except FileNotFoundError:
        raise FlightError(f"{path}: no such file") from None
    except ImportError:
        raise FlightError(f"{path}: reading Parquet needs pyarrow (pip install pyarrow)") from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, OSError,
            ValueError) as exc:  # ValueError: pyarrow.ArrowInvalid on a corrupt Parquet file
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise FlightError(f"{path}: cannot read flight data ({first})") from None
    if columns:
        unknown = sorted(set(columns.values()) - set(REQUIRED_CHANNELS) - set(OPTIONAL_CHANNELS))
        if unknown:
            raise FlightError(f"{path}: column map names unknown channel(s) {unknown}")
        absent = sorted(set(columns) - set(frame.columns))
        if absent:
            raise FlightError(f"{path}: column map names column(s) not in the file: {absent}")
        frame = frame.rename(columns=dict(columns))
    if angles_in_degrees:
        for name in ANGLE_CHANNELS:
            if name in frame:
                frame[name] = np.radians(pd.to_numeric(frame[name], errors="coerce"))
    metadata: dict[str, Any] = {}
    sidecar = sidecar_path(path)
    if sidecar.exists() and sidecar != path:
        try:
            payload = json.loads(sidecar.read_text())
            sidecar_airframe = Airframe.from_dict(payload["airframe"], source=str(sidecar))
            metadata = dict(payload.get("metadata", {}))
        except (json.JSONDecodeError, KeyError, TypeError) as exc:
            raise FlightError(f"{sidecar}: malformed flight sidecar ({exc})") from None
        except AirframeError as exc:
            raise FlightError(str(exc)) from None
        airframe = airframe or sidecar_airframe
    if airframe is None:
        raise FlightError(f"{path}: no airframe (no sidecar {sidecar.name}; give --airframe FILE)")
    metadata["source"] = str(path)
    numeric = {}
    for c in frame.columns:
        numeric[str(c)] = pd.to_numeric(frame[c], errors="coerce").to_numpy(dtype=float)
    return make_flight(numeric, airframe, metadata)
