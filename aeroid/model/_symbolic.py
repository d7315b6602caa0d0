"""The airframe model written once in CasADi form, for exact Jacobians (private).

The equations are those of :mod:`aeroid.model` (eqs. 2-10, 14-16) and of
:func:`aeroid.flights.accelerometers` (eq. 28), written with operations that work on
CasADi ``SX``/``MX`` symbols (and on floats). Tests check that these functions equal
aeroid's numpy model (:func:`aeroid.state_derivative`, :func:`aeroid.propagate`,
:func:`aeroid.accelerometers`) to rounding, so the baselines fit exactly the model the
simulator integrates.

Built CasADi functions are cached per (constants, dt, substeps) with
:func:`functools.lru_cache`, so repeated fits on flights of the same airframe and sample
interval never rebuild them. :func:`compile_functions` turns CasADi functions into C
(CasADi code generation), compiles them with the system C compiler and caches the shared
library on disk.
"""

from __future__ import annotations

import functools
import hashlib
import os
import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from pathlib import Path

import casadi as ca

from aeroid.model._dynamics import Constants

#: Measurement layout of every baseline: both triads, then the body rates (section 4.3).
MEASUREMENT_NAMES: tuple[str, ...] = ("ax1", "ay1", "az1", "ax2", "ay2", "az2", "p", "q", "r")
N_MEASUREMENTS = 9
N_STATE = 9
N_COEF = 9


def rhs(x, delta, theta, const: Constants):
    """Return d(state)/dt and the aerodynamic forces/moments (eqs. 2-10), CasADi-compatible.

    Parameters
    ----------
    x : casadi SX/MX or sequence, length 9
        ``[u, v, w, p, q, r, phi, theta, psi]`` [m/s, rad/s, rad].
    delta : scalar symbol or float
        Fin deflection [rad].
    theta : casadi SX/MX or sequence, length 9
        Coefficients in ``aeroid.NAMES`` order.
    const : Constants

    Returns
    -------
    xdot : casadi vector (9,)
    fm : list of 6 expressions
        ``F_AX, F_AY, F_AZ`` [N], ``M_X, M_Y, M_Z`` [N m].
    """
    u, v, w, p, q, r, phi, th = (x[i] for i in range(8))
    c = [theta[i] for i in range(9)]
    speed = ca.sqrt(u * u + v * v + w * w)
    alpha = ca.atan2(w, u)
    beta = ca.asin(v / speed)
    qs = 0.5 * const.rho * speed * speed * const.area
    qsd = qs * const.diameter
    k = const.diameter / (2.0 * speed)
    fax = qs * c[0]
    fay = qs * (c[1] * beta - c[3] * k * r)
    faz = qs * (c[1] * alpha + c[2] * delta + c[3] * k * q)
    mx = qsd * (c[4] + c[5] * k * p)
    my = qsd * (c[6] * alpha + c[7] * delta + c[8] * k * q)
    mz = qsd * (-c[6] * beta + c[8] * k * r)
    g = const.gravity
    sphi, cphi = ca.sin(phi), ca.cos(phi)
    sth, cth = ca.sin(th), ca.cos(th)
    xdot = ca.vertcat(
        r * v - q * w - g * sth + (fax + const.thrust) / const.mass,
        -r * u + p * w + g * cth * sphi + fay / const.mass,
        q * u - p * v + g * cth * cphi + faz / const.mass,
        mx / const.ix,
        (const.iz - const.ix) / const.iy * p * r + my / const.iy,
        (const.ix - const.iy) / const.iz * p * q + mz / const.iz,
        p + (q * sphi + r * cphi) * sth / cth,
        q * cphi - r * sphi,
        (q * sphi + r * cphi) / cth,
    )
    return xdot, [fax, fay, faz, mx, my, mz]


def measurement(x, delta, theta, positions, const: Constants):
    """Return the nine measurements ``[a1 (3), a2 (3), p, q, r]`` (eq. 28), CasADi-compatible.

    ``a_R = (F_A + F_T) / m + wdot x R + w x (w x R)`` at each triad position ``R``.

    Parameters
    ----------
    x, delta, theta, const
        As in :func:`rhs`.
    positions : casadi vector of length 6 or sequence
        ``[x1, y1, z1, x2, y2, z2]`` triad positions from the c.g. [m].
    """
    xdot, fm = rhs(x, delta, theta, const)
    p, q, r = x[3], x[4], x[5]
    pd, qd, rd = xdot[3], xdot[4], xdot[5]
    fx = (fm[0] + const.thrust) / const.mass
    fy = fm[1] / const.mass
    fz = fm[2] / const.mass
    out = []
    for j in range(2):
        rx, ry, rz = positions[3 * j], positions[3 * j + 1], positions[3 * j + 2]
        # w x R
        cx, cy, cz = q * rz - r * ry, r * rx - p * rz, p * ry - q * rx
        out += [
            fx + (qd * rz - rd * ry) + (q * cz - r * cy),
            fy + (rd * rx - pd * rz) + (r * cx - p * cz),
            fz + (pd * ry - qd * rx) + (p * cy - q * cx),
        ]
    return ca.vertcat(*out, p, q, r)


def rk4_step(x, delta, theta, const: Constants, dt: float, substeps: int):
    """Return the state after ``substeps`` RK4 steps of ``dt / substeps`` with ``delta`` held.

    The same scheme as :func:`aeroid.model.propagate` (zero-order hold of ``delta``
    over the sample interval).
    """
    h = dt / substeps
    for _ in range(substeps):
        k1 = rhs(x, delta, theta, const)[0]
        k2 = rhs(x + 0.5 * h * k1, delta, theta, const)[0]
        k3 = rhs(x + 0.5 * h * k2, delta, theta, const)[0]
        k4 = rhs(x + h * k3, delta, theta, const)[0]
        x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return x


@functools.lru_cache(maxsize=32)
def step_function(const: Constants, dt: float, substeps: int) -> ca.Function:
    """Return the CasADi Function ``step(x (9), theta (9), delta) -> x_next (9)``."""
    x = ca.SX.sym("x", N_STATE)
    theta = ca.SX.sym("theta", N_COEF)
    delta = ca.SX.sym("delta")
    return ca.Function("step", [x, theta, delta],
                       [rk4_step(x, delta, theta, const, dt, substeps)],
                       ["x", "theta", "delta"], ["x_next"])


@functools.lru_cache(maxsize=32)
def measurement_function(const: Constants) -> ca.Function:
    """Return the CasADi Function ``meas(x (9), theta (9), delta, positions (6)) -> y (9)``."""
    x = ca.SX.sym("x", N_STATE)
    theta = ca.SX.sym("theta", N_COEF)
    delta = ca.SX.sym("delta")
    pos = ca.SX.sym("pos", 6)
    return ca.Function("meas", [x, theta, delta, pos],
                       [measurement(x, delta, theta, pos, const)],
                       ["x", "theta", "delta", "pos"], ["y"])


@functools.lru_cache(maxsize=32)
def augmented_functions(const: Constants, dt: float, substeps: int) -> tuple[ca.Function, ...]:
    """Return the augmented-state (18) model of the Kalman filters with exact Jacobians.

    The augmented state is ``z = [x (9), theta (9)]`` with constant coefficients.

    Returns
    -------
    f : Function ``(z (18), delta) -> (z_next (18), F (18, 18))``
        RK4 transition and its Jacobian ``d z_next / d z`` (CasADi AD).
    h : Function ``(z (18), delta, positions (6)) -> (y (9), H (9, 18))``
        Measurement and its Jacobian.
    """
    z = ca.SX.sym("z", N_STATE + N_COEF)
    delta = ca.SX.sym("delta")
    pos = ca.SX.sym("pos", 6)
    x, theta = z[:N_STATE], z[N_STATE:]
    z_next = ca.vertcat(rk4_step(x, delta, theta, const, dt, substeps), theta)
    f = ca.Function("f_aug", [z, delta], [z_next, ca.jacobian(z_next, z)])
    y = measurement(x, delta, theta, pos, const)
    h = ca.Function("h_aug", [z, delta, pos], [y, ca.jacobian(y, z)])
    return f, h


#: Compiler flags of :func:`compile_functions` (-O1: a third less compile time than -O2
#: for the same speed within 20 % on the output-error sensitivities, measured).
C_FLAGS: tuple[str, ...] = ("-O1", "-fPIC", "-shared")


def cache_dir() -> Path:
    """Return the on-disk cache of compiled models: ``$AEROID_CASADI_CACHE`` or
    ``~/.cache/aeroid/casadi``."""
    env = os.environ.get("AEROID_CASADI_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "aeroid" / "casadi"


def compile_functions(functions: Sequence[ca.Function], name: str
                      ) -> list[ca.Function] | None:
    """Return compiled copies of ``functions`` (one shared library), or None if impossible.

    The C source from :class:`casadi.CodeGenerator` is hashed (with the compiler and
    flags); the library ``<name>_<hash>.so`` is looked up in :func:`cache_dir` and built
    there with ``$CC`` (else ``cc``/``gcc``) when absent: written to a temporary name and
    renamed, so concurrent processes do not see half-written files. Any failure (no
    compiler, compile error, unwritable cache) returns None and the caller keeps
    CasADi's virtual machine, which gives the same numbers.
    """
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not compiler:
        return None
    try:
        with tempfile.TemporaryDirectory() as tmp:
            gen = ca.CodeGenerator(f"{name}.c")
            for fun in functions:
                gen.add(fun)
            gen.generate(tmp + os.sep)
            source = Path(tmp, f"{name}.c").read_bytes()
        digest = hashlib.sha256(source + compiler.encode() + " ".join(C_FLAGS).encode())
        cache = cache_dir()
        library = cache / f"{name}_{digest.hexdigest()[:20]}.so"
        if not library.exists():
            cache.mkdir(parents=True, exist_ok=True)
            with tempfile.TemporaryDirectory(dir=cache) as tmp:
                src = Path(tmp, f"{name}.c")
                src.write_bytes(source)
                out = Path(tmp, library.name)
                subprocess.run([compiler, *C_FLAGS, str(src), "-o", str(out)], check=True,
                               capture_output=True, timeout=300)
                os.replace(out, library)
        return [ca.external(fun.name(), str(library)) for fun in functions]
    except (OSError, subprocess.SubprocessError, RuntimeError):
        return None
