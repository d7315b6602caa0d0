"""Aiding sources of output-error and the EKF/UKF: their names and samples (private).

What :mod:`baselines._oe_aiding` puts in the likelihood, read and checked here: each
source's channels in ``metadata["aiding"][source]``, its label and unit, and
:func:`aiding_samples` (the samples on the flight's grid, refused in one line otherwise).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import NamedTuple

import numpy as np

import aeroid
from aeroid.flights import Flight

#: The option's values (output-error's and the EKF's and UKF's).
AIDING = ("none", "gnss-velocity", "gnss-velocity+ins-attitude")
#: Output-error's: also the GNSS position (:mod:`baselines._oe_position`).
OE_AIDING = AIDING + ("gnss-position", "gnss-velocity+gnss-position",
                      "gnss-velocity+gnss-position+ins-attitude", "baro-altitude",
                      "gnss-position+baro-altitude", "gnss-velocity+gnss-position+baro-altitude")
#: Each aiding source: the option's word, the key in ``metadata["aiding"]``.
SOURCES = {"gnss-velocity": "gnss", "gnss-position": "gnss_position", "ins-attitude": "ins",
           "baro-altitude": "baro"}
#: Each source's channels in ``metadata["aiding"][source]``, the names of its residuals
#: (the INS's prefixed: ``phi`` is also a flight channel), what it is, its unit.
CHANNELS = {"gnss": ("vn", "ve", "vd"), "gnss_position": ("pn", "pe", "pd"),
            "ins": ("phi", "theta", "psi"), "baro": ("altitude",)}
RESIDUAL_NAMES = {"gnss": ("vn", "ve", "vd"), "gnss_position": ("pn", "pe", "pd"),
                  "ins": ("ins_phi", "ins_theta", "ins_psi"), "baro": ("baro_altitude",)}
LABELS = {"gnss": "GNSS velocity", "gnss_position": "GNSS position", "ins": "INS attitude",
          "baro": "barometric altitude"}
UNITS = {"gnss": "m/s", "gnss_position": "m", "ins": "rad", "baro": "m"}
#: The GNSS aiding outputs (NED velocity [m/s]), after the IMU's.
AIDING_CHANNELS = CHANNELS["gnss"]
#: An aiding time within this fraction of the sample interval of a flight sample is on it
#: (times logged in ms or us round to 1e-9 s or better).
GRID_RTOL = 1e-6


class AidingSamples(NamedTuple):
    """One aiding source's samples on the flight's grid."""

    index: np.ndarray   # (n_a,) flight sample of each
    z: np.ndarray       # (n_a, 3) vn ve vd [m/s] or phi theta psi [rad]
    sd: np.ndarray      # (3,) stated white-noise sd [m/s] or [rad]
    source: str = "gnss"  # a key of CHANNELS


def aiding_sources(aiding: str) -> tuple[str, ...]:
    """The sources of an option value: ``"gnss-velocity+ins-attitude"`` -> gnss, ins."""
    return () if aiding == "none" else tuple(SOURCES[w] for w in aiding.split("+"))


def aiding_samples(flight: Flight, source: str = "gnss") -> AidingSamples:
    """The flight's samples of ``source`` (``metadata["aiding"][source]``), checked."""
    where = flight.metadata.get("source", "flight")
    channels, label, unit = CHANNELS[source], LABELS[source], UNITS[source]
    word = next(w for w, s in SOURCES.items() if s == source)
    aiding = flight.metadata.get("aiding")
    group = aiding.get(source) if isinstance(aiding, Mapping) else None
    if not isinstance(group, Mapping):
        raise aeroid.FlightError(
            f"{where}: aiding = {word} needs the {label} samples in "
            f"metadata['aiding']['{source}'] (t, {', '.join(channels)}, sd; "
            + ("Reconstruction.to_flight does not pass them yet: put them there"
               if source in ("gnss_position", "baro") else
               "Reconstruction.to_flight(imu='raw', aiding=True) passes them")
            + "); the flight has none")
    try:
        t = np.asarray(group["t"], dtype=float).reshape(-1)
        z = np.column_stack([np.asarray(group[c], dtype=float).reshape(-1) for c in channels])
        sd = np.array([float(group["sd"][c]) for c in channels])
    except (KeyError, TypeError, ValueError) as exc:
        raise aeroid.FlightError(f"{where}: metadata aiding.{source} needs t, "
                                 f"{', '.join(channels)} (numbers, one per sample) and sd of "
                                 f"each: {exc}") from None
    if z.shape[0] != t.size or t.size == 0 or not (np.all(np.isfinite(z))
                                                   and np.all(np.isfinite(t))):
        raise aeroid.FlightError(f"{where}: metadata aiding.{source}: {t.size} times for "
                                 f"{z.shape[0]} samples, or a value not finite")
    if not np.all(sd > 0):
        raise aeroid.FlightError(f"{where}: metadata aiding.{source} sd must be positive "
                                 f"[{unit}], got {dict(zip(channels, sd.tolist(), strict=True))}")
    dt, ft = flight.dt, flight.t
    k = np.clip(np.rint((t - ft[0]) / dt).astype(int), 0, ft.size - 1)
    off = t - ft[k]
    bad = np.flatnonzero(np.abs(off) > GRID_RTOL * dt)
    if bad.size:
        j = int(bad[0])
        raise aeroid.FlightError(
            f"{where}: {label.split()[0]} sample at t = {t[j]:.9g} s is {1e3 * off[j]:+.6g} ms "
            f"from the flight's nearest sample ({1e3 * dt:.6g} ms grid): an aiding sample is "
            "predicted at a flight sample (nothing resampled); log it on the IMU's clock or "
            "leave it out")
    if np.unique(k).size != k.size:
        raise aeroid.FlightError(f"{where}: two {label.split()[0]} samples on one flight sample")
    return AidingSamples(k, z, sd, source)


def source_columns(samples: tuple[AidingSamples, ...]) -> list[slice]:
    """Each source's columns among the aiding outputs (its channels: 3, the barometer 1)."""
    stops = np.cumsum([s.sd.size for s in samples])
    return [slice(int(b - s.sd.size), int(b)) for s, b in zip(samples, stops, strict=True)]
