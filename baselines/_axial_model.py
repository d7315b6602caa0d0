"""The axial-drag method's model: a point mass with the model's axial force along the airspeed.

State ``(pn, pe, pd, vn, ve, vd)`` [m, m/s], NED over a flat earth, still air::

    d(position)/dt = velocity
    d(velocity)/dt = f_x(V, Cx(M)) velocity / V + (0, 0, g)

``f_x`` is the model's axial specific force, not written again here: a body whose x axis
lies along the airspeed (``u = V``, ``v = w = 0``, no rates) evaluated by
:func:`aeroid.model.equations.aerodynamic_loads` and
:func:`~aeroid.model.equations.specific_force` (``(Q S Cx + thrust) / m``), with Cx the
table :func:`aeroid.model.tables.table_value` at ``M = V / a``; the density and the speed
of sound are the airframe's constants, gravity the model's; the thrust and mass the
constants' or, with a motor (``propagate(..., motor=...)``), given at the grid's nodes and
linear between them within each RK4 step. The axial accelerometer reads
``(1 + scale) f_x + bias``. The accelerometer's lever arm is not in the model, and the
lateral aerodynamic force only as the **trim** of a statically stable airframe in a gravity
turn (optional): turning its nose at ``q = -g cos(gamma) / V`` needs an incidence
``alpha = -Cmq (D / 2V) q / Cma`` whose normal force ``Q S (Cza alpha + Czq (D / 2V) q)``
is ``k g cos(gamma)``, a constant share ``k = -rho S D (Czq - Cza Cmq / Cma) / (4 m)`` of
gravity's component normal to the path (-0.0196 for the rocket coast: the trim holds the
path up against gravity's turning, the nose above the path); ``k`` is a free
parameter (the trim factor), the normal force ``k (g - (g . v/V) v/V)``. The pitch and
yaw oscillation's normal force averages out; nothing else lateral is modelled: a
point-mass reduction, the range-test way (a "modified point mass" with its trim).

The graph is CasADi's, so the sensitivities of the states to the initial state and the
table points are exact: the RK4 step and its Jacobians give ``S_{k+1} = A_k S_k + B_k``
(the forward sensitivity recursion of the discrete map), accumulated in one CasADi call
(``mapaccum``) over the record's time grid.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import casadi as ca
import numpy as np

from aeroid.model import NAMES, Constants, equations, rk4_step, tables

__all__ = ["N_TRACK", "Track", "axial_force", "propagate"]

#: Point-mass states: position and velocity, NED.
PN, PE, PD, VN, VE, VD = range(6)
N_TRACK = 6


class Track(NamedTuple):
    """The integrated track and its sensitivities on a time grid.

    ``states`` (n, 6); ``sensitivity`` (n, 6, k + 6): d state / d (table points, initial
    state); ``force`` (n,) the axial specific force [m/s^2] and ``force_sensitivity``
    (n, k + 6) its total derivative.
    """

    states: np.ndarray
    sensitivity: np.ndarray
    force: np.ndarray
    force_sensitivity: np.ndarray


def _specific_force(velocity, points, const: Constants, knots: tuple[float, ...],
                    sound: float):
    """Return the model's axial specific force at the NED ``velocity`` (element-wise)."""
    speed = ca.sqrt(velocity[0] ** 2 + velocity[1] ** 2 + velocity[2] ** 2)
    cx = tables.table_value(tables.mach_number(speed, 0.0, 0.0, sound), knots,
                            [points[i] for i in range(len(knots))])
    state = equations.State(speed, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    coefficients = equations.Coefficients(*(cx if n == "Cx" else 0.0 for n in NAMES))
    loads = equations.aerodynamic_loads(state, coefficients, 0.0, const)
    return equations.specific_force(loads, const)[0], speed


@functools.lru_cache(maxsize=16)
def _functions(const: Constants, knots: tuple[float, ...], sound: float, n_steps: int,
               trim: bool, motor: bool = False) -> tuple[ca.Function, ca.Function]:
    k = len(knots) + int(trim)
    x = ca.SX.sym("x", N_TRACK)
    c = ca.SX.sym("c", k)
    dt = ca.SX.sym("dt")
    # a motor: thrust and mass at the step's two ends (linear between grid nodes, the
    # estimators' convention for per-sample inputs), else the constants' own
    ends = ca.SX.sym("ends", 4 if motor else 0)

    def at(tau):
        if not motor:
            return const
        share = tau / dt
        return const._replace(thrust=ends[0] + (ends[1] - ends[0]) * share,
                              mass=ends[2] + (ends[3] - ends[2]) * share)

    def rhs(z, tau=0.0):
        force, speed = _specific_force(z[VN:], c, at(tau), knots, sound)
        gravity = ca.vertcat(0.0, 0.0, const.gravity)
        along = z[VN:] / speed
        accel = force * along + gravity
        if trim:  # the trim's normal force: a share c[-1] of gravity's normal component
            accel += c[k - 1] * (gravity - ca.dot(gravity, along) * along)
        return ca.vertcat(z[VN:], accel)

    # the model's RK4, on CasADi too (tau: the time within the step)
    x_next = rk4_step(lambda tau, z: rhs(z, tau), 0.0, x, dt)
    sens = ca.SX.sym("s", N_TRACK, k + N_TRACK)
    s_next = ca.jacobian(x_next, x) @ sens + ca.horzcat(ca.jacobian(x_next, c),
                                                        ca.SX.zeros(N_TRACK, N_TRACK))
    z = ca.vertcat(x, ca.vec(sens))
    step = ca.Function("axial_step", [z, c, dt, ends], [ca.vertcat(x_next, ca.vec(s_next))])
    node = ca.SX.sym("node", 2 if motor else 0)  # thrust and mass at a grid node
    here = const._replace(thrust=node[0], mass=node[1]) if motor else const
    force, _ = _specific_force(x[VN:], c, here, knots, sound)
    grad = ca.horzcat(ca.jacobian(force, c), ca.SX.zeros(1, N_TRACK)) \
        + ca.jacobian(force, x) @ sens
    force_fn = ca.Function("axial_force", [z, c, node], [force, grad])
    return step.mapaccum("axial_track", n_steps), force_fn.map(n_steps + 1)


def propagate(x0: np.ndarray, points: np.ndarray, t: np.ndarray, const: Constants,
              knots: tuple[float, ...], sound: float, trim: bool = False,
              motor: tuple[np.ndarray, np.ndarray] | None = None) -> Track:
    """Integrate the point mass from ``x0`` at ``t[0]`` over the grid ``t`` (RK4, one step
    per interval) with the sensitivities to ``(points, x0)``.

    Parameters
    ----------
    x0 : ndarray, shape (6,)
        Initial position [m] and velocity [m/s], NED.
    points : ndarray, shape (k,) or (k + 1,)
        The Cx table's values at ``knots`` (one knot: a constant Cx), then with ``trim``
        the trim factor (module docstring).
    t : ndarray, shape (n,)
        Increasing times [s].
    const : Constants
        The model's constants (density, area, mass, thrust, gravity).
    knots : tuple of float
        The table's knots [Mach].
    sound : float
        Speed of sound [m/s].
    trim : bool
        Whether the trim's normal force is in the model (``points[-1]`` its factor).
    motor : pair of ndarray, shape (n,), optional
        Thrust [N] and mass [kg] at ``t`` (a thrust curve's), linear between them; None:
        the constants' ``thrust`` and ``mass``.
    """
    k = len(knots) + int(trim)
    n = len(t)
    z0 = np.concatenate([x0, np.column_stack([np.zeros((N_TRACK, k)),
                                              np.eye(N_TRACK)]).ravel(order="F")])
    track, force_fn = _functions(const, tuple(knots), float(sound), n - 1, bool(trim),
                                 motor is not None)
    if motor is None:
        ends, nodes = np.zeros((0, n - 1)), np.zeros((0, n))
    else:
        thrust, mass = (np.asarray(a, dtype=float) for a in motor)
        ends = np.vstack([thrust[:-1], thrust[1:], mass[:-1], mass[1:]])
        nodes = np.vstack([thrust, mass])
    out = np.array(track(z0, np.asarray(points, dtype=float), np.diff(t)[None, :], ends))
    z = np.column_stack([z0, out])  # (6 + 6 (k + 6), n)
    force, grad = force_fn(z, np.asarray(points, dtype=float), nodes)
    states = z[:N_TRACK].T
    sens = z[N_TRACK:].T.reshape(n, k + N_TRACK, N_TRACK).transpose(0, 2, 1)
    return Track(states, sens, np.array(force).ravel(), np.array(grad).reshape(n, k + N_TRACK))


def axial_force(velocity: np.ndarray, points: np.ndarray, const: Constants,
                knots: tuple[float, ...], sound: float) -> np.ndarray:
    """Return the axial specific force [m/s^2] at NED velocities (n, 3) (numpy; for tests)."""
    v = np.asarray(velocity, dtype=float)
    speed = np.sqrt(np.sum(v * v, axis=-1))
    cx = tables.table_value(tables.mach_number(speed, 0.0, 0.0, sound), knots, list(points))
    state = equations.State(speed, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    coefficients = equations.Coefficients(*(cx if n == "Cx" else 0.0 for n in NAMES))
    return equations.specific_force(equations.aerodynamic_loads(state, coefficients, 0.0,
                                                                const), const)[0]
