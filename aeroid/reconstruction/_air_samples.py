"""The air group's samples in the reconstruction's flight (``to_flight(air=True)``, issue 26).

A suite log's ``air`` group (a probe's ``alpha``, ``beta``, ``airspeed`` or its
``total_pressure`` and ``static_pressure``) samples at its own clock; the flight of
:meth:`~aeroid.reconstruction.Reconstruction.to_flight` is at the IMU's. Each channel is
**linearly interpolated** (:func:`numpy.interp`) to the IMU's instants, so equation-error's
and output-error's air-data paths read them as a single-file log's channels (the
pressures turned into the airspeed by ``Estimator.fit``, as there). Where the air group
samples at the IMU's instants (a probe on the IMU's clock) that is the samples as logged.
At a lower rate the interpolated samples are not independent: one air sample's noise
spans ``imu_rate / air_rate`` IMU samples, and the note says so (a fit that takes them
as white noise at the IMU's rate measures less noise than the probe's: measured in the
README). An IMU instant outside the air group's times is refused (nothing extrapolated).
The probe's position, where the group states one, becomes the flight's
``metadata["air_data_probe"] = {"position_m": [x, y, z]}`` (a single-file flight's key).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from aeroid.errors import FlightError
from aeroid.flights import SuiteLog

__all__ = ["AIR_LOG", "flight_air", "logged_air"]

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


def flight_air(metadata: dict[str, Any], channels: dict[str, np.ndarray], air: bool,
               notes: list[str]) -> dict[str, Any]:
    """``metadata`` without the log's air samples; with ``air`` their channels added to
    ``channels`` at the IMU's times ``channels["t"]`` (module docstring) and one note."""
    meta = {k: v for k, v in metadata.items() if k != AIR_LOG}
    logged = metadata.get(AIR_LOG)
    if logged is None:
        return meta
    names = ", ".join(logged["channels"])
    if not air:
        notes.append(f"air: the air group's {names} not carried (air=False; the steady wind "
                     "only, where estimated)")
        return meta
    t, ta = channels["t"], logged["t"]
    tol = SAME_RTOL * float(t[1] - t[0])
    if ta[0] > t[0] + tol or ta[-1] < t[-1] - tol:
        raise FlightError(f"{logged['source']}: the air group's samples span "
                          f"{ta[0]:.6g}-{ta[-1]:.6g} s, the IMU's {t[0]:.6g}-{t[-1]:.6g} s: "
                          "not resampled beyond its times (cut the flight, or air=False for "
                          "the steady wind only)")
    channels.update({c: np.interp(t, ta, v) for c, v in logged["channels"].items()})
    k = np.clip(np.searchsorted(ta, t), 0, ta.size - 1)
    near = np.minimum(np.abs(ta[k] - t), np.abs(ta[np.maximum(k - 1, 0)] - t))
    used = int(np.count_nonzero((ta >= t[0] - tol) & (ta <= t[-1] + tol)))
    how = ("at the IMU's instants (the same clock): as logged" if np.all(near <= tol) else
           f"linearly interpolated to the IMU's {t.size} instants: one air sample's noise "
           f"spans about {(t.size - 1) / max(used - 1, 1):.3g} IMU samples (not white at the "
           "IMU's rate)")
    where = ""
    if logged["position_m"] is not None:
        meta[PROBE_KEY] = {"position_m": list(logged["position_m"])}
        where = (f"; probe at [{', '.join(f'{v:.4g}' for v in logged['position_m'])}] m: "
                 f"metadata {PROBE_KEY}")
    notes.append(f"air: {used} samples of {names} from {logged['source']} {how}{where}")
    return meta
