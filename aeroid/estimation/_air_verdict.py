"""Air data against the inertial angles: a steady wind, or turbulence (issue 26).

A flight whose logged air data differ from the inertial ``u, v, w`` was flown in moving
air (or its probe is off). The wind per sample that makes the model's air-relative
velocity match the logged angles (and airspeed, when logged) is
:func:`aeroid.estimation.air_data_wind`; :func:`air_data_verdict` splits it into

- its mean over the record: the **steady wind** (NED [m/s]);
- the slow part of the rest (Savitzky-Golay of order 3 over ``window_s``, the
  equation-error's default 0.1 s), whose mean square beyond what the probe's white
  noise leaves after the same smoothing is the **gusts'** (``noise^2 sum c_j^2`` with
  ``c`` the smoother's interior weights, :func:`scipy.signal.savgol_coeffs`; the
  noise per component from the 4th differences, :func:`aeroid.estimation.
  difference_noise_sd`).

Gusts above :data:`GUST_LIMIT_FACTOR` times the smoothed noise's RMS (and above
:data:`GUST_FLOOR_MPS`) are reported as
**turbulence** (a steady wind does not explain the disagreement), else a **steady
wind** (or **still air** when the steady wind is within :data:`STEADY_SE` standard
errors ``noise / sqrt(n)`` of zero). Measured on the reference flight (Gaussian IMU,
0.1 deg vane noise, no airspeed channel, 6 seeds each, 0.1 s; ``python
benchmarks/bench_air_data_outputs.py --seeds 8 --verdict-seeds 6``): a steady 5 m/s wind
gave gusts of 0.00-0.10 m/s against a limit of 0.27 (0/6 called turbulence: no correct
steady wind refused); Dryden sd 0.3 m/s 0.00-0.38 (2/6 called turbulence), sd 1 m/s
0.62-1.25 (6/6), sd 3 m/s 2.03-3.72 (6/6). Without an airspeed channel the along-path
component is unseen (the angles do not see it); the line says so. From the log alone a
miscalibrated vane (a factor, an offset) turns with the roll like gusts, so the log-only
line says "turbulence (or a probe's calibration)"; output-error's line judges what its
fitted steady wind and calibration leave (:mod:`baselines._oe_airdata_fit`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_coeffs

from aeroid.estimation._air_data import (
    WIND_POLYORDER,
    WIND_WINDOW_S,
    air_data_wind,
    has_air_angles,
    has_air_data,
    has_airspeed,
    wind_window,
)
from aeroid.estimation._result import EstimationResult
from aeroid.estimation._signals import difference_noise_sd, smooth
from aeroid.flights import Flight
from aeroid.model import equations

#: Gusts (the RMS of the implied wind's slow part beyond the probe noise's) above this
#: multiple of the smoothed noise's RMS are turbulence (module docstring: measured).
GUST_LIMIT_FACTOR = 1.0
#: Gusts below this RMS [m/s] are never called turbulence: on a noise-free log the limit
#: above is ~0 and the smoothing's end effects alone leave ~0.004 m/s (measured on the
#: reference flight in a 5 m/s crosswind); light turbulence (MIL-F-8785C) is ~1 m/s.
GUST_FLOOR_MPS = 0.1
#: A steady wind within this many standard errors of zero in every component is still air.
STEADY_SE = 3.0


@dataclass(frozen=True)
class AirVerdict:
    """What the air data say about the air: ``kind`` (``"still air"``, ``"steady
    wind"``, ``"turbulence"``), the steady wind (NED [m/s]) and its standard error, the
    gusts' RMS beyond the probe noise and its limit [m/s], the logged angles' RMS
    distance from the inertial ones [deg], and ``line``: the one-line report."""

    kind: str
    steady_ned_mps: tuple[float, float, float]
    steady_stderr_mps: tuple[float, float, float]
    gust_rms_mps: float
    gust_limit_mps: float
    angle_rms_deg: float
    line: str

    def as_info(self) -> dict[str, object]:
        """The verdict as ``info["air_data_verdict"]``."""
        return {"kind": self.kind, "steady_ned_mps": list(self.steady_ned_mps),
                "steady_stderr_mps": list(self.steady_stderr_mps),
                "gust_rms_mps": self.gust_rms_mps, "gust_limit_mps": self.gust_limit_mps,
                "angle_rms_deg": self.angle_rms_deg}


def air_data_verdict(flight: Flight, owner: str, window_s: float = WIND_WINDOW_S
                     ) -> AirVerdict | None:
    """Return what the flight's air data say about the air (module docstring), or None
    for a flight without air data (or too short to smooth)."""
    if not has_air_data(flight):
        return None
    window = wind_window(flight, window_s)
    if window == 1:
        return None
    wind = air_data_wind(flight, 0.0)
    steady = wind.mean(axis=0)
    rest = wind - steady
    noise = np.asarray(difference_noise_sd(rest)[0], dtype=float).reshape(-1)
    return verdict_of(flight, owner, rest, steady, noise / np.sqrt(wind.shape[0]), window_s)


def verdict_of(flight: Flight, owner: str, rest: np.ndarray, steady: np.ndarray,
               steady_se: np.ndarray, window_s: float = WIND_WINDOW_S, source: str = ""
               ) -> AirVerdict:
    """The verdict on ``rest`` (n, k) [m/s], what the steady wind ``steady`` (NED [m/s],
    standard errors ``steady_se``) leaves of the air data, smoothed over ``window_s``
    [s] (module docstring); ``source`` names where ``rest`` comes from in the line."""
    window = max(wind_window(flight, window_s), WIND_POLYORDER + 2)
    noise = np.asarray(difference_noise_sd(rest)[0], dtype=float).reshape(-1)
    gain = float(np.sum(savgol_coeffs(window, WIND_POLYORDER) ** 2))
    slow = smooth(rest, window, WIND_POLYORDER, axis=0)
    excess = np.maximum(np.mean(slow * slow, axis=0) - gain * noise ** 2, 0.0)
    gust = float(np.sqrt(np.sum(excess)))
    limit = max(GUST_LIMIT_FACTOR * float(np.sqrt(gain * np.sum(noise ** 2))), GUST_FLOOR_MPS)
    steady, se = np.asarray(steady, dtype=float), np.asarray(steady_se, dtype=float)
    if gust > limit:
        kind = "turbulence"
    elif np.all(np.abs(steady) <= STEADY_SE * se):
        kind = "still air"
    else:
        kind = "steady wind"
    _, alpha, beta = equations.air_data(flight["u"], flight["v"], flight["w"])
    rms = float(np.degrees(np.sqrt(np.mean(np.concatenate([flight["alpha"] - alpha,
                                                           flight["beta"] - beta]) ** 2))))
    logged = ", ".join((["alpha, beta"] if has_air_angles(flight) else [])
                       + (["airspeed"] if has_airspeed(flight) else []))
    along = "" if has_airspeed(flight) else " (along the path unseen: no airspeed channel)"
    shown = ", ".join(f"{a} {w:+.2f}" for a, w in zip("NED", steady, strict=True))
    # from the log alone, a miscalibrated probe's error turns with the roll like gusts
    said = kind + (" (or a probe's calibration)" if kind == "turbulence" and not source else "")
    line = (f"{owner}: the air data ({logged}) against the inertial u, v, w: {rms:.3g} deg "
            f"RMS apart; {said}: steady part {shown} m/s, gusts of {gust:.2g} m/s RMS "
            f"beyond the probe noise{source} (turbulence "
            f"above {limit:.2g}){along}")
    return AirVerdict(kind, tuple(steady.tolist()),  # type: ignore[arg-type]
                      tuple(se.tolist()), gust, limit, rms, line)  # type: ignore[arg-type]


def with_air_verdict(result: EstimationResult, verdict: AirVerdict | None) -> EstimationResult:
    """``result`` with the verdict's line among its warnings and ``info["air_data_verdict"]``
    (``result`` itself without a verdict)."""
    if verdict is None:
        return result
    return dataclasses.replace(result, info={**result.info,
                                             "air_data_verdict": verdict.as_info()},
                               warnings=(*result.warnings, verdict.line))


__all__ = ["GUST_FLOOR_MPS", "GUST_LIMIT_FACTOR", "STEADY_SE", "AirVerdict", "air_data_verdict",
           "verdict_of", "with_air_verdict"]
