"""Rigid-body equations of motion of the rolling airframe (paper eqs. 2-10, 14-16).

Body axes, flat non-rotating earth, no wind, symmetric cruciform airframe with
``Iy = Iz`` allowed but not required, no products of inertia, thrust on body +x
through the c.g. The lateral coefficients follow the symmetry ties of eq. 1 and the
side force has no fin term (one fin pair acts in pitch only; notes, "Model").

Every function is batched: ``state`` has shape ``(..., 9)`` and ``coefficients``
``(..., 9)``; leading axes broadcast, so one call evaluates a whole swarm.

State layout (SI, radians): ``u, v, w`` [m/s], ``p, q, r`` [rad/s], ``phi, theta, psi``
[rad], indexed by the names below.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from aeroid.model._airframe import Airframe
from aeroid.model._atmosphere import G0
from aeroid.model._coefficients import CL0, CLP, CMA, CMD, CMQ, CX, CZA, CZD, CZQ

U, V, W, P, Q, R, PHI, THETA, PSI = range(9)
STATE_NAMES: tuple[str, ...] = ("u", "v", "w", "p", "q", "r", "phi", "theta", "psi")
N_STATE = 9
#: Aerodynamic force and moment layout: F_AX, F_AY, F_AZ [N], M_X, M_Y, M_Z [N m].
FM_NAMES: tuple[str, ...] = ("FAX", "FAY", "FAZ", "MX", "MY", "MZ")


class Constants(NamedTuple):
    """Model constants as plain floats (a tuple, so compiled kernels take it too).

    ``rho`` [kg/m^3], ``area`` S [m^2], ``diameter`` D [m], ``mass`` [kg], inertias
    [kg m^2], ``thrust`` [N], ``gravity`` [m/s^2].
    """

    rho: float
    area: float
    diameter: float
    mass: float
    ix: float
    iy: float
    iz: float
    thrust: float
    gravity: float


def constants(airframe: Airframe) -> Constants:
    """Return the model constants of ``airframe`` (ISA density at its altitude)."""
    return Constants(
        rho=airframe.density_kgm3,
        area=airframe.area_m2,
        diameter=airframe.diameter_m,
        mass=airframe.mass_kg,
        ix=airframe.ix_kgm2,
        iy=airframe.iy_kgm2,
        iz=airframe.iz_kgm2,
        thrust=airframe.thrust_n,
        gravity=G0,
    )


def air_data(state: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return total speed V_T [m/s], alpha [rad] and beta [rad] (eqs. 14-16).

    ``alpha = arctan(w / u)`` is evaluated with ``arctan2`` (equal for u > 0).
    """
    u, v, w = state[..., U], state[..., V], state[..., W]
    speed = np.sqrt(u * u + v * v + w * w)
    return speed, np.arctan2(w, u), np.arcsin(v / speed)


def regressors(state: np.ndarray, delta: np.ndarray | float, const: Constants) -> np.ndarray:
    """Return the aerodynamic regressors: forces and moments are linear in the coefficients.

    ``FM[..., i] = sum_j X[..., i, j] * C[..., j]`` with ``X`` of shape ``(..., 6, 9)``:
    every force and moment of eqs. 2-7 is linear in the nine coefficients (notes,
    "EBM first step"), so this matrix serves the simulator, the EBM second step and the
    closed-form equation-error fits alike.

    Parameters
    ----------
    state : ndarray, shape (..., 9)
    delta : ndarray or float, broadcastable to ``state.shape[:-1]`` [rad]
    const : Constants
    """
    speed, alpha, beta = air_data(state)
    qbar_s = 0.5 * const.rho * speed * speed * const.area
    qbar_sd = qbar_s * const.diameter
    k = const.diameter / (2.0 * speed)
    delta = np.broadcast_to(np.asarray(delta, dtype=float), speed.shape)
    X = np.zeros((*speed.shape, 6, 9))
    X[..., 0, CX] = qbar_s
    X[..., 1, CZA] = qbar_s * beta
    X[..., 1, CZQ] = -qbar_s * k * state[..., R]
    X[..., 2, CZA] = qbar_s * alpha
    X[..., 2, CZD] = qbar_s * delta
    X[..., 2, CZQ] = qbar_s * k * state[..., Q]
    X[..., 3, CL0] = qbar_sd
    X[..., 3, CLP] = qbar_sd * k * state[..., P]
    X[..., 4, CMA] = qbar_sd * alpha
    X[..., 4, CMD] = qbar_sd * delta
    X[..., 4, CMQ] = qbar_sd * k * state[..., Q]
    X[..., 5, CMA] = -qbar_sd * beta
    X[..., 5, CMQ] = qbar_sd * k * state[..., R]
    return X


def aero_forces_moments(
    state: np.ndarray, delta: np.ndarray | float, coefficients: np.ndarray, const: Constants
) -> np.ndarray:
    """Return aerodynamic forces and moments, shape (..., 6) [N, N m] (eqs. 2-7).

    ``F_AX = Q S Cx``; ``F_AY = Q S (Cza beta - Czq D/(2V) r)``;
    ``F_AZ = Q S (Cza alpha + Czd delta + Czq D/(2V) q)``; ``M_X = Q S D (Cl0 + Clp D/(2V) p)``;
    ``M_Y = Q S D (Cma alpha + Cmd delta + Cmq D/(2V) q)``;
    ``M_Z = Q S D (-Cma beta + Cmq D/(2V) r)``.
    """
    speed, alpha, beta = air_data(state)
    c = np.asarray(coefficients, dtype=float)
    qs = 0.5 * const.rho * speed * speed * const.area
    qsd = qs * const.diameter
    k = const.diameter / (2.0 * speed)
    p, q, r = state[..., P], state[..., Q], state[..., R]
    fm = np.empty(np.broadcast_shapes(speed.shape, c.shape[:-1], np.shape(delta)) + (6,))
    fm[..., 0] = qs * c[..., CX]
    fm[..., 1] = qs * (c[..., CZA] * beta - c[..., CZQ] * k * r)
    fm[..., 2] = qs * (c[..., CZA] * alpha + c[..., CZD] * delta + c[..., CZQ] * k * q)
    fm[..., 3] = qsd * (c[..., CL0] + c[..., CLP] * k * p)
    fm[..., 4] = qsd * (c[..., CMA] * alpha + c[..., CMD] * delta + c[..., CMQ] * k * q)
    fm[..., 5] = qsd * (-c[..., CMA] * beta + c[..., CMQ] * k * r)
    return fm


def derivative_from_forces(state: np.ndarray, fm: np.ndarray, const: Constants) -> np.ndarray:
    """Return d(state)/dt, shape (..., 9), from aerodynamic forces and moments (eqs. 2-10)."""
    u, v, w = state[..., U], state[..., V], state[..., W]
    p, q, r = state[..., P], state[..., Q], state[..., R]
    phi, theta = state[..., PHI], state[..., THETA]
    g = const.gravity
    sphi, cphi = np.sin(phi), np.cos(phi)
    sth, cth = np.sin(theta), np.cos(theta)
    out = np.empty(np.broadcast_shapes(state.shape, fm.shape[:-1] + (9,)))
    out[..., U] = r * v - q * w - g * sth + (fm[..., 0] + const.thrust) / const.mass
    out[..., V] = -r * u + p * w + g * cth * sphi + fm[..., 1] / const.mass
    out[..., W] = q * u - p * v + g * cth * cphi + fm[..., 2] / const.mass
    out[..., P] = fm[..., 3] / const.ix
    out[..., Q] = (const.iz - const.ix) / const.iy * p * r + fm[..., 4] / const.iy
    out[..., R] = (const.ix - const.iy) / const.iz * p * q + fm[..., 5] / const.iz
    out[..., PHI] = p + (q * sphi + r * cphi) * sth / cth
    out[..., THETA] = q * cphi - r * sphi
    out[..., PSI] = (q * sphi + r * cphi) / cth
    return out


def state_derivative(
    state: np.ndarray, delta: np.ndarray | float, coefficients: np.ndarray, const: Constants
) -> np.ndarray:
    """Return d(state)/dt, shape (..., 9), for fin deflection ``delta`` [rad] (eqs. 2-10).

    Note eq. 5 has no ``(Iy - Iz) q r`` term: the paper's model, exact for Iy = Iz.
    """
    return derivative_from_forces(state, aero_forces_moments(state, delta, coefficients, const),
                                  const)


def lever_arm_acceleration(
    specific_force: np.ndarray, omega: np.ndarray, omega_dot: np.ndarray, position: np.ndarray
) -> np.ndarray:
    """Return ``f + wdot x R + w x (w x R)`` (eq. 28), shape (..., 3) [m/s^2].

    Parameters
    ----------
    specific_force : ndarray, shape (..., 3)
        ``(F_A + F_T) / m`` [m/s^2].
    omega, omega_dot : ndarray, shape (..., 3)
        Body rates [rad/s] and their derivatives [rad/s^2].
    position : ndarray, shape (..., 3) or (3,)
        Sensor position from the c.g. [m].
    """
    position = np.broadcast_to(np.asarray(position, dtype=float), omega.shape)
    return (specific_force + np.cross(omega_dot, position)
            + np.cross(omega, np.cross(omega, position)))


def accelerometers(
    state: np.ndarray,
    delta: np.ndarray | float,
    coefficients: np.ndarray,
    const: Constants,
    positions: np.ndarray,
) -> np.ndarray:
    """Return the readings of accelerometer triads, shape (..., n_triads, 3) [m/s^2].

    Parameters
    ----------
    state : ndarray, shape (..., 9)
    delta : ndarray or float [rad]
    coefficients : ndarray, shape (..., 9)
    const : Constants
    positions : ndarray, shape (n_triads, 3)
        Triad positions from the c.g. [m].
    """
    fm = aero_forces_moments(state, delta, coefficients, const)
    xdot = derivative_from_forces(state, fm, const)
    force = fm[..., :3].copy()
    force[..., 0] += const.thrust
    specific = force / const.mass
    omega = state[..., [P, Q, R]]
    omega_dot = xdot[..., [P, Q, R]]
    positions = np.asarray(positions, dtype=float)
    return np.stack(
        [lever_arm_acceleration(specific, omega, omega_dot, pos) for pos in positions], axis=-2
    )
