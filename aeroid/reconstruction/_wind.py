"""The reconstruction's steady wind from a suite log's air data (issues 22 and 26).

The kinematic filter's ``u v w`` are over the ground. A log with an ``air`` group
(``alpha``, ``beta``, ``airspeed`` of a probe, each with its ``noise_sd``) gives, at
each of its samples, the air-relative velocity
``v_air = V (cos a cos b, sin b, sin a cos b)`` (body axes; the model's air data,
:func:`aeroid.model.equations.air_data`, inverted), so a wind sample
``w_k = C_nb (v_body - v_air)`` in north-east-down axes from the smoothed states at the
sample's time (linear interpolation of the IMU-rate table). :func:`steady_wind` returns
their weighted mean, a constant NED wind:

- **weights**: each sample's probe-noise covariance ``J R J'`` (``J`` the derivative of
  ``w_k`` in ``alpha, beta, V``; ``R`` the stated noise variances): generalized least
  squares of a constant;
- **its sd**: the probe noise's part ``(sum_k (J R J')^-1)^-1`` averages down over the
  samples; the states' part (velocity and attitude, the smoothed covariance mapped by
  ``dw/dx``) is taken as **fully correlated** over the record (the smoother's errors are
  slow), so it does not average down: its mean over the samples is added. Conservative.
- **its check**: the samples' scatter about the constant, ``mean (w_k - w)' S_k^-1
  (w_k - w) / 3`` with ``S_k`` the sample's own covariance (probe and states); about 1
  for a steady wind. Well above it (:data:`STEADY_NIS_LIMIT`) the line says the wind is
  not steady (turbulence, or a probe's calibration or position).

**The probe's position** ``r`` (the air group's ``probe_position_m``): the probe reads
``v_air + omega x r``, so ``v_air = V (...) - omega x r`` with ``omega`` the corrected
gyros interpolated to the sample (their noise, 0.002 rad/s at 0.5 m: 1 mm/s, is left out
of the sd). Not stated: the probe is taken at the c.g., and the line says so. **A probe's
pressures** instead of the airspeed: the airspeed of Mach ``p0 / p`` times the airframe's
speed of sound (:func:`aeroid.flights.air_group_airspeed`), its sd per sample from both
pressures' sd; the line says so. Without an ``air`` group the wind cannot be estimated,
and the line says that instead.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from aeroid.flights import (
    DECLARED_WIND_KEY,
    PITOT_CHANNELS,
    SensorGroup,
    SuiteLog,
    air_group_airspeed,
    body_to_ned,
)
from aeroid.model import Airframe
from aeroid.reconstruction._kinematics import ATT, N_STATES, VEL

#: The air group's channels, all three needed (the angles alone leave the wind along the
#: air velocity open).
AIR_CHANNELS = ("alpha", "beta", "airspeed")
#: The samples' mean normalized scatter about the steady wind above which it is said not
#: to be steady: the 99.9 % point of a chi-square of 3 n degrees of freedom over 3 n is
#: below 1.2 for n >= 100 samples; 2 leaves room for the states' correlated errors.
STEADY_NIS_LIMIT = 2.0
#: Complex step of the rotation's derivative [rad] (exact to rounding).
COMPLEX_STEP = 1e-20


def _wind_samples(v_body: np.ndarray, angles: np.ndarray, air: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Wind samples (k, 3) and their derivatives in the body velocity (k, 3, 3), the
    attitude (k, 3, 3) and the air data ``alpha, beta, V`` (k, 3, 3)."""
    a, b, speed = air.T
    ca_, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)
    v_air = speed[:, None] * np.stack([ca_ * cb, sb, sa * cb], axis=1)
    d_air = np.stack([speed[:, None] * np.stack([-sa * cb, 0 * a, ca_ * cb], axis=1),
                      speed[:, None] * np.stack([-ca_ * sb, cb, -sa * sb], axis=1),
                      np.stack([ca_ * cb, sb, sa * cb], axis=1)], axis=2)  # (k, body, a b V)
    rel = v_body - v_air
    c_nb = body_to_ned(*angles.T)
    wind = np.einsum("kij,kj->ki", c_nb, rel)
    d_att = np.zeros((len(a), 3, 3))
    for j in range(3):
        step = angles.astype(complex)
        step[:, j] += 1j * COMPLEX_STEP
        d_att[:, :, j] = np.einsum("kij,kj->ki", body_to_ned(*step.T).imag / COMPLEX_STEP, rel)
    return wind, c_nb, d_att, -np.einsum("kij,kjl->kil", c_nb, d_air)


def steady_wind(log: SuiteLog, t: np.ndarray, states: np.ndarray, covariance: np.ndarray,
                state_names: tuple[str, ...], notes: list[str],
                rates: np.ndarray | None = None, airframe: Airframe | None = None
                ) -> dict[str, Any]:
    """Return the steady wind's metadata and append its one-line note to ``notes``
    (module docstring).

    ``t`` (n,) the IMU times, ``states`` (n, N) the smoothed states named
    ``state_names``, ``covariance`` (n, N, N), ``rates`` (n, 3) the corrected gyros
    [rad/s] (a probe position needs them), ``airframe`` (a probe's pressures need its
    temperature). The metadata (empty without air data):
    ``wind_ned_mps``, ``wind_stderr_mps``, ``wind_samples``, ``wind_scatter`` (the mean
    normalized scatter) and ``wind_steady`` (the scatter below :data:`STEADY_NIS_LIMIT`);
    with the air the log declares (``metadata["wind"]``, the suite simulator's: kept for the
    flight, :mod:`aeroid.flights._declared_air`).
    """
    declared = {k: v for k, v in log.metadata.items() if k == DECLARED_WIND_KEY}
    if "air" not in log:
        notes.append("no air data in the log (an air group with alpha, beta, airspeed): u v w "
                     "are over the ground and the steady wind cannot be estimated")
        return declared
    group = log["air"]
    speed, speed_note = _airspeed(group, airframe)
    missing = [c for c in AIR_CHANNELS if c not in group.channels or c not in group.noise_sd]
    if speed is not None:
        missing = [c for c in ("alpha", "beta") if c in missing] + (
            ["airspeed (the pressures' sd)"] if speed[1] is None else [])
    if missing:
        notes.append(f"{group.source}: the air group lacks {', '.join(missing)} (or its "
                     "noise_sd): the steady wind needs alpha, beta and airspeed with their sd "
                     "(the angles alone leave the wind along the path open); not estimated")
        return declared
    inside = (group.t >= t[0]) & (group.t <= t[-1])
    ta = group.t[inside]
    vel, att = list(range(N_STATES))[VEL], list(range(N_STATES))[ATT]
    names = [state_names[i] for i in vel + att]
    cols = np.column_stack([np.interp(ta, t, np.unwrap(states[:, i]) if state_names[i] in
                                      ("phi", "psi") else states[:, i]) for i in vel + att])
    k = np.clip(np.searchsorted(t, ta), 0, t.size - 1)  # the states' covariance there
    idx = np.array(vel + att)
    p_states = covariance[k][:, idx[:, None], idx[None, :]]  # (k, 6, 6)
    values = {**group.channels, **({} if speed is None else {"airspeed": speed[0]})}
    air = np.column_stack([values[c][inside] for c in AIR_CHANNELS])
    r = group.probe_position_m
    v_probe = cols[:, :3]
    if r is not None:  # v_air at the c.g. = the probe's - omega x r: as v_body + omega x r
        assert rates is not None, "a probe position needs the gyros"
        omega = np.column_stack([np.interp(ta, t, rates[:, j]) for j in range(3)])
        v_probe = v_probe + np.cross(omega, np.asarray(r, dtype=float))
    wind, d_vel, d_att, d_air = _wind_samples(v_probe, cols[:, 3:], air)
    var = np.array([[group.noise_sd[c] ** 2 for c in AIR_CHANNELS[:2]]] * len(ta))
    sd_speed = (np.full(len(ta), group.noise_sd["airspeed"]) if speed is None or speed[1] is None
                else speed[1][inside])  # the pressures' propagated sd (checked above)
    var = np.column_stack([var, sd_speed ** 2])
    s_probe = np.einsum("kij,kj,klj->kil", d_air, var, d_air)
    d_x = np.concatenate([d_vel, d_att], axis=2)  # (k, 3, 6)
    s_states = np.einsum("kij,kjl,kml->kim", d_x, p_states, d_x)
    info = np.linalg.inv(s_probe)
    cov_probe = np.linalg.inv(info.sum(axis=0))
    mean = cov_probe @ np.einsum("kij,kj->i", info, wind)
    cov = cov_probe + s_states.mean(axis=0)
    sd = np.sqrt(np.diag(cov))
    e = wind - mean
    scatter = float(np.mean(np.einsum("ki,kij,kj->k", e, np.linalg.inv(s_probe + s_states),
                                      e)) / 3.0)
    steady = scatter <= STEADY_NIS_LIMIT
    shown = ", ".join(f"{a} {w:+.2f} +- {s:.2f}" for a, w, s in zip("NED", mean, sd,
                                                                     strict=True))
    verdict = ("steady" if steady else f"not steady: the samples scatter {scatter:.3g}x "
               "their sd (turbulence, or the probe's calibration or position)")
    where = ("probe taken at the c.g." if r is None else
             f"probe at [{', '.join(f'{v:.4g}' for v in r)}] m, omega x r from the gyros")
    notes.append(f"steady wind from the air data ({len(ta)} samples of {', '.join(AIR_CHANNELS)}"
                 f"{speed_note}, {where}; states {', '.join(names)} interpolated): {shown} m/s "
                 f"NED; {verdict}")
    return {**declared, "wind_ned_mps": mean.tolist(), "wind_stderr_mps": sd.tolist(),
            "wind_samples": int(len(ta)), "wind_scatter": scatter, "wind_steady": bool(steady)}


def _airspeed(group: SensorGroup, airframe: Airframe | None
              ) -> tuple[tuple[np.ndarray, np.ndarray | None] | None, str]:
    """The airspeed of a group's pressures and its sd (None without pressures), and the
    note's words."""
    if not all(c in group.channels for c in PITOT_CHANNELS):
        return None, ""
    speed, sd, note = air_group_airspeed(group, airframe)
    return (speed, sd), f" ({note})"


__all__ = ["AIR_CHANNELS", "STEADY_NIS_LIMIT", "steady_wind"]
