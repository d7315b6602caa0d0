"""The kinematic model of the reconstruction: strapdown equations driven by the IMU.

State (:data:`STATES`, indexed by name): body velocity ``u v w`` [m/s] over the ground,
3-2-1 Euler angles ``phi theta psi`` [rad] (phi and psi unwrapped: the state is
continuous, only the INS's measured angles are wrapped), NED position ``pn pe pd`` [m]
(flat Earth, from the origin of the GNSS), ``alt0`` the pressure altitude of that origin
[m], then the instrument errors: accelerometer biases of the two triads [m/s^2], gyro
biases [rad/s], accelerometer and gyro scale factors [-].

The IMU's readings are corrected, ``(reading - bias) / (1 + scale)``; the specific force
at the c.g. is the mean of the two corrected triads (at their mean position ``r``) less
the lever-arm terms ``wdot x r + w x (w x r)``: ``w`` the corrected gyros, ``wdot`` their
smoothed derivative (given). With the two triads nearly symmetric about the c.g. ``r`` is
small (5 mm on the reference airframe), so the differentiated gyro's noise hardly enters;
one triad alone would need ``wdot`` times its 0.6 m lever arm. The derivatives of ``u v
w`` and of the Euler angles are the model's own (:func:`aeroid.model.equations.derivative`,
eqs. 2-4 and 8-10) with these loads; the position's derivative is ``C_nb [u v w]``.
Biases and scale factors are constant. No wind: ``u v w`` are over the ground (equal to
the air-relative velocity only in still air; without air data a wind is unobservable).

Every function is element-wise over a trailing axis of columns, so one call with complex
perturbations gives the exact Jacobians (complex step).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from aeroid.flights import body_to_ned
from aeroid.model import G0, Constants, Loads, State, equations

#: The reconstruction's states, in order.
STATES: tuple[str, ...] = (
    "u", "v", "w", "phi", "theta", "psi", "pn", "pe", "pd", "alt0",
    "bax1", "bay1", "baz1", "bax2", "bay2", "baz2", "bp", "bq", "br",
    "sax1", "say1", "saz1", "sax2", "say2", "saz2", "sp", "sq", "sr",
)
N_STATES = len(STATES)
IX = {name: j for j, name in enumerate(STATES)}
VEL = slice(IX["u"], IX["w"] + 1)
ATT = slice(IX["phi"], IX["psi"] + 1)
POS = slice(IX["pn"], IX["pd"] + 1)
ACCEL_BIAS = slice(IX["bax1"], IX["baz2"] + 1)
GYRO_BIAS = slice(IX["bp"], IX["br"] + 1)
ACCEL_SCALE = slice(IX["sax1"], IX["saz2"] + 1)
GYRO_SCALE = slice(IX["sp"], IX["sr"] + 1)
#: The IMU channels that drive the model, in order.
IMU_CHANNELS: tuple[str, ...] = ("ax1", "ay1", "az1", "ax2", "ay2", "az2", "p", "q", "r")
N_IMU = len(IMU_CHANNELS)

# Unit mass and inertias, no thrust, no aerodynamics: the model's equations then turn the
# "loads" into the specific force and leave only the kinematic terms.
_KINEMATIC = Constants(rho=0.0, area=0.0, diameter=1.0, mass=1.0, ix=1.0, iy=1.0, iz=1.0,
                       thrust=0.0, gravity=G0)
_STEP = 1e-30  # complex step: exact derivatives to rounding for any step this small


def corrected_imu(x: np.ndarray, imu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the corrected triads (2, 3, m) [m/s^2] and gyros (3, m) [rad/s]."""
    accel = ((imu[:6] - x[ACCEL_BIAS]) / (1.0 + x[ACCEL_SCALE])).reshape(2, 3, -1)
    gyro = (imu[6:] - x[GYRO_BIAS]) / (1.0 + x[GYRO_SCALE])
    return accel, gyro


def _cross(a: Any, b: Any) -> tuple[Any, Any, Any]:
    """Return ``a x b`` by components (sequences of three arrays)."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def derivative(x: np.ndarray, imu: np.ndarray, omega_dot: np.ndarray,
               lever: np.ndarray) -> np.ndarray:
    """Return d(state)/dt, shape (N_STATES, m).

    Parameters
    ----------
    x : ndarray, shape (N_STATES, m)
    imu : ndarray, shape (N_IMU, m) or (N_IMU, 1)
        Raw IMU readings [m/s^2, rad/s] (:data:`IMU_CHANNELS`).
    omega_dot : ndarray, shape (3, 1)
        Angular acceleration [rad/s^2].
    lever : ndarray, shape (3, 1)
        Mean position of the two triads from the c.g. [m].
    """
    accel, gyro = corrected_imu(x, imu)
    mean = 0.5 * (accel[0] + accel[1])
    spin = _cross(omega_dot, lever)
    centripetal = _cross(gyro, _cross(gyro, lever))
    force = [mean[j] - spin[j] - centripetal[j] for j in range(3)]
    state = State(x[IX["u"]], x[IX["v"]], x[IX["w"]], gyro[0], gyro[1], gyro[2],
                  x[IX["phi"]], x[IX["theta"]], x[IX["psi"]])
    zero = 0.0 * force[0]
    d = equations.derivative(state, Loads(force[0], force[1], force[2], zero, zero, zero),
                             _KINEMATIC, equations.trig(state))
    out = np.zeros(np.broadcast_shapes(x.shape, (1, force[0].shape[-1])), dtype=force[0].dtype)
    out[VEL] = d.u, d.v, d.w
    out[ATT] = d.phi, d.theta, d.psi
    out[POS] = ned_velocity(x)
    return out


def ned_velocity(x: np.ndarray) -> np.ndarray:
    """Return the NED velocity ``C_nb [u v w]`` (3, m) [m/s]."""
    c = body_to_ned(x[IX["phi"]], x[IX["theta"]], x[IX["psi"]])  # (m, 3, 3)
    return np.einsum("mij,jm->im", c, x[VEL])


def jacobians(x: np.ndarray, imu: np.ndarray, omega_dot: np.ndarray, lever: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return ``f(x)`` (N_STATES,), ``df/dx`` (N_STATES, N_STATES), ``df/dimu`` (N_STATES, N_IMU).

    One complex-step evaluation over N_STATES + N_IMU columns.
    """
    n, m = N_STATES, N_IMU
    xs = np.tile(x[:, None].astype(complex), (1, n + m))
    xs[np.arange(n), np.arange(n)] += 1j * _STEP
    us = np.tile(imu[:, None].astype(complex), (1, n + m))
    us[np.arange(m), n + np.arange(m)] += 1j * _STEP
    f = derivative(xs, us, omega_dot, lever)
    return f[:, 0].real, f[:, :n].imag / _STEP, f[:, n:].imag / _STEP


def rk4_step(x: np.ndarray, imu0: np.ndarray, imu1: np.ndarray, omega_dot: np.ndarray,
             lever: np.ndarray, dt: float, k1: np.ndarray) -> np.ndarray:
    """Return the state after ``dt`` by RK4, the IMU linear between its two readings."""
    mid = 0.5 * (imu0 + imu1)[:, None]
    k2 = derivative((x + 0.5 * dt * k1)[:, None], mid, omega_dot, lever)[:, 0]
    k3 = derivative((x + 0.5 * dt * k2)[:, None], mid, omega_dot, lever)[:, 0]
    k4 = derivative((x + dt * k3)[:, None], imu1[:, None], omega_dot, lever)[:, 0]
    return x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
