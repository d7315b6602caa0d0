"""Compiled RK4 of aeroid's equations with a time-resolved fin input (prototype kernel).

The right-hand side is eqs. 2-10 exactly as :func:`aeroid.model.state_derivative` writes
them (a test compares the two to 1e-12), with the density and gravity interpolated
linearly between samples at every RK4 stage. Two input modes:

* events (``mode = 0``): the deflection is piecewise constant with switches at
  ``event_t`` (values ``event_v`` after each, ``delta0`` before the first); an RK4 step
  that contains a switch is split at it.
* law (``mode = 1``): ``delta = dmax sign(sin 2 phi + A sin(phi + phi0))`` on the
  trajectory's own roll angle; when the switching function changes sign over a step
  the crossing is located by bisection on the cubic Hermite interpolant of phi
  (values and derivatives at both ends) and the step is redone in two parts.
"""

from __future__ import annotations

import math

import numba
import numpy as np

#: Bisection iterations for a switch inside a step (step / 2^50: below rounding).
BISECTIONS = 50


@numba.njit(cache=True, fastmath=False)
def _interp(values, t0, dt, t):
    """Linear interpolation of uniformly sampled ``values`` at ``t`` (clamped)."""
    s = (t - t0) / dt
    n = values.shape[0]
    if s <= 0.0:
        return values[0]
    if s >= n - 1:
        return values[n - 1]
    k = int(math.floor(s))
    f = s - k
    return values[k] * (1.0 - f) + values[k + 1] * f


@numba.njit(cache=True, fastmath=False)
def derivative(x, delta, th, rho, g, cst, out):
    """Eqs. 2-10 into ``out`` (9,); ``cst = (S, D, m, Ix, Iy, Iz, thrust)``."""
    area, diam, mass, ix, iy, iz, thrust = cst[0], cst[1], cst[2], cst[3], cst[4], cst[5], cst[6]
    u, v, w, p, q, r, phi, theta = x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7]
    speed = math.sqrt(u * u + v * v + w * w)
    alpha = math.atan2(w, u)
    beta = math.asin(v / speed)
    qs = 0.5 * rho * speed * speed * area
    qsd = qs * diam
    k = diam / (2.0 * speed)
    fx = qs * th[0]
    fy = qs * (th[1] * beta - th[3] * k * r)
    fz = qs * (th[1] * alpha + th[2] * delta + th[3] * k * q)
    mx = qsd * (th[4] + th[5] * k * p)
    my = qsd * (th[6] * alpha + th[7] * delta + th[8] * k * q)
    mz = qsd * (-th[6] * beta + th[8] * k * r)
    sphi, cphi = math.sin(phi), math.cos(phi)
    sth, cth = math.sin(theta), math.cos(theta)
    out[0] = r * v - q * w - g * sth + (fx + thrust) / mass
    out[1] = -r * u + p * w + g * cth * sphi + fy / mass
    out[2] = q * u - p * v + g * cth * cphi + fz / mass
    out[3] = mx / ix
    out[4] = (iz - ix) / iy * p * r + my / iy
    out[5] = (ix - iy) / iz * p * q + mz / iz
    out[6] = p + (q * sphi + r * cphi) * sth / cth
    out[7] = q * cphi - r * sphi
    out[8] = (q * sphi + r * cphi) / cth


@numba.njit(cache=True, fastmath=False)
def _rk4(x, delta, th, cst, rho_s, g_s, t0s, dts, ta, h, out):
    k1 = np.empty(9)
    k2 = np.empty(9)
    k3 = np.empty(9)
    k4 = np.empty(9)
    tmp = np.empty(9)
    derivative(x, delta, th, _interp(rho_s, t0s, dts, ta), _interp(g_s, t0s, dts, ta), cst, k1)
    tm = ta + 0.5 * h
    rho_m, g_m = _interp(rho_s, t0s, dts, tm), _interp(g_s, t0s, dts, tm)
    for i in range(9):
        tmp[i] = x[i] + 0.5 * h * k1[i]
    derivative(tmp, delta, th, rho_m, g_m, cst, k2)
    for i in range(9):
        tmp[i] = x[i] + 0.5 * h * k2[i]
    derivative(tmp, delta, th, rho_m, g_m, cst, k3)
    for i in range(9):
        tmp[i] = x[i] + h * k3[i]
    tb = ta + h
    derivative(tmp, delta, th, _interp(rho_s, t0s, dts, tb), _interp(g_s, t0s, dts, tb), cst,
               k4)
    for i in range(9):
        out[i] = x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@numba.njit(cache=True, fastmath=False)
def _switching(phi, amp, phase):
    return math.sin(2.0 * phi) + amp * math.sin(phi + phase)


@numba.njit(cache=True, fastmath=False)
def _crossing(x, nxt, delta, th, cst, rho_s, g_s, t0s, dts, ta, h, amp, phase, sign0):
    """Time in (ta, ta + h) where the switching function leaves the sign ``sign0``."""
    fa = np.empty(9)
    fb = np.empty(9)
    derivative(x, delta, th, _interp(rho_s, t0s, dts, ta), _interp(g_s, t0s, dts, ta), cst, fa)
    derivative(nxt, delta, th, _interp(rho_s, t0s, dts, ta + h),
               _interp(g_s, t0s, dts, ta + h), cst, fb)
    pa, pb, da, db = x[6], nxt[6], h * fa[6], h * fb[6]
    lo, hi = 0.0, 1.0
    for _ in range(BISECTIONS):
        s = 0.5 * (lo + hi)
        phi = ((2 * s**3 - 3 * s**2 + 1) * pa + (s**3 - 2 * s**2 + s) * da
               + (-2 * s**3 + 3 * s**2) * pb + (s**3 - s**2) * db)
        if (_switching(phi, amp, phase) >= 0.0) == sign0:
            lo = s
        else:
            hi = s
    return ta + 0.5 * (lo + hi) * h


@numba.njit(cache=True, fastmath=False)
def integrate(x0, theta, cst, t0, dt, n, substeps, rho_s, g_s, mode, event_t, event_v,
              delta0, law):
    """Integrate B trajectories over ``n`` samples.

    Parameters
    ----------
    x0, theta : ndarray, shape (B, 9)
    cst : ndarray, shape (7,)
        ``S, D, m, Ix, Iy, Iz, thrust`` (SI).
    t0, dt : float
        First sample time and sample interval [s].
    n, substeps : int
    rho_s, g_s : ndarray, shape (n,)
        Density and gravity at the samples.
    mode : int
        0 events, 1 law.
    event_t, event_v : ndarray, shape (m,)
        Sorted switch instants [s] and the deflection after each [rad]: every switch
        (events), or those before the law's first delayed switch can act (law with a
        delay: ``t < t0 + delay``).
    delta0 : float
        Deflection at ``t0`` before any event at ``t0`` (events; law with a delay).
    law : ndarray, shape (4,)
        ``A, phi0 [rad], dmax [rad], delay [s]`` (law): a zero of the switching function
        at ``t_c`` switches the deflection at ``t_c + delay``.

    Returns
    -------
    states : ndarray, shape (B, n, 9)
    deltas : ndarray, shape (B, n)
        The deflection at each sample (a switch exactly at the sample counts as done).
    """
    batch = x0.shape[0]
    states = np.empty((batch, n, 9))
    deltas = np.empty((batch, n))
    h = dt / substeps
    m = event_t.shape[0]
    amp, phase, dmax, tau = law[0], law[1], law[2], law[3]
    cap = m + 4 * n * substeps + 16
    for b in range(batch):
        x = x0[b].copy()
        nxt = np.empty(9)
        th = theta[b]
        queue_t = np.empty(cap)
        queue_v = np.empty(cap)
        queue_t[:m] = event_t
        queue_v[:m] = event_v
        head, tail = 0, m
        delta = delta0
        sign = _switching(x[6], amp, phase) >= 0.0
        if mode == 1 and tau == 0.0:
            delta = dmax if sign else -dmax
        while head < tail and queue_t[head] <= t0:
            delta = queue_v[head]
            head += 1
        last_cross = -np.inf
        for k in range(n):
            states[b, k] = x
            deltas[b, k] = delta
            if k == n - 1:
                break
            for j in range(substeps):
                t = t0 + k * dt + j * h
                tb = t0 + k * dt + (j + 1) * h if j < substeps - 1 else t0 + (k + 1) * dt
                while t < tb:
                    t_next = tb
                    if head < tail and queue_t[head] < t_next:
                        t_next = queue_t[head]
                    _rk4(x, delta, th, cst, rho_s, g_s, t0, dt, t, t_next - t, nxt)
                    if mode == 1 and t_next > last_cross:
                        s1 = _switching(nxt[6], amp, phase) >= 0.0
                        if s1 != sign:
                            t_c = _crossing(x, nxt, delta, th, cst, rho_s, g_s, t0, dt, t,
                                            t_next - t, amp, phase, sign)
                            sign = s1
                            last_cross = t_c
                            queue_t[tail] = t_c + tau
                            queue_v[tail] = dmax if s1 else -dmax
                            tail += 1
                            if t_c + tau < t_next:
                                continue  # redo the piece up to the switch
                    x[:] = nxt
                    t = t_next
                    while head < tail and queue_t[head] <= t:
                        delta = queue_v[head]
                        head += 1
    return states, deltas
