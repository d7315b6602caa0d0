"""The reconstruction's steady wind as a fit's wind (issues 22 and 26).

A flight made by :meth:`aeroid.reconstruction.Reconstruction.to_flight` from a suite log
with an ``air`` group carries the reconstruction's steady wind in its metadata
(``wind_ned_mps``, ``wind_stderr_mps``: :mod:`aeroid.reconstruction._wind`). The
regression methods (equation-error, EBM-PSO, SEBM-PSO; option ``air_data =
"reconstruction"``, or ``"auto"`` on a flight without logged air data) then evaluate
the model's loads with that wind (the model constants' wind per sample: the same path as
the logged angles' wind, :func:`aeroid.estimation.air_data_wind`).

Its uncertainty is not carried into their covariance: the fit says so in one line, with
the size it can have. A wind error ``dw`` along the path scales the dynamic pressure by
``2 dw / V``, so every coefficient by about that much; across the path it turns the
aerodynamic angles by ``dw / V`` rad.
"""

from __future__ import annotations

import numpy as np

from aeroid.errors import FlightError
from aeroid.flights import Flight

#: The metadata keys of the reconstruction's steady wind (NED [m/s]) and its sd.
WIND_KEY, WIND_SD_KEY = "wind_ned_mps", "wind_stderr_mps"


def reconstruction_wind(flight: Flight) -> tuple[np.ndarray, np.ndarray] | None:
    """The steady wind and its sd (NED [m/s], (3,) each) in the flight's metadata, or None.

    Raises
    ------
    FlightError
        A ``wind_ned_mps`` that is not three finite numbers, or its ``wind_stderr_mps``
        missing, not three or negative.
    """
    meta = flight.metadata
    if WIND_KEY not in meta:
        return None
    where = meta.get("source", "flight")
    try:
        wind = np.asarray(meta[WIND_KEY], dtype=float).reshape(-1)
        sd = np.asarray(meta[WIND_SD_KEY], dtype=float).reshape(-1)
    except (KeyError, TypeError, ValueError) as exc:
        raise FlightError(f"{where}: metadata {WIND_KEY} needs {WIND_SD_KEY} beside it "
                          f"(three numbers each, NED [m/s]): {exc}") from None
    if wind.size != 3 or sd.size != 3 or not (np.all(np.isfinite(wind))
                                              and np.all(np.isfinite(sd)) and np.all(sd >= 0)):
        raise FlightError(f"{where}: metadata {WIND_KEY} and {WIND_SD_KEY} must be three "
                          f"finite numbers each (sd >= 0), NED [m/s]; got {wind.tolist()} and "
                          f"{sd.tolist()}")
    return wind, sd


def reconstruction_note(flight: Flight, owner: str, wind: np.ndarray, sd: np.ndarray
                        ) -> tuple[np.ndarray, str, str]:
    """The per-sample wind (n, 3), the fit's one-line note and its warning (the wind's sd
    left out of the standard errors, with its size)."""
    speed = float(np.mean(np.sqrt(sum(flight[c] ** 2 for c in ("u", "v", "w")))))
    shown = ", ".join(f"{a} {w:+.2f} +- {s:.2f}" for a, w, s in zip("NED", wind, sd,
                                                                     strict=True))
    note = (f"{owner}: aerodynamic angles and airspeed from u, v, w less the reconstruction's "
            f"steady wind {shown} m/s (metadata {WIND_KEY}; the flight logs no air data)")
    warning = (f"{owner}: the reconstruction's steady wind is taken as exact: its sd of up to "
               f"{float(np.max(sd)):.2g} m/s moves every coefficient by up to about "
               f"{200.0 * float(np.max(sd)) / speed:.2g} % (along the path), which the "
               "standard errors leave out")
    return np.tile(wind, (flight.n_samples, 1)), note, warning


__all__ = ["WIND_KEY", "WIND_SD_KEY", "reconstruction_note", "reconstruction_wind"]
