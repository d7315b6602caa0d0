"""Flight data: a time series of named channels, its airframe and metadata.

Channels (SI, radians; :mod:`aeroid.flights._channels`): ``t, ax1, ay1, az1, ax2, ay2,
az2, p, q, r, delta, u, v, w, alpha, beta, phi, theta, psi``, and the optional per-sample
inputs ``mass``, ``thrust``, ``ix``, ``iy``, ``iz`` and one atmosphere channel (``rho``,
``altitude`` or ``qbar``, named by the airframe's ``[atmosphere] per_sample``), which
every estimator uses (:func:`aeroid.flights.exogenous`); a channel the model does not
use is refused by :meth:`Flight.validate`, never ignored.

The airframe a flight carries is the *estimator's* view of it: its accelerometer
positions are the ones the estimator is given (with the paper's position error when
the flight was simulated with it); the true positions, when known, stay in
``metadata["true_accel_positions_m"]``.

Files (CSV or Parquet, with a JSON sidecar) are read by :mod:`aeroid.flights._files`
and written by :func:`write_flight` (:meth:`Flight.write`); what :meth:`Flight.validate`
checks is in :mod:`aeroid.flights._checks`.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from aeroid.errors import AeroidWarning, FlightError
from aeroid.flights._channels import (
    ACCELEROMETER_CHANNELS,
    ANGLE_CHANNELS,
    CHANNELS,
    OPTIONAL_CHANNELS,
    REQUIRED_CHANNELS,
    STATE_CHANNELS,
)
from aeroid.flights._checks import check_flight
from aeroid.flights._sidecar import sidecar_path, sidecar_payload
from aeroid.model import NAMES, Airframe


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
        JSON-serialisable. aeroid writes and checks ``noise`` (the noise model's
        settings), ``seed`` (int or None), ``true_coefficients`` (name -> value),
        ``true_accel_positions_m`` (2 x 3), ``manoeuvre`` (the simulated law and
        window) and ``source`` (the file read); other keys are kept as they are.
    notes : tuple of str
        What reading the file did, one line each (units converted, an angle unwrapped,
        columns dropped or not read): :func:`aeroid.flights.read_flight`. Not
        written with the flight.
    """

    data: pd.DataFrame
    airframe: Airframe
    metadata: dict[str, Any] = field(default_factory=dict)
    notes: tuple[str, ...] = field(default=(), kw_only=True)

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
        """Return the measured state ``[u, v, w, p, q, r, phi, theta, psi]``, (n, N_STATE)."""
        return self._columns(STATE_CHANNELS)

    def accelerations(self) -> np.ndarray:
        """Return both triads' readings, shape (n, 2, 3) [m/s^2]."""
        return self._columns(ACCELEROMETER_CHANNELS).reshape(-1, 2, 3)

    def _columns(self, names: tuple[str, ...]) -> np.ndarray:
        """Return a float copy of several channels, shape (n, len(names))."""
        missing = [c for c in names if c not in self.data.columns]
        if missing:
            raise FlightError(f"flight has no channel {missing[0]!r}")
        return np.array(self.data[list(names)].to_numpy(dtype=float), copy=True)

    @property
    def true_coefficients(self) -> np.ndarray | None:
        """The true coefficients (simulated flights), shape (N_COEFFICIENTS,), else None."""
        truth = self.metadata.get("true_coefficients")
        if truth is None:
            return None
        return np.array([truth[n] for n in NAMES], dtype=float)

    # Validation ------------------------------------------------------------------
    def check(self) -> tuple[list[str], list[str]]:
        """Return ``(problems, warnings)``: every finding, one line each.

        Problems make the flight unusable (missing or non-numeric channel, bad time
        base, too few samples, values outside physical ranges, units that contradict
        the kinematics, spikes, inputs the model does not use); warnings are
        data a person might mean but should look at. The thresholds and their
        reasons are the constants of :mod:`aeroid.flights._checks`.
        """
        return check_flight(self.data, self.airframe)

    def problems(self) -> list[str]:
        """Return every problem found, one line each (empty when the flight is valid)."""
        return self.check()[0]

    def validate(self) -> Flight:
        """Raise :class:`FlightError` listing every problem (``"; "``-joined) or return self.

        Each warning is issued as an :class:`~aeroid.errors.AeroidWarning` (one line,
        naming the flight's source).
        """
        problems, doubts = self.check()
        where = self.metadata.get("source", "flight")
        if problems:
            raise FlightError(f"{where}: " + "; ".join(problems))
        for doubt in doubts:
            warnings.warn(f"{where}: {doubt}", AeroidWarning, stacklevel=2)
        return self

    # Files -----------------------------------------------------------------------
    def write(self, path: str | Path) -> Path:
        """Write CSV (or Parquet for a ``.parquet`` path) plus the JSON sidecar.

        CSV values are written with 17 significant digits, so a round trip is lossless.
        Returns the sidecar path (:func:`aeroid.flights.write_flight`).
        """
        return write_flight(self, path)


def make_flight(data: Mapping[str, np.ndarray] | pd.DataFrame, airframe: Airframe,
                metadata: Mapping[str, Any] | None = None) -> Flight:
    """Build a :class:`Flight` from channel arrays; ``alpha``/``beta`` derived if absent.

    Channels are ordered as :data:`aeroid.flights.CHANNELS`, other columns after them.
    """
    frame = pd.DataFrame({k: np.asarray(v, dtype=float) for k, v in dict(data).items()})
    if all(c in frame for c in ("u", "v", "w")):
        alpha, beta = air_angles(*(frame[c].to_numpy(dtype=float) for c in ("u", "v", "w")))
        if "alpha" not in frame:
            frame["alpha"] = alpha
        if "beta" not in frame:
            frame["beta"] = beta
    ordered = [c for c in CHANNELS if c in frame]
    others = [c for c in frame.columns if c not in ordered]
    return Flight(frame[ordered + others], airframe, dict(metadata or {}))


def air_angles(u: np.ndarray, v: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return alpha = atan2(w, u) and beta = asin(v / V) [rad] (eqs. 14-16)."""
    with np.errstate(all="ignore"):
        return np.arctan2(w, u), np.arcsin(v / np.sqrt(u * u + v * v + w * w))


def write_flight(flight: Flight, path: str | Path) -> Path:
    """Write ``flight`` as CSV (Parquet for a ``.parquet`` path) plus its JSON sidecar.

    CSV values are written with 17 significant digits (a lossless round trip).

    Returns
    -------
    Path
        The sidecar written.

    Raises
    ------
    FlightError
        A ``.json`` data path (the sidecar's own name), or Parquet without pyarrow.
    """
    path = Path(path)
    sidecar = sidecar_path(path)
    if sidecar == path:
        raise FlightError(f"{path}: a flight's data cannot be .json (that is its sidecar's "
                          "name); use .csv or .parquet")
    if path.suffix == ".parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            raise FlightError(f"{path}: writing Parquet needs pyarrow "
                              "(pip install 'aeroid-toolkit[parquet]'); or write .csv") from None
        flight.data.to_parquet(path, index=False, engine="pyarrow")
    else:
        flight.data.to_csv(path, index=False, float_format="%.17g")
    sidecar.write_text(json.dumps(sidecar_payload(flight.airframe, flight.metadata), indent=2))
    return sidecar


__all__ = ["ANGLE_CHANNELS", "OPTIONAL_CHANNELS", "REQUIRED_CHANNELS", "STATE_CHANNELS",
           "Flight", "air_angles", "make_flight", "write_flight"]
