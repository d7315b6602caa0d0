"""What the axial-drag method reads from a suite log: an axial accelerometer and a track.

A cheap flight computer logs one accelerometer axis along the rocket's long axis (no
lateral axes, no gyros), GNSS positions (perhaps velocities) and a barometer. That is
enough for the range-test reduction of drag (:mod:`baselines.axial_drag`): a point mass
whose only aerodynamic force is the axial one, along the airspeed. This module turns a
:class:`aeroid.flights.SuiteLog` into the arrays the method fits (:class:`AxialLog`) and
refuses, in one line naming the group, what it cannot use: lateral accelerometers, gyros,
an INS attitude, a fin channel (a point mass has no attitude: use a full IMU with
output-error), a channel without its ``noise_sd`` (the likelihood needs it), saturated
axial samples.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aeroid.errors import EstimatorError
from aeroid.flights import SuiteLog
from aeroid.model import Airframe, pressure_altitude

__all__ = ["AXIAL_CHANNEL", "GNSS_POSITIONS", "GNSS_VELOCITIES", "AxialLog", "axial_log"]

#: The one accelerometer channel the method reads: body x of the first triad (after the
#: mounting: a board logging its long axis as -y says ``axes = "x=-y, ..."``).
AXIAL_CHANNEL = "ax1"
#: GNSS channels of a track (NED from the origin) [m], [m/s].
GNSS_POSITIONS = ("pn", "pe", "pd")
GNSS_VELOCITIES = ("vn", "ve", "vd")
#: Pressure step [Pa] of the central difference giving a barometer's altitude sd from its
#: pressure sd (dh/dp of the ISA pressure altitude; exact to 1e-9 relative at 1 Pa).
PRESSURE_STEP_PA = 1.0


@dataclass(frozen=True, eq=False)
class AxialLog:
    """The measurements of an axial-only log, SI units, one clock.

    Attributes
    ----------
    airframe : Airframe
        Mass, reference area, atmosphere, thrust, prior (the consider path replaces it).
    t : ndarray, shape (n,)
        Axial accelerometer times [s].
    accel : ndarray, shape (n,)
        Axial specific force readings, body x [m/s^2].
    accel_sd : float
        Their white-noise sd [m/s^2].
    gnss_t : ndarray, shape (m,)
        GNSS times [s], inside ``t[0] .. t[-1]``.
    gnss : ndarray, shape (m, 3 or 6)
        NED positions [m] (then velocities [m/s] when logged).
    gnss_sd : ndarray, shape (3 or 6,)
    baro_t, baro_altitude, baro_sd : ndarray or None
        Pressure altitude [m] and its sd per sample [m] (from the pressure sd), or None.
    source : str
    notes : tuple of str
        One line each: what was read and how.
    """

    airframe: Airframe
    t: np.ndarray
    accel: np.ndarray
    accel_sd: float
    gnss_t: np.ndarray
    gnss: np.ndarray
    gnss_sd: np.ndarray
    baro_t: np.ndarray | None = None
    baro_altitude: np.ndarray | None = None
    baro_sd: np.ndarray | None = None
    source: str = "suite log"
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def has_velocity(self) -> bool:
        """Whether the GNSS logged velocities too."""
        return self.gnss.shape[1] == len(GNSS_POSITIONS) + len(GNSS_VELOCITIES)


def _refuse(where: str, text: str) -> EstimatorError:
    return EstimatorError(f"axial-drag: {where}: {text}")


def _inside(t: np.ndarray, start: float, stop: float, name: str, notes: list[str]
            ) -> np.ndarray:
    keep = (t >= start - 1e-9) & (t <= stop + 1e-9)
    if not keep.all():
        notes.append(f"{name}: {int((~keep).sum())} sample(s) outside the accelerometer's "
                     f"{start:.6g}..{stop:.6g} s left out (the model is integrated over it)")
    return keep


def _sd(group: Any, channels: tuple[str, ...]) -> np.ndarray:
    missing = [c for c in channels if c not in group.noise_sd]
    if missing:
        raise _refuse(group.source, f"no noise_sd for {', '.join(missing)} (the likelihood "
                      "weighs each channel by it)")
    return np.array([group.noise_sd[c] for c in channels])


def axial_log(log: SuiteLog, airframe: Airframe | None = None) -> AxialLog:
    """Return the axial accelerometer, GNSS track and barometer of ``log``.

    Raises
    ------
    EstimatorError
        One line: no airframe, no imu or gnss group, an imu with other channels than
        the axial one (or without it), an INS or fin group, a missing noise sd, a
        saturated axial sample, fewer than two GNSS fixes in the accelerometer's span.
    """
    airframe = airframe or log.airframe
    if airframe is None:
        raise _refuse(log.source, "no airframe (the mass, area and atmosphere are needed)")
    for name in ("imu", "gnss"):
        if name not in log:
            raise _refuse(log.source, f"no {name!r} group: the method fits an axial "
                          "accelerometer against a GNSS track")
    other = sorted(set(log.groups) - {"imu", "gnss", "baro"})
    if other:
        raise _refuse(log.source, f"group(s) {', '.join(other)} not used by a point-mass "
                      "model (no attitude, no fin): give a log without them, or fit a full "
                      "IMU with output-error")
    imu = log["imu"]
    extra = sorted(set(imu.channels) - {AXIAL_CHANNEL})
    if AXIAL_CHANNEL not in imu.channels or extra:
        raise _refuse(imu.source, f"the imu group has {', '.join(sorted(imu.channels))}; "
                      f"this method takes the axial accelerometer {AXIAL_CHANNEL} alone (body "
                      "x after the mounting); a log with lateral axes or gyros is fitted by "
                      "output-error")
    if imu.n_saturated:
        raise _refuse(imu.source, f"{imu.n_saturated} axial sample(s) at the accel_range: "
                      "saturated readings cannot be fitted by this method yet")
    accel_sd = float(_sd(imu, (AXIAL_CHANNEL,))[0])
    t = np.asarray(imu.t, dtype=float)
    notes = [str(n) for n in log.metadata.get("notes", ())]
    gnss = log["gnss"]
    present = tuple(c for c in (*GNSS_POSITIONS, *GNSS_VELOCITIES) if c in gnss.channels)
    if present not in (GNSS_POSITIONS, (*GNSS_POSITIONS, *GNSS_VELOCITIES)):
        raise _refuse(gnss.source, f"GNSS channels {', '.join(present)}: give the three "
                      "NED positions, with or without the three velocities")
    keep = _inside(gnss.t, t[0], t[-1], "gnss", notes)
    if keep.sum() < 2:
        raise _refuse(gnss.source, f"{int(keep.sum())} fix(es) within the accelerometer's "
                      "span; the track needs at least two")
    track = np.column_stack([gnss.channels[c] for c in present])[keep]
    notes.append(f"gnss: {int(keep.sum())} fixes of {', '.join(present)} in the likelihood")
    baro_t = baro_alt = baro_sd = None
    if "baro" in log:
        baro = log["baro"]
        inside = _inside(baro.t, t[0], t[-1], "baro", notes)
        baro_t = np.asarray(baro.t, dtype=float)[inside]
        if "altitude" in baro.channels:
            baro_alt = baro.channels["altitude"][inside]
            baro_sd = np.full(baro_alt.shape, _sd(baro, ("altitude",))[0])
            used = "altitude"
        elif "pressure" in baro.channels:
            pressure = baro.channels["pressure"][inside]
            baro_alt = pressure_altitude(pressure)
            slope = (pressure_altitude(pressure + PRESSURE_STEP_PA)
                     - pressure_altitude(pressure - PRESSURE_STEP_PA)) / (2 * PRESSURE_STEP_PA)
            baro_sd = np.abs(slope) * _sd(baro, ("pressure",))[0]
            used = "pressure (as the ISA pressure altitude, sd through dh/dp)"
        else:
            raise _refuse(baro.source, "a baro group without altitude or pressure")
        notes.append(f"baro: {baro_t.size} samples of {used} in the likelihood, the altitude "
                     "of the track's origin a free parameter")
        if "temperature" in baro.channels:
            notes.append(f"baro: temperature ({baro.temperature_of}'s) not used: the model's "
                         "density and speed of sound are the airframe's atmosphere")
    return AxialLog(airframe=airframe, t=t, accel=np.asarray(imu.channels[AXIAL_CHANNEL],
                                                             dtype=float),
                    accel_sd=accel_sd, gnss_t=np.asarray(gnss.t, dtype=float)[keep],
                    gnss=track, gnss_sd=_sd(gnss, present), baro_t=baro_t,
                    baro_altitude=baro_alt, baro_sd=baro_sd, source=log.source,
                    notes=tuple(notes))
