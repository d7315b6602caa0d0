"""Logged air-data angles (a vane's or probe's ``alpha`` and ``beta``): used or refused.

The model's loads see the air-relative velocity, the inertial ``u, v, w`` minus the wind
(:func:`aeroid.model.equations.air_velocity`). A flight whose logged ``alpha`` and
``beta`` differ from the inertial ``atan(w/u)``, ``asin(v/V)`` was flown in moving air (or
its vane is miscalibrated). A method that regresses the loads on the measured states
(equation-error) can use the logged angles directly: :func:`air_data_wind` returns the
per-sample wind (north-east-down) that makes the model's air-relative angles equal the
logged ones, so the loads are still evaluated by the one model (no second writing of
eqs. 2-7). The airspeed is the log's ``airspeed`` channel (an air-data probe's) or,
without one, the inertial speed ``|u, v, w|``: then a wind *along* the path changes the
dynamic pressure by ``2 w / V`` (5 m/s at 540 m/s: 1.9 %), which the angles cannot see
(a crosswind changes it only to second order), and the fit says so in one line.

A vane's noise enters the regressors (errors in variables): 0.1 deg at 500 m/s is 0.9 m/s
of implied wind per sample, and the loads' noise it makes is several times the IMU's.
The wind is slow in north-east-down axes (steady, or Dryden gusts with a time constant
``L / V`` ~ 1 s) while the angles turn with the roll (~50 rad/s), so the implied wind is
smoothed there (Savitzky-Golay, order :data:`WIND_POLYORDER`, over the option
``air_data_window_s``), never the angles themselves. Measured on the reference flight
(Gaussian IMU, vane noise 0.1 deg, 4 seeds, mean |error| of the nine coefficients; still
air 1.3 %): steady 5 m/s wind 6.5 % unsmoothed, 3.0 % over 0.1 s, 2.4 % over 0.2 s;
with Dryden turbulence of sd 3 m/s 6.8 %, 6.0 % and 8.2 % (a long window smooths the
gusts away). ``window_s = None`` (equation-error's, EBM-PSO's, SEBM-PSO's default) smooths it
with a Kalman smoother whose gust intensity the data choose
(:mod:`aeroid.estimation._air_smoother`): equation-error's default, measured in
``benchmarks/bench_air_data.py`` (steady wind: the whole record's weighted mean; 0.1
deg vanes with an airspeed channel: 0.90-0.96x the still-air error against 2.2-2.6x
with the 0.1 s window).

Every other method takes the angles from ``u, v, w`` and says so
(:func:`ignored_air_data_warning`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from aeroid.errors import FlightError
from aeroid.estimation._air_reconstruction import (
    WIND_KEY,
    reconstruction_note,
    reconstruction_wind,
)
from aeroid.estimation._air_smoother import SmoothedWind, dryden_note, smooth_air_wind
from aeroid.estimation._signals import smooth
from aeroid.flights import PITOT_KEY, Flight, air_data_probe_position
from aeroid.model import equations

__all__ = ["AIR_DATA_CHOICES", "ANGLE_TOLERANCE_RAD", "WIND_WINDOW_S", "AirData", "air_data_wind",
           "check_air_options",
           "has_air_angles", "has_air_data", "has_airspeed", "ignored_air_data_warning",
           "resolve_air_data"]

#: The option ``air_data``: ``auto`` uses the logged angles when the flight has them
#: (:func:`has_air_data`), else the reconstruction's steady wind when the flight carries
#: one, ``inertial`` takes the angles from ``u, v, w``, ``measured`` uses the logged ones
#: or refuses a flight without them, ``reconstruction`` uses the reconstruction's steady
#: wind (:mod:`aeroid.estimation._air_reconstruction`) or refuses a flight without it.
AIR_DATA_CHOICES: tuple[str, ...] = ("auto", "inertial", "measured", "reconstruction")
#: Logged angles within this of the inertial ones everywhere are the inertial ones: a
#: reader derives them when the log has none, and a log written with 6 significant digits
#: (or as float32) makes them differ by up to ~1e-6 rad; 1e-5 rad is 1/170 of a 0.1 deg
#: vane's noise and a wind of 5 mm/s at 500 m/s.
ANGLE_TOLERANCE_RAD = 1e-5
#: Savitzky-Golay order of the implied wind's smoothing (module docstring).
WIND_POLYORDER = 3
#: Default smoothing of the implied wind [s] (module docstring: measured).
WIND_WINDOW_S = 0.1


@dataclass(frozen=True)
class AirData:
    """The aerodynamic angles a fit uses: ``source`` ``"measured"`` or ``"inertial"``,
    ``wind`` (n, 3) [m/s] NED per sample with the measured ones (else None), ``note``:
    one line saying what was done and why; ``warning``: with the measured ones, the bias
    the airspeed assumption leaves out of the standard errors (else None)."""

    source: str
    wind: np.ndarray | None
    note: str
    warning: str | None = None
    smoothed: SmoothedWind | None = None  # the Kalman smoother's answer, when it ran


def _inertial_angles(flight: Flight) -> tuple[np.ndarray, np.ndarray]:
    u, v, w = (flight[c] for c in ("u", "v", "w"))
    _, alpha, beta = equations.air_data(u, v, w)
    return alpha, beta


def has_airspeed(flight: Flight) -> bool:
    """Return True when the flight logs an air-data probe's ``airspeed`` [m/s]."""
    return "airspeed" in flight.channels


def has_air_data(flight: Flight) -> bool:
    """Return True when the flight logs an ``airspeed``, or ``alpha`` and ``beta`` that
    differ from the inertial angles by more than :data:`ANGLE_TOLERANCE_RAD` somewhere."""
    if has_airspeed(flight):
        return True
    return has_air_angles(flight)


def has_air_angles(flight: Flight) -> bool:
    """Return True when the flight logs ``alpha`` and ``beta`` that differ from the
    inertial angles by more than :data:`ANGLE_TOLERANCE_RAD` somewhere."""
    if not {"alpha", "beta", "u", "v", "w"} <= set(flight.channels):
        return False
    alpha, beta = _inertial_angles(flight)
    off = max(float(np.max(np.abs(flight["alpha"] - alpha))),
              float(np.max(np.abs(flight["beta"] - beta))))
    return off > ANGLE_TOLERANCE_RAD


def wind_window(flight: Flight, window_s: float) -> int:
    """Return the odd smoothing window [samples] of ``window_s`` on ``flight`` (1: none),
    at most the record's length."""
    n = flight.n_samples
    window = 2 * int(round(0.5 * window_s / flight.dt)) + 1
    window = min(window, n if n % 2 else n - 1)
    return window if window > WIND_POLYORDER + 1 else 1


def check_air_options(est: Any) -> None:
    """Raise ValueError (one line) on a bad ``air_data`` or ``air_data_window_s`` of a
    method that smooths the air data's wind (equation-error's kin: the PSO methods)."""
    if est.air_data not in AIR_DATA_CHOICES:
        raise ValueError(f"air_data must be one of {', '.join(AIR_DATA_CHOICES)}, "
                         f"got {est.air_data!r}")
    if est.air_data_window_s is not None and not (
            np.isfinite(est.air_data_window_s) and est.air_data_window_s >= 0):
        raise ValueError(f"air_data_window_s must be >= 0 [s] or None (the Kalman smoother), "
                         f"got {est.air_data_window_s}")


def air_data_wind(flight: Flight, window_s: float = 0.0) -> np.ndarray:
    """Return the wind (n, 3) [m/s], north-east-down, that makes the model's air-relative
    angles equal the logged ``alpha`` and ``beta`` (module docstring).

    The air-relative velocity in body axes is ``V (cos a cos b, sin b, sin a cos b)`` with
    ``V`` the logged ``airspeed`` (an air-data probe's) or, without one, ``|u, v, w|``;
    the wind is the inertial velocity minus it, rotated to NED by the
    transpose of the model's :func:`aeroid.model.equations.ned_to_body`; smoothed over
    ``window_s`` [s] in NED axes (:func:`wind_window`; 0: not smoothed). A probe off the
    c.g. (:func:`aeroid.flights.air_data_probe_position`, the flight's metadata) reads the
    rotation's ``omega x r`` too (``omega`` the logged p, q, r): it is removed first.
    """
    u, v, w, phi, theta, psi = (flight[c] for c in ("u", "v", "w", "phi", "theta", "psi"))
    speed = flight["airspeed"] if has_airspeed(flight) else np.sqrt(u * u + v * v + w * w)
    alpha, beta = flight["alpha"], flight["beta"]
    air = speed[:, None] * np.stack([np.cos(alpha) * np.cos(beta), np.sin(beta),
                                     np.sin(alpha) * np.cos(beta)], axis=1)
    r, _ = air_data_probe_position(flight)
    if np.any(r):  # the probe's air velocity less the rotation's at the probe
        air = air - np.cross(np.stack([flight[c] for c in ("p", "q", "r")], axis=1), r)
    body = np.stack([u, v, w], axis=1) - air
    # columns of the direction-cosine matrix: the NED unit vectors in body axes
    dcm = np.stack([np.stack(equations.ned_to_body(phi, theta, psi, *e), axis=1)
                    for e in np.eye(3)], axis=2)  # (n, body, ned)
    wind = np.einsum("nbk,nb->nk", dcm, body)
    window = wind_window(flight, window_s)
    return wind if window == 1 else smooth(wind, window, WIND_POLYORDER, axis=0)


def resolve_air_data(flight: Flight, choice: str, owner: str,
                     window_s: float | None = WIND_WINDOW_S,
                     smoother: str = "random-walk") -> AirData:
    """Return the angles a fit of ``owner`` uses on ``flight`` for the option ``choice``
    (the implied wind smoothed over ``window_s`` [s]; None: by the Kalman smoother whose
    gust intensity is fitted, :mod:`aeroid.estimation._air_smoother`, its wind model
    ``smoother``: ``"random-walk"`` or ``"dryden"``).

    Raises
    ------
    FlightError
        ``measured`` on a flight without logged ``alpha`` and ``beta`` (or whose logged
        angles are the inertial ones: nothing to use).
    """
    if choice not in AIR_DATA_CHOICES:
        raise FlightError(f"{owner}: air_data must be one of {', '.join(AIR_DATA_CHOICES)}, "
                          f"got {choice!r}")
    logged = has_air_data(flight)
    steady = reconstruction_wind(flight) if choice in ("auto", "reconstruction") else None
    if choice == "reconstruction" or (choice == "auto" and not logged and steady is not None):
        if steady is None:
            raise FlightError(f"{owner}: air_data = 'reconstruction' but "
                              f"{flight.metadata.get('source', 'flight')} carries no "
                              "reconstruction's steady wind (metadata wind_ned_mps: "
                              "reconstruct a suite log with an air group)")
        return AirData("reconstruction", *reconstruction_note(flight, owner, *steady))
    if choice == "inertial" or (choice == "auto" and not logged):
        why = ("air_data = 'inertial'" if choice == "inertial"
               else "the flight logs no alpha, beta apart from the inertial ones")
        return AirData("inertial", None, f"{owner}: aerodynamic angles from u, v, w ({why})")
    if not logged:
        where = flight.metadata.get("source", "flight")
        raise FlightError(f"{owner}: air_data = 'measured' but {where} has no airspeed "
                          "channel and no logged alpha and beta apart from the inertial "
                          "atan(w/u), asin(v/V)")
    alpha, beta = _inertial_angles(flight)
    rms = np.degrees(np.sqrt(np.mean(np.concatenate([flight["alpha"] - alpha,
                                                     flight["beta"] - beta]) ** 2)))
    if window_s is not None and not (np.isfinite(window_s) and window_s >= 0):
        raise FlightError(f"{owner}: air_data_window_s must be >= 0 [s], got {window_s!r}")
    if window_s is not None and smoother != "random-walk":
        raise FlightError(f"{owner}: the {smoother} smoother is the Kalman smoother's; "
                          f"air_data_window_s = {window_s:g} s smooths with a fixed window")
    kalman = None
    if window_s is None:
        kalman = smooth_air_wind(flight, air_data_wind(flight), model=smoother)
        wind = kalman.wind
        smoothed = dryden_note(kalman) if kalman.model == "dryden" else (
                    "the wind they imply Kalman-smoothed in NED axes (a random walk of "
                    f"intensity {kalman.intensity:.3g} (m/s)^2/s by maximum likelihood, "
                    f"0: steady; probe noise {_body_sd(kalman)} m/s along body x, y, z)")
    else:
        wind = air_data_wind(flight, window_s)
        window = wind_window(flight, window_s)
        smoothed = (f"the wind they imply smoothed over {window} samples in NED axes"
                    if window > 1 else "not smoothed")
    speed = float(np.mean(np.sqrt(sum(flight[c] ** 2 for c in ("u", "v", "w")))))
    probe = air_data_probe_position(flight)[1]
    angles = (f"the logged alpha, beta ({rms:.3g} deg RMS from the inertial ones"
              if has_air_angles(flight) else "alpha, beta from u, v, w (none logged apart "
              "from them")
    if has_airspeed(flight):
        off = float(np.sqrt(np.mean((flight["airspeed"] - np.sqrt(
            sum(flight[c] ** 2 for c in ("u", "v", "w")))) ** 2)))
        origin = ("the probe's pressures (Mach, by the pitot formulas)" if PITOT_KEY
                  in flight.metadata else "the logged airspeed channel")
        return AirData("measured", wind,
                       f"{owner}: aerodynamic angles from {angles}; {smoothed}; {probe}), "
                       f"airspeed from {origin} ({off:.3g} m/s RMS from |u, v, w|)",
                       smoothed=kalman)
    warning = (f"{owner}: airspeed taken as |u, v, w| (no airspeed channel): a wind along "
               f"the path of 1 m/s biases every coefficient by about {200.0 / speed:.2g} %, "
               "which the logged angles cannot see and the standard errors leave out")
    return AirData("measured", wind,
                   f"{owner}: aerodynamic angles from {angles}; {smoothed}; {probe}), "
                   "airspeed |u, v, w| (no airspeed channel)", warning, kalman)


def _body_sd(kalman: SmoothedWind) -> str:
    return ", ".join(f"{v:.2g}" for v in kalman.noise_sd_body)


def ignored_air_data_warning(flight: Flight, owner: str) -> str | None:
    """Return the one-line warning of a method that ignores logged angles (or the
    reconstruction's steady wind the flight carries), or None."""
    if not has_air_data(flight):
        if WIND_KEY not in flight.metadata:
            return None
        return (f"{owner}: takes the aerodynamic angles from u, v, w (still air) and ignores "
                f"the reconstruction's steady wind the flight carries (metadata {WIND_KEY}); "
                "equation-error and the PSO methods use it (option air_data), output-error "
                "estimates its own (estimate_wind)")
    logged = " and ".join(
        (["logged alpha, beta (they differ: wind, or a vane's calibration)"]
         if has_air_angles(flight) else []) + (["airspeed"] if has_airspeed(flight) else []))
    return (f"{owner}: takes the aerodynamic angles from u, v, w and ignores the flight's "
            f"{logged}; equation-error and the PSO methods use them (option air_data), "
            "output-error, the EKF, the UKF and filter-error as measured outputs (option "
            "air_data = measured)")
