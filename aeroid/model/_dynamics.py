"""The equations on numpy arrays: states (..., 9), coefficients (..., 9), loads (..., 6).

Thin array plumbing over :mod:`aeroid.model._equations` (the one definition): the last
axis is split into named fields, the element-wise equations are evaluated, and the
results are stacked back. Leading axes broadcast, so one call evaluates a whole swarm.

Array layouts (named once here): the state ``u, v, w`` [m/s], ``p, q, r`` [rad/s],
``phi, theta, psi`` [rad] (:data:`STATE_NAMES`, indices :data:`U` ... :data:`PSI`); the
aerodynamic loads ``F_AX, F_AY, F_AZ`` [N], ``M_X, M_Y, M_Z`` [N m] (:data:`FM_NAMES`);
the measured outputs of the two accelerometer triads and the rate gyros
(:data:`OUTPUT_CHANNELS`).
"""

from __future__ import annotations

import numpy as np

from aeroid.model import _equations as eq
from aeroid.model._airframe import Airframe
from aeroid.model._atmosphere import G0
from aeroid.model._coefficients import N_COEFFICIENTS
from aeroid.model._equations import Constants

STATE_NAMES: tuple[str, ...] = eq.STATE_NAMES
N_STATE = len(STATE_NAMES)
U, V, W, P, Q, R, PHI, THETA, PSI = range(N_STATE)
#: Aerodynamic force and moment layout.
FM_NAMES: tuple[str, ...] = eq.LOAD_NAMES
#: The measured outputs of the model (:func:`aeroid.model._equations.outputs`): both
#: triads of the flights' sensor layout, body x, y, z [m/s^2], then the body rates [rad/s].
OUTPUT_CHANNELS: tuple[str, ...] = eq.output_names(n_triads=2)
#: Rate-gyro channels [rad/s].
RATE_CHANNELS: tuple[str, ...] = tuple(eq.rate_gyros(eq.State(*STATE_NAMES)))
#: Accelerometer channels: triad 1 then triad 2, body x, y, z [m/s^2].
ACCEL_CHANNELS: tuple[str, ...] = OUTPUT_CHANNELS[:-len(RATE_CHANNELS)]


def constants(airframe: Airframe) -> Constants:
    """Return the model constants of ``airframe`` (its air density, standard gravity).

    With a per-sample atmosphere (``[atmosphere] per_sample``) the constant density is
    NaN: only the flight's per-sample values may be used (:mod:`aeroid.flights`), and a
    computation that forgot them fails instead of using a wrong density.
    """
    per_sample = getattr(airframe, "atmosphere_channel", None) is not None
    return Constants(
        rho=float("nan") if per_sample else airframe.density_kgm3,
        area=airframe.area_m2,
        diameter=airframe.diameter_m,
        mass=airframe.mass_kg,
        ix=airframe.ix_kgm2,
        iy=airframe.iy_kgm2,
        iz=airframe.iz_kgm2,
        thrust=airframe.thrust_n,
        gravity=G0,
    )


def as_state(state: np.ndarray) -> eq.State:
    """Return the named fields of ``state`` (..., 9) (views, no copy)."""
    state = np.asarray(state, dtype=float)
    return eq.State(*np.moveaxis(state, -1, 0))


def as_coefficients(coefficients: np.ndarray) -> eq.Coefficients:
    """Return the named fields of ``coefficients`` (..., 9) (views, no copy)."""
    coefficients = np.asarray(coefficients, dtype=float)
    return eq.Coefficients(*np.moveaxis(coefficients, -1, 0))


def _stack(fields: tuple) -> np.ndarray:
    return np.stack(np.broadcast_arrays(*fields), axis=-1)


def air_data(state: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return total speed V_T [m/s], alpha [rad] and beta [rad] of ``state`` (..., 9)."""
    x = as_state(state)
    return eq.air_data(x.u, x.v, x.w)


def aero_forces_moments(state: np.ndarray, delta: np.ndarray | float, coefficients: np.ndarray,
                        const: Constants) -> np.ndarray:
    """Return the aerodynamic forces and moments, shape (..., 6) [N, N m] (eqs. 2-7).

    Parameters
    ----------
    state : ndarray, shape (..., 9)
    delta : ndarray or float, broadcastable to ``state.shape[:-1]`` [rad]
    coefficients : ndarray, shape (..., 9)
    const : Constants
    """
    loads = eq.aerodynamic_loads(as_state(state), as_coefficients(coefficients),
                                 np.asarray(delta, dtype=float), const)
    return _stack(loads)


def regressors(state: np.ndarray, delta: np.ndarray | float, const: Constants) -> np.ndarray:
    """Return the regressors ``X`` (..., 6, 9): the loads are linear in the coefficients.

    ``FM[..., i] = sum_j X[..., i, j] * C[..., j]``. Column ``j`` is the loads evaluated
    with the unit coefficient vector ``e_j`` (eqs. 2-7 are linear in the coefficients), so
    this matrix is the same model as :func:`aero_forces_moments`, not a second writing of
    it. It serves the EBM second step and the equation-error fits.
    """
    x = as_state(np.asarray(state, dtype=float)[..., None, :])  # fields (..., 1)
    unit = eq.Coefficients(*np.eye(N_COEFFICIENTS))  # fields (9,)
    delta = np.asarray(delta, dtype=float)[..., None]
    # constants given per sample (array fields) get the coefficient axis too
    const = Constants(*(np.asarray(v, dtype=float)[..., None] if np.ndim(v) else v
                        for v in const))
    return np.stack(np.broadcast_arrays(*eq.aerodynamic_loads(x, unit, delta, const)), axis=-2)


def derivative_from_forces(state: np.ndarray, fm: np.ndarray, const: Constants) -> np.ndarray:
    """Return d(state)/dt, shape (..., 9), from aerodynamic loads ``fm`` (..., 6) (eqs. 2-10)."""
    x = as_state(state)
    loads = eq.Loads(*np.moveaxis(np.asarray(fm, dtype=float), -1, 0))
    return _stack(eq.derivative(x, loads, const, eq.trig(x)))


def state_derivative(state: np.ndarray, delta: np.ndarray | float, coefficients: np.ndarray,
                     const: Constants) -> np.ndarray:
    """Return d(state)/dt, shape (..., 9), for fin deflection ``delta`` [rad] (eqs. 2-10)."""
    x = as_state(state)
    return _stack(eq.state_derivative(x, as_coefficients(coefficients),
                                      np.asarray(delta, dtype=float), const, eq.trig(x)))


def accelerometers(state: np.ndarray, delta: np.ndarray | float, coefficients: np.ndarray,
                   const: Constants, positions: np.ndarray) -> np.ndarray:
    """Return the readings of accelerometer triads, shape (..., n_triads, 3) [m/s^2] (eq. 28).

    Parameters
    ----------
    state : ndarray, shape (..., 9)
    delta : ndarray or float [rad]
    coefficients : ndarray, shape (..., 9)
    const : Constants
    positions : ndarray, shape (n_triads, 3)
        Triad positions from the c.g. [m].
    """
    x = as_state(state)
    loads = eq.aerodynamic_loads(x, as_coefficients(coefficients),
                                 np.asarray(delta, dtype=float), const)
    positions = np.asarray(positions, dtype=float)
    return np.stack([_stack(eq.accelerometer(x, loads, const, *pos)) for pos in positions],
                    axis=-2)
