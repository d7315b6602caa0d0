"""The air group's samples in the reconstruction's flight (``to_flight(air=...)``, issue 26).

A suite log's ``air`` group (a probe's ``alpha``, ``beta``, ``airspeed`` or its
``total_pressure`` and ``static_pressure``) samples at its own clock; the flight of
:meth:`~aeroid.reconstruction.Reconstruction.to_flight` is at the IMU's. Where the air
group has a sample at every IMU instant (a probe on the IMU's clock) its channels are
carried as logged, so equation-error's and output-error's air-data paths read them as a
single-file log's (the pressures turned into the airspeed by ``Estimator.fit``, as there).
At a lower rate each channel can be **linearly interpolated** (:func:`numpy.interp`) to
the IMU's instants (``air = "interpolate"``), but the interpolated samples are not
independent: one air sample's noise spans ``imu_rate / air_rate`` IMU samples, the fits
measure less noise than the probe's and their fit checks refuse correct fits (measured:
benchmarks/bench_suite_wind.py). So by default (``"auto"``) such samples are not carried,
only the steady wind the reconstruction estimated from them, and the note says why. An
IMU instant outside the air group's times is refused (nothing extrapolated).
The probe's position, where the group states one, becomes the flight's
``metadata["air_data_probe"] = {"position_m": [x, y, z]}`` (a single-file flight's key).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from aeroid.errors import FlightError
from aeroid.flights import SuiteLog

__all__ = ["AIR_CHOICES", "AIR_LOG", "flight_air", "logged_air"]

#: ``to_flight``'s ``air``: the samples where they are on the IMU's clock, else the steady
#: wind only (``auto``); the samples or a refusal (``samples``); the samples linearly
#: interpolated (``interpolate``); the steady wind only (``wind``).
AIR_CHOICES = ("auto", "samples", "interpolate", "wind")
#: The reconstruction's metadata key holding the log's air samples until ``to_flight``.
AIR_LOG = "air_log"
#: The flight's metadata key of the probe's position (output-error's and the filters').
PROBE_KEY = "air_data_probe"
#: Times within this fraction of the IMU interval are the same instant (times in ms).
SAME_RTOL = 1e-6


def logged_air(log: SuiteLog) -> dict[str, Any]:
    """The log's air samples for :func:`flight_air` (empty without an air group)."""
    if "air" not in log:
        return {}
    group = log["air"]
    return {AIR_LOG: {"t": np.asarray(group.t, float).copy(), "source": group.source,
                      "channels": {c: np.asarray(v, float).copy()
                                   for c, v in group.channels.items()},
                      "position_m": group.probe_position_m}}


def flight_air(metadata: dict[str, Any], channels: dict[str, np.ndarray], air: str,
               notes: list[str]) -> dict[str, Any]:
    """``metadata`` without the log's air samples; with them (``air``, :data:`AIR_CHOICES`)
    their channels added to ``channels`` at the IMU's times ``channels["t"]`` (module
    docstring) and one note."""
    meta = {k: v for k, v in metadata.items() if k != AIR_LOG}
    logged = metadata.get(AIR_LOG)
    where = metadata.get("source", "suite log")
    if air not in AIR_CHOICES:
        raise FlightError(f"{where}: air must be one of {', '.join(map(repr, AIR_CHOICES))}, "
                          f"got {air!r}")
    if logged is None:
        if air in ("samples", "interpolate"):
            raise FlightError(f"{where}: air={air!r} needs an air group in the log; it has none")
        return meta
    names, source = ", ".join(logged["channels"]), logged["source"]
    t, ta = channels["t"], logged["t"]
    tol = SAME_RTOL * float(t[1] - t[0])
    k = np.clip(np.searchsorted(ta, t), 0, ta.size - 1)
    near = np.minimum(np.abs(ta[k] - t), np.abs(ta[np.maximum(k - 1, 0)] - t))
    same = bool(np.all(near <= tol))
    used = int(np.count_nonzero((ta >= t[0] - tol) & (ta <= t[-1] + tol)))
    if air == "wind" or (air == "auto" and not same):
        why = ("air='wind'" if air == "wind" else
               f"its {used} samples are not on the IMU's clock: interpolated, their noise is "
               "not white at the IMU's rate and the fit checks refuse correct fits (README); "
               "air='interpolate' carries them so")
        notes.append(f"air: {source}'s {names} not carried ({why}); the steady wind only, "
                     "where estimated")
        return meta
    if air == "samples" and not same:
        raise FlightError(f"{source}: air='samples' needs an air sample at every IMU instant "
                          f"(the IMU's clock); {int(np.count_nonzero(near > tol))} of {t.size} "
                          "have none (air='interpolate' resamples them)")
    if ta[0] > t[0] + tol or ta[-1] < t[-1] - tol:
        raise FlightError(f"{source}: the air group's samples span {ta[0]:.6g}-{ta[-1]:.6g} s, "
                          f"the IMU's {t[0]:.6g}-{t[-1]:.6g} s: not resampled beyond its times "
                          "(cut the flight, or air='wind' for the steady wind only)")
    channels.update({c: np.interp(t, ta, v) for c, v in logged["channels"].items()})
    how = ("at the IMU's instants (the same clock): as logged" if same else
           f"linearly interpolated to the IMU's {t.size} instants: one air sample's noise "
           f"spans about {(t.size - 1) / max(used - 1, 1):.3g} IMU samples (not white at the "
           "IMU's rate: the fit checks refuse correct fits, README)")
    probe = ""
    if logged["position_m"] is not None:
        meta[PROBE_KEY] = {"position_m": list(logged["position_m"])}
        probe = (f"; probe at [{', '.join(f'{v:.4g}' for v in logged['position_m'])}] m: "
                 f"metadata {PROBE_KEY}")
    notes.append(f"air: {used} samples of {names} from {source} {how}{probe}")
    return meta
