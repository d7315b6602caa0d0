"""The equations of the rolling airframe, written once (paper eqs. 2-16 and 28).

Every function here is element-wise and indexes states, coefficients and constants by
name, so the same definition is evaluated three ways:

* by numpy on arrays (any broadcastable shapes; :mod:`aeroid.model._dynamics` stacks the
  results into ``(..., len(fields))`` arrays);
* by numba on scalars, inlined into the RK4 and cost kernels
  (:mod:`aeroid.model._compiled` registers each function as a numba overload of itself);
* by CasADi on symbols, to build exact derivatives (:mod:`aeroid.model._symbolic`; numpy's
  element-wise functions dispatch to CasADi objects in CasADi's numpy mode).

So the functions use only arithmetic and numpy's element-wise functions (no branches, no
array indexing), except :func:`outputs`, which assembles the output vector with the few
array operations all three share. Two hooks let the compiled kernels take faster paths
without copying an equation: :func:`atan2` (numba evaluates ``atan(y/x)`` for
``x > 0``, the same value) and the attitude trigonometry, which the rigid-body functions
take as arguments (:class:`Trig`) so a kernel can get it by the addition theorem instead
of calling sin/cos.

Model (notes, "Model"): body axes, flat non-rotating earth, cruciform airframe
with no products of inertia, thrust on body +x through the c.g.; the lateral coefficients
follow the symmetry ties of eq. 1 and the side force has no fin term (one fin pair acts in
pitch only). Eq. 5 has no ``(Iy - Iz) q r`` term: the paper's model, exact for Iy = Iz.
The air may move (issue 26): the loads see the air-relative velocity, the body velocity
minus the wind (NED components, :class:`Constants` ``wind_n, wind_e, wind_d``) rotated into
body axes by the attitude (:func:`air_velocity`); the states stay inertial. Zero wind is
the paper's still air, to the bit (a third hook: the kernels skip the rotation then).

Adding a coefficient or an input is one change here (and its name in
:mod:`aeroid.model._coefficients` or :class:`Constants`); README, "How to add a
coefficient or an input".
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

Scalar = Any  # a float, an ndarray or a CasADi symbol: everything here is element-wise


class State(NamedTuple):
    """The states [m/s, rad/s, rad]; the order is :data:`STATE_NAMES`."""

    u: Scalar
    v: Scalar
    w: Scalar
    p: Scalar
    q: Scalar
    r: Scalar
    phi: Scalar
    theta: Scalar
    psi: Scalar


class Coefficients(NamedTuple):
    """The aerodynamic coefficients (dimensionless); the order is ``NAMES``.

    Every count of coefficients in aeroid is the number of these fields.
    """

    Cx: Scalar
    Cza: Scalar
    Czd: Scalar
    Czq: Scalar
    Cl0: Scalar
    Clp: Scalar
    Cma: Scalar
    Cmd: Scalar
    Cmq: Scalar


class Constants(NamedTuple):
    """Physical constants of the model (a tuple of floats, so compiled kernels take it).

    ``rho`` air density [kg/m^3], ``area`` reference area S [m^2], ``diameter`` reference
    length D [m], ``mass`` [kg], principal inertias ``ix, iy, iz`` [kg m^2], ``thrust`` [N]
    along body +x, ``gravity`` [m/s^2]; the wind ``wind_n, wind_e, wind_d`` [m/s], the
    air's velocity over the ground in north-east-down axes (default 0: still air; given
    per sample, a gust: :data:`aeroid.model.EXOGENOUS`); ``temperature`` the air
    temperature [K], read only by Mach tables that take a per-sample temperature
    (:class:`aeroid.model.MachTables` ``per_sample_temperature``; default 0: not given).
    """

    rho: Scalar
    area: Scalar
    diameter: Scalar
    mass: Scalar
    ix: Scalar
    iy: Scalar
    iz: Scalar
    thrust: Scalar
    gravity: Scalar
    wind_n: Scalar = 0.0
    wind_e: Scalar = 0.0
    wind_d: Scalar = 0.0
    temperature: Scalar = 0.0


class Loads(NamedTuple):
    """Aerodynamic forces [N] and moments [N m] in body axes (eqs. 2-7)."""

    fax: Scalar
    fay: Scalar
    faz: Scalar
    mx: Scalar
    my: Scalar
    mz: Scalar


class Trig(NamedTuple):
    """Sines and cosines of the roll and pitch angles (the kernels' hook)."""

    sphi: Scalar
    cphi: Scalar
    stheta: Scalar
    ctheta: Scalar


STATE_NAMES: tuple[str, ...] = State._fields
LOAD_NAMES: tuple[str, ...] = ("FAX", "FAY", "FAZ", "MX", "MY", "MZ")


def atan2(y: Scalar, x: Scalar) -> Scalar:
    """Return the four-quadrant arctangent of ``y / x`` (a hook: see the module docstring)."""
    return np.arctan2(y, x)


def air_data(u: Scalar, v: Scalar, w: Scalar) -> tuple[Scalar, Scalar, Scalar]:
    """Return total speed V_T [m/s], alpha [rad] and beta [rad] (eqs. 14-16).

    ``alpha = arctan(w / u)`` is evaluated four-quadrant (equal for u > 0);
    ``beta = arcsin(v / V_T)``.
    """
    speed = np.sqrt(u * u + v * v + w * w)
    return speed, atan2(w, u), np.arcsin(v / speed)


def ned_to_body(phi: Scalar, theta: Scalar, psi: Scalar, north: Scalar, east: Scalar,
                down: Scalar) -> tuple[Scalar, Scalar, Scalar]:
    """Return a north-east-down vector in body axes (yaw ``psi``, pitch, roll: 3-2-1 Euler).

    The rows of the direction-cosine matrix ``[[c th c psi, c th s psi, -s th], ...]``
    applied as the three elementary rotations in turn.
    """
    spsi, cpsi = np.sin(psi), np.cos(psi)
    sth, cth = np.sin(theta), np.cos(theta)
    sphi, cphi = np.sin(phi), np.cos(phi)
    x1 = cpsi * north + spsi * east  # after the yaw rotation
    y1 = cpsi * east - spsi * north
    z2 = sth * x1 + cth * down  # after the pitch rotation
    return cth * x1 - sth * down, cphi * y1 + sphi * z2, cphi * z2 - sphi * y1


def wind_body(x: State, const: Constants) -> tuple[Scalar, Scalar, Scalar]:
    """Return the wind in body axes [m/s] (a hook: the kernels give zeros in still air)."""
    return ned_to_body(x.phi, x.theta, x.psi, const.wind_n, const.wind_e, const.wind_d)


def still_air_wind_body(x: State, const: Constants) -> tuple[Scalar, Scalar, Scalar]:
    """:func:`wind_body` for the compiled kernels (:data:`KERNEL_HOOKS`): in still air the
    zeros the rotation would give, without six sin/cos per RK4 stage (numba only: a branch)."""
    if const.wind_n == 0.0 and const.wind_e == 0.0 and const.wind_d == 0.0:
        return 0.0, 0.0, 0.0
    return ned_to_body(x.phi, x.theta, x.psi, const.wind_n, const.wind_e, const.wind_d)


def air_velocity(x: State, const: Constants) -> tuple[Scalar, Scalar, Scalar]:
    """Return the air-relative velocity in body axes [m/s]: ``(u, v, w)`` minus the wind."""
    wx, wy, wz = wind_body(x, const)
    return x.u - wx, x.v - wy, x.w - wz


def trig(x: State) -> Trig:
    """Return the attitude trigonometry of state ``x`` with sin and cos."""
    return Trig(np.sin(x.phi), np.cos(x.phi), np.sin(x.theta), np.cos(x.theta))


def aerodynamic_loads(x: State, c: Coefficients, delta: Scalar, const: Constants) -> Loads:
    """Return the aerodynamic forces and moments (eqs. 2-7).

    ``F_AX = Q S Cx``; ``F_AY = Q S (Cza beta - Czq D/(2V) r)``;
    ``F_AZ = Q S (Cza alpha + Czd delta + Czq D/(2V) q)``;
    ``M_X = Q S D (Cl0 + Clp D/(2V) p)``;
    ``M_Y = Q S D (Cma alpha + Cmd delta + Cmq D/(2V) q)``;
    ``M_Z = Q S D (-Cma beta + Cmq D/(2V) r)``, with ``Q = rho V^2 / 2`` and ``delta`` the
    fin deflection [rad]. Every load is linear in the coefficients. ``V``, alpha and
    beta are the air-relative ones (:func:`air_velocity`; the inertial ones in still air).
    """
    ua, va, wa = air_velocity(x, const)
    speed, alpha, beta = air_data(ua, va, wa)
    # Q S, with V^2 from the components (not the rounded square root)
    qs = 0.5 * const.rho * const.area * (ua * ua + va * va + wa * wa)
    qsd = qs * const.diameter
    rate_scale = 0.5 * const.diameter / speed  # D / (2 V)
    return Loads(
        qs * c.Cx,
        qs * (c.Cza * beta - c.Czq * rate_scale * x.r),
        qs * (c.Cza * alpha + c.Czd * delta + c.Czq * rate_scale * x.q),
        qsd * (c.Cl0 + c.Clp * rate_scale * x.p),
        qsd * (c.Cma * alpha + c.Cmd * delta + c.Cmq * rate_scale * x.q),
        qsd * (-c.Cma * beta + c.Cmq * rate_scale * x.r),
    )


def angular_acceleration(p: Scalar, q: Scalar, r: Scalar, f: Loads, const: Constants
                         ) -> tuple[Scalar, Scalar, Scalar]:
    """Return ``pdot, qdot, rdot`` [rad/s^2] (eqs. 5-7)."""
    return (f.mx / const.ix,
            (const.iz - const.ix) / const.iy * p * r + f.my / const.iy,
            (const.ix - const.iy) / const.iz * p * q + f.mz / const.iz)


def specific_force(f: Loads, const: Constants) -> tuple[Scalar, Scalar, Scalar]:
    """Return the specific force ``(F_A + F_T) / m`` [m/s^2] (no gravity: accelerometers see it)."""
    return (f.fax + const.thrust) / const.mass, f.fay / const.mass, f.faz / const.mass


def derivative(x: State, f: Loads, const: Constants, t: Trig) -> State:
    """Return d(state)/dt from the loads (eqs. 2-10).

    Eqs. 2-4 (translation, gravity along the earth z axis), 5-7 (rotation) and 8-10 (Euler
    angle kinematics).
    """
    fx, fy, fz = specific_force(f, const)
    pdot, qdot, rdot = angular_acceleration(x.p, x.q, x.r, f, const)
    g = const.gravity
    qr = x.q * t.sphi + x.r * t.cphi
    return State(
        x.r * x.v - x.q * x.w - g * t.stheta + fx,
        -x.r * x.u + x.p * x.w + g * t.ctheta * t.sphi + fy,
        x.q * x.u - x.p * x.v + g * t.ctheta * t.cphi + fz,
        pdot,
        qdot,
        rdot,
        x.p + qr * t.stheta / t.ctheta,
        x.q * t.cphi - x.r * t.sphi,
        qr / t.ctheta,
    )


def state_derivative(x: State, c: Coefficients, delta: Scalar, const: Constants, t: Trig
                     ) -> State:
    """Return d(state)/dt for coefficients ``c`` and fin deflection ``delta`` [rad]."""
    return derivative(x, aerodynamic_loads(x, c, delta, const), const, t)


def accelerometer(x: State, f: Loads, const: Constants, rx: Scalar, ry: Scalar, rz: Scalar
                  ) -> tuple[Scalar, Scalar, Scalar]:
    """Return the reading of an accelerometer triad at ``(rx, ry, rz)`` [m] from the c.g. (eq. 28).

    ``a_R = (F_A + F_T) / m + wdot x R + w x (w x R)`` [m/s^2], with ``wdot`` from
    eqs. 5-7; accelerometers measure specific force (no gravity).
    """
    fx, fy, fz = specific_force(f, const)
    pdot, qdot, rdot = angular_acceleration(x.p, x.q, x.r, f, const)
    cx = x.q * rz - x.r * ry  # w x R
    cy = x.r * rx - x.p * rz
    cz = x.p * ry - x.q * rx
    return (fx + (qdot * rz - rdot * ry) + (x.q * cz - x.r * cy),
            fy + (rdot * rx - pdot * rz) + (x.r * cx - x.p * cz),
            fz + (pdot * ry - qdot * rx) + (x.p * cy - x.q * cx))


def rate_gyros(x: State) -> tuple[Scalar, Scalar, Scalar]:
    """Return the rate-gyro readings ``p, q, r`` [rad/s] (body rates, measured directly)."""
    return x.p, x.q, x.r


def output_names(n_triads: int) -> tuple[str, ...]:
    """Return the output channels of :func:`outputs`: ``ax1, ay1, az1, ...`` per triad, then
    the gyros, named by the states they read (``p, q, r``)."""
    return (tuple(f"a{axis}{j + 1}" for j in range(n_triads) for axis in "xyz")
            + tuple(rate_gyros(State(*STATE_NAMES))))


def outputs(out: Any, x: State, f: Loads, const: Constants, positions: Any) -> Any:
    """Write the model's outputs into ``out[0], out[1], ...`` and return ``out``.

    The output vector, written once: eq. 28 at each accelerometer triad, then the rate
    gyros (columns :func:`output_names`). ``positions`` holds the triad positions from the
    c.g. [m], ``positions[j, 0..2]`` for triad ``j`` (an (n_triads, 3) array, or
    (n_triads, 3, ...) with per-evaluation positions); ``out`` takes ``out[k] = value``
    (a numpy array whose first axis is the channel, a numba scratch vector, a CasADi
    column). Unlike the functions above it indexes arrays, with operations numpy, numba
    and CasADi share (``shape[0]``, ``[j, i]``, item assignment).
    """
    k = 0
    for j in range(positions.shape[0]):
        for value in accelerometer(x, f, const, positions[j, 0], positions[j, 1],
                                   positions[j, 2]):
            out[k] = value
            k += 1
    for value in rate_gyros(x):
        out[k] = value
        k += 1
    return out


#: The compiled kernels' implementation of some functions above (the same values).
KERNEL_HOOKS: dict[Any, Any] = {wind_body: still_air_wind_body}
#: The element-wise functions above, in dependency order (the compiled layer registers
#: each as a numba overload of itself, and :func:`outputs` too; :func:`atan2` gets its
#: fast implementation there, :func:`wind_body` its still-air shortcut).
ELEMENT_WISE = (atan2, air_data, ned_to_body, wind_body, air_velocity, trig, aerodynamic_loads,
                angular_acceleration, specific_force, derivative, state_derivative, accelerometer,
                rate_gyros)
