"""The channels of a flight: names, units, and which per-sample inputs the model uses.

Inside aeroid every channel is SI with angles in radians; a log whose angles are in
degrees and rates in deg/s is converted on reading (``--degrees``, the channels of
:data:`ANGLE_CHANNELS`).
"""

from __future__ import annotations

from aeroid.model import ACCEL_CHANNELS as ACCELEROMETER_CHANNELS
from aeroid.model import STATE_NAMES

#: The measured state, in the model's order ``[u, v, w, p, q, r, phi, theta, psi]``.
STATE_CHANNELS: tuple[str, ...] = STATE_NAMES
#: Every flight has these (``alpha`` and ``beta`` are derived from u, v, w when absent).
REQUIRED_CHANNELS: tuple[str, ...] = (
    "t", *ACCELEROMETER_CHANNELS, "p", "q", "r", "delta",
    "u", "v", "w", "alpha", "beta", "phi", "theta", "psi",
)
#: Per-sample inputs: mass, thrust, inertias, and the atmosphere (density, altitude for
#: the ISA density, or dynamic pressure), the latter named by ``[atmosphere] per_sample``.
#: The model interpolates them linearly in time between samples; every estimator, the EBM
#: reconstruction and the Cramér-Rao floor use them (:mod:`aeroid.flights._record`).
OPTIONAL_CHANNELS: tuple[str, ...] = ("mass", "thrust", "ix", "iy", "iz", "rho", "altitude",
                                      "qbar", "air_temperature")
#: The atmosphere channels: one of them is used when ``[atmosphere] per_sample`` names it.
ATMOSPHERE_CHANNELS: tuple[str, ...] = ("rho", "altitude", "qbar")
#: Measured air data beyond the required angles: an air-data probe's airspeed [m/s] (the
#: air-relative speed at the probe), used by equation-error and by output-error's
#: ``air_data`` (:mod:`aeroid.estimation._air_data`), said ignored by the other methods;
#: or a pitot-static probe's total and static pressures [Pa], which ``Estimator.fit``
#: turns into the airspeed channel (:mod:`aeroid.flights._pitot`).
AIR_DATA_CHANNELS: tuple[str, ...] = ("airspeed", "total_pressure", "static_pressure")
#: Every channel name aeroid knows.
CHANNELS: tuple[str, ...] = (*REQUIRED_CHANNELS, *OPTIONAL_CHANNELS, *AIR_DATA_CHANNELS)
#: Channels converted by ``angles_in_degrees`` (rates in deg/s).
ANGLE_CHANNELS: tuple[str, ...] = ("p", "q", "r", "delta", "alpha", "beta", "phi", "theta", "psi")

#: Unit of each channel inside aeroid (and in files written without ``--degrees``).
UNITS: dict[str, str] = {
    "t": "s",
    **{c: "m/s^2" for c in ACCELEROMETER_CHANNELS},
    "p": "rad/s", "q": "rad/s", "r": "rad/s",
    "delta": "rad", "alpha": "rad", "beta": "rad", "phi": "rad", "theta": "rad", "psi": "rad",
    "u": "m/s", "v": "m/s", "w": "m/s",
    "mass": "kg", "thrust": "N", "ix": "kg m^2", "iy": "kg m^2", "iz": "kg m^2",
    "rho": "kg/m^3", "altitude": "m", "qbar": "Pa",
    "airspeed": "m/s", "total_pressure": "Pa", "static_pressure": "Pa",
    "air_temperature": "K",  # the air's (Mach tables), not a barometer board's
}
