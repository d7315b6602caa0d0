"""What ``Flight.validate`` checks: structure, physical ranges, units, spikes.

Each finding is one line. Errors are data no estimator can use (or that would give
confident garbage: rates in deg/s made equation-error and the EKF report success with
answers 1e3-1e6 off); warnings are data a person might mean but should look at. Every
threshold is a named constant with its reason, and the reference flights (paper,
Gaussian and no noise, any seed) pass with neither.

Units are checked through the kinematics, which hold whatever the magnitudes: the roll
angle's derivative against eq. 8, ``phidot = p + (q sin phi + r cos phi) tan theta``,
the pitch angle's derivative against eq. 9, ``thetadot = q cos phi - r sin phi``, and
the logged alpha and beta against ``atan(w/u)`` and ``asin(v/V)`` (eqs. 14-16). A
least-squares scale ``k`` between the two sides is 1 for consistent data, about 1/57.3
for rates in deg/s with angles in radians and about 57.3 for angles in degrees. The
per-sample inputs (mass, thrust, inertias, atmosphere) are checked against ranges, the
airframe and the altitude's change by :mod:`aeroid.flights._input_checks`.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from aeroid.flights._airspeed import airspeed_findings
from aeroid.flights._channels import (
    ACCELEROMETER_CHANNELS,
    ATMOSPHERE_CHANNELS,
    CHANNELS,
    REQUIRED_CHANNELS,
)
from aeroid.flights._channels import (
    UNITS as PER_SAMPLE_UNITS,
)
from aeroid.flights._input_checks import (
    ALTITUDE_RATE,
    altitude_hint,
    altitude_pair,
    check_inputs,
    range_hint,
)
from aeroid.flights._passive_fin import passive_fin_problem
from aeroid.flights._pitot import pitot_findings
from aeroid.model import AIRFRAME_LIMITS, Airframe, check_air_temperature

#: Relative spread of the sample interval accepted as a uniform time base.
TIME_UNIFORMITY_RTOL = 1e-6
#: Fewest samples: the largest fit aeroid runs has 20 unknowns (9 coefficients, 9
#: initial states, a sensor position and an input delay); two samples per unknown leave
#: as many residual degrees of freedom as parameters. Fewer gave confident garbage
#: (output-error on 3 rows: Cl0 67.5 +- 0.011, truth 0.041).
MIN_SAMPLES = 40
#: Sample interval range [s]: no IMU logs faster than 100 kHz, and at 1 Hz the roll of a
#: rolling airframe (several turns a second) aliases. Outside: time in ms or us?
DT_RANGE_S = (1e-5, 1.0)
#: Fastest airspeed [m/s]: Mach 10 at 10 km; no airframe with constant coefficients
#: flies faster (speeds in km/h or ft/s of real airframes stay below it, so this catches
#: garbage, not units).
MAX_SPEED_MPS = 3000.0
#: Largest |alpha| and |beta| [deg]: beyond it the linear aerodynamics of eqs. 2-7
#: mean nothing; a value in degrees read as radians lands here.
MAX_AIR_ANGLE_DEG = 60.0
#: A sample is a spike when it is this many times the spread-plus-level of its channel
#: group (accelerations, rates, velocities, angles) away from its channel's median.
#: Physical data stay within a few spreads; a 1e300 sample is 1e297 of them.
SPIKE_FACTOR = 100.0
#: The spread and level are taken from every k-th sample, at most this many: a factor
#: 100 test needs no exact percentile, and a 560,000-sample log validates 10x faster.
SPIKE_SUBSAMPLE = 50_000
#: The kinematic scale k is judged only when the two sides agree in shape: the squared
#: cosine between them at least this (0.996-1.000 on the reference flights with paper,
#: Gaussian or no noise); below it the motion is too small to say anything.
KINEMATIC_MIN_COS2 = 0.9
#: |log k| beyond log of this is an error: no consistent log is 2x off its kinematics.
KINEMATIC_ERROR_FACTOR = 2.0
#: Beyond this (and within the error factor) a warning: a gyro scale error or a time
#: base off by this much biases every coefficient. Reference flights: k within 1.2 %.
KINEMATIC_WARN_FACTOR = 1.25
#: Degrees per radian: the factor between the two unit hypotheses.
DEG = 180.0 / math.pi
#: Largest step of phi and psi between samples [rad]: a larger one is a wrap to +-180
#: deg (or a roll faster than half a turn per sample, which aliases); estimators
#: differentiate phi, so it must be continuous.
MAX_ANGLE_STEP_RAD = math.pi
#: |delta| above this multiple of the airframe's delta_max is an error (degrees read as
#: radians give 57.3); above :data:`DELTA_OVERSHOOT` a warning (a fin that overshoots
#: its stop, or a delta_max_deg that is wrong).
DELTA_UNITS_FACTOR = 10.0
DELTA_OVERSHOOT = 1.1

_GROUPS: dict[str, tuple[str, ...]] = {
    "accelerations": ACCELEROMETER_CHANNELS,
    "rates": ("p", "q", "r"),
    "velocities": ("u", "v", "w"),
    "angles": ("alpha", "beta", "phi", "theta", "psi", "delta"),
}


def check_flight(data: pd.DataFrame, airframe: Airframe) -> tuple[list[str], list[str]]:
    """Return ``(errors, warnings)`` found in a flight's data and airframe, one line each."""
    errors: list[str] = []
    warns: list[str] = []
    missing = [c for c in REQUIRED_CHANNELS if c not in data.columns]
    if missing:
        errors.append(f"missing required column(s): {', '.join(missing)}")
    present = [c for c in CHANNELS if c in data.columns]
    values = {c: _floats(data[c]) for c in present}
    for name in present:
        bad = np.flatnonzero(~np.isfinite(values[name]))
        if bad.size:
            errors.append(f"column {name!r} has {bad.size} NaN/inf or non-numeric value(s), "
                          f"first at row {bad[0]}")
    errors.extend(_per_sample(values, airframe))
    if len(data) < MIN_SAMPLES:
        errors.append(f"too few samples ({len(data)}; need at least {MIN_SAMPLES}: two per "
                      "unknown of the largest fit)")
        return errors, warns
    finite = {c: v for c, v in values.items() if np.all(np.isfinite(v))}
    clean = not errors
    if "t" in finite:
        errors.extend(_time(finite["t"]))
    spikes = _spikes(finite)
    errors.extend(spikes)
    errors.extend(_ranges(finite, airframe, warns))
    check_inputs(finite, airframe, errors, warns)
    errors.extend(airspeed_findings(finite))
    errors.extend(pitot_findings(values, check_finite=False))  # a pitot-static probe's
    if clean and not errors:
        _kinematics(finite, errors, warns)
    return errors, warns


def _floats(column: pd.Series) -> np.ndarray:
    """The column as floats (non-numeric values become NaN)."""
    if pd.api.types.is_numeric_dtype(column):
        return column.to_numpy(dtype=float)
    return pd.to_numeric(column, errors="coerce").to_numpy(dtype=float)


def _per_sample(values: dict[str, np.ndarray], airframe: Airframe) -> list[str]:
    """A per-sample input is used or refused: never present and silently ignored."""
    found: list[str] = []
    channel = airframe.atmosphere_channel
    if channel is not None and channel not in values:
        found.append(f"[atmosphere] per_sample = {channel!r} but the flight has no "
                     f"{channel!r} channel")
    ignored = [c for c in ATMOSPHERE_CHANNELS if c in values and c != channel]
    if ignored:
        found.append(f"channel(s) {', '.join(ignored)} given while the airframe states one "
                     "atmosphere for the flight: set [atmosphere] per_sample to the channel "
                     "to use it, or drop the column(s)")
    for name in ("mass", "ix", "iy", "iz", "rho", "qbar"):
        v = values.get(name)
        if v is not None and np.all(np.isfinite(v)) and np.any(v <= 0):
            found.append(f"channel {name!r} must be positive ({PER_SAMPLE_UNITS[name]}), "
                         f"first non-positive at row {int(np.flatnonzero(v <= 0)[0])}")
    temperature = values.get("air_temperature")  # the air's, for Mach tables
    if temperature is not None and np.all(np.isfinite(temperature)):  # NaN: said above
        try:
            check_air_temperature(values["air_temperature"], "channel 'air_temperature'")
        except ValueError as exc:
            found.append(str(exc))
    thrust = values.get("thrust")
    if thrust is not None and np.all(np.isfinite(thrust)) and np.any(thrust < 0):
        found.append("channel 'thrust' must be >= 0 [N] (thrust along body +x)")
    altitude = values.get("altitude")
    low, high = AIRFRAME_LIMITS["altitude_m"]
    if altitude is not None and np.all(np.isfinite(altitude)) and (
            np.any(altitude < low) or np.any(altitude > high)):
        found.append(f"channel 'altitude' outside the ISA model's {low:g} to {high:g} m"
                     f"{range_hint('altitude', altitude, low, high)}")
    return found


def _time(t: np.ndarray) -> list[str]:
    steps = np.diff(t)
    nonpos = np.flatnonzero(steps <= 0)
    if nonpos.size:
        return [f"time is not increasing at row {nonpos[0] + 1}"]
    dt = float(np.median(steps))
    off = np.flatnonzero(np.abs(steps - dt) > TIME_UNIFORMITY_RTOL * dt + 1e-12)
    if off.size:
        return [f"time base is not uniform: step {steps[off[0]]:.6g} s at row {off[0] + 1} "
                f"(median {dt:.6g} s)"]
    low, high = DT_RANGE_S
    if not low <= dt <= high:
        return [f"sample interval {dt:.3g} s is outside {low:g}..{high:g} s "
                "(time in ms or us? the t channel is in seconds)"]
    return []


def _spikes(finite: dict[str, np.ndarray]) -> list[str]:
    found = []
    for group, names in _GROUPS.items():
        names = tuple(c for c in names if c in finite)
        if not names:
            continue
        low, centre, high = {}, {}, {}
        for c in names:  # one partition per channel, of at most SPIKE_SUBSAMPLE samples
            step = -(-len(finite[c]) // SPIKE_SUBSAMPLE)
            low[c], centre[c], high[c] = np.percentile(finite[c][::step], [1, 50, 99])
        spread = max(float(high[c] - low[c]) for c in names)
        scale = spread + max(abs(float(m)) for m in centre.values())
        if scale == 0.0:
            continue
        for c in names:
            far = np.flatnonzero(np.abs(finite[c] - centre[c]) > SPIKE_FACTOR * scale)
            if far.size:
                found.append(f"column {c!r} has {far.size} spike(s), first at row {far[0]} "
                             f"({finite[c][far[0]]:.3g}, more than {SPIKE_FACTOR:g}x the "
                             f"{group}' spread and level {scale:.3g} from the median)")
    return found


def _ranges(finite: dict[str, np.ndarray], airframe: Airframe, warns: list[str]) -> list[str]:
    found = []
    if all(c in finite for c in ("u", "v", "w")):
        u, v, w = finite["u"], finite["v"], finite["w"]
        speed = np.sqrt(u * u + v * v + w * w)
        for mask, what, why in (
                (~(speed > 0), "implausible airspeed V <= 0", ""),
                (~(u > 0) & (speed > 0), "u <= 0", " (flying backwards? alpha = atan(w/u) needs "
                 "u > 0; check the axis conventions)"),
                (speed > MAX_SPEED_MPS, f"airspeed above {MAX_SPEED_MPS:g} m/s", "")):
            rows = np.flatnonzero(mask)
            if rows.size:
                shown = f" ({speed[rows[0]]:.3g} m/s)" if speed[rows[0]] > MAX_SPEED_MPS else ""
                found.append(f"{what} at row {rows[0]}{shown}{why}")
    for name in ("alpha", "beta"):
        if name in finite:
            high = np.flatnonzero(np.abs(finite[name]) > math.radians(MAX_AIR_ANGLE_DEG))
            if high.size:
                value = math.degrees(abs(finite[name][high[0]]))
                found.append(f"implausible |{name}| > {MAX_AIR_ANGLE_DEG:g} deg at row "
                             f"{high[0]} ({value:.1f} deg; angles in degrees? use --degrees)")
    for name in ("phi", "psi"):
        if name in finite and len(finite[name]) > 1:
            jumps = np.flatnonzero(np.abs(np.diff(finite[name])) > MAX_ANGLE_STEP_RAD)
            if jumps.size:
                step = finite[name][jumps[0] + 1] - finite[name][jumps[0]]
                found.append(f"{name} jumps by {step:.3g} rad at row {jumps[0] + 1} (wrapped to "
                             "+-180 deg? aeroid needs it continuous: unwrap it, e.g. with "
                             "numpy.unwrap; in degrees? use --degrees)")
    if "theta" in finite:
        high = np.flatnonzero(np.abs(finite["theta"]) > math.pi / 2)
        if high.size:
            found.append(f"|theta| > 90 deg at row {high[0]} (an Euler pitch angle is within "
                         "+-90 deg; angles in degrees? use --degrees)")
    if "delta" in finite and airframe.fin == "passive":  # issue 25: no moving fin
        found += [p for p in [passive_fin_problem(finite["delta"])] if p]
    elif "delta" in finite:
        peak = float(np.max(np.abs(finite["delta"])))
        limit = airframe.delta_max_rad
        where = (f"|delta| reaches {peak:.4g} rad, {peak / limit:.3g}x the airframe's "
                 f"delta_max_deg {airframe.delta_max_deg:g}")
        if peak > DELTA_UNITS_FACTOR * limit:
            found.append(f"{where} (delta in degrees? use --degrees)")
        elif peak > DELTA_OVERSHOOT * limit:
            warns.append(f"{where} (check delta_max_deg and the fin's units)")
    return found


def _kinematics(finite: dict[str, np.ndarray], errors: list[str], warns: list[str]) -> None:
    """Compare eqs. 8, 9 and 14-16 with the logged angles (see the module docstring)."""
    have = set(finite)
    pairs: list[tuple[str, str, np.ndarray, np.ndarray]] = []  # (left, right, y, x): y = k x
    if {"t", "p", "q", "r", "phi", "theta"} <= have:
        t, p, q, r = finite["t"], finite["p"], finite["q"], finite["r"]
        phi, theta = finite["phi"], finite["theta"]
        pairs.append(("the roll angle's derivative", "p + (q sin phi + r cos phi) tan theta "
                      "(eq. 8)", np.gradient(phi, t),
                      p + (q * np.sin(phi) + r * np.cos(phi)) * np.tan(theta)))
        pairs.append(("the pitch angle's derivative", "q cos phi - r sin phi (eq. 9)",
                      np.gradient(theta, t), q * np.cos(phi) - r * np.sin(phi)))
    if {"u", "v", "w"} <= have:
        u, v, w = finite["u"], finite["v"], finite["w"]
        with np.errstate(all="ignore"):
            if "alpha" in have:
                pairs.append(("alpha", "atan(w/u) (eq. 15)", finite["alpha"], np.arctan2(w, u)))
            if "beta" in have:
                pairs.append(("beta", "asin(v/V) (eq. 16)", finite["beta"],
                              np.arcsin(v / np.sqrt(u * u + v * v + w * w))))
    climb = altitude_pair(finite)
    if climb is not None:
        pairs.append(climb)
    for left, right, y, x in pairs:
        k = _scale(y, x)
        if k is None:
            continue
        off = abs(math.log(abs(k))) if k != 0 else math.inf
        line = f"{left} is {k:.3g} x {right}"
        if k < 0 or off > math.log(KINEMATIC_ERROR_FACTOR):
            errors.append(f"{line}: " + (altitude_hint(k) if left == ALTITUDE_RATE else
                                         _hint(k, left if left in ("alpha", "beta") else None)))
        elif off > math.log(KINEMATIC_WARN_FACTOR):
            warns.append(f"{line}: " + (
                "check the altitude's unit and the time column" if left == ALTITUDE_RATE
                else _AIR_HINT if left in ("alpha", "beta")
                else "check the gyro scale, the time column and the axis conventions"))


#: A logged alpha or beta a few tens of % off the inertial angle: moving air (a vane's
#: angles in wind or turbulence: 0.708 x atan(w/u) in Dryden sd 3 m/s, seen), not a gyro.
_AIR_HINT = ("a wind or turbulence (the logged angles are then air data, which the "
             "estimators use or say they ignore), or check the time column and the axis "
             "conventions")


def _scale(y: np.ndarray, x: np.ndarray) -> float | None:
    """Least-squares k in ``y = k x``, or None when the two do not agree in shape."""
    yy, xx, xy = float(y @ y), float(x @ x), float(x @ y)
    if not (xx > 0 and yy > 0 and math.isfinite(xx * yy)):
        return None
    if xy * xy < KINEMATIC_MIN_COS2 * xx * yy:
        return None
    return xy / xx


def _hint(k: float, angle: str | None) -> str:
    """The likely cause of a kinematic scale ``k`` (``angle``: the air angle compared)."""
    if k < 0:
        return "opposite signs: check the axis and sign conventions"
    near_deg_per_rad = abs(math.log(k / DEG)) < math.log(3.0)
    near_rad_per_deg = abs(math.log(k * DEG)) < math.log(3.0)
    if angle is not None and near_deg_per_rad:
        return f"{angle} in degrees? (--degrees converts every angle and rate)"
    if angle is not None and near_rad_per_deg:
        return f"{angle} in radians but read as degrees (--degrees)?"
    if near_rad_per_deg:
        return "rates in deg/s while angles are in rad? (--degrees converts both together)"
    if near_deg_per_rad:
        return "angles in degrees while rates are in rad/s? (--degrees converts both together)"
    return "check the units of the rates and angles, the time column and the axes"
