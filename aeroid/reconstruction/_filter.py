"""The extended Kalman filter and Rauch-Tung-Striebel smoother of the reconstruction.

Prediction: RK4 of :func:`~aeroid.reconstruction._kinematics.derivative` between IMU
samples (readings linear in between), covariance through ``F = exp(A dt)`` (fourth-order
series; ``|A dt|`` is about 0.05 at a 50 rad/s roll and 1 kHz) and the IMU's white noise
``Q = (dt B) diag(sd^2) (dt B)^T``, ``A, B`` the exact (complex-step) Jacobians.
Update: each aiding measurement at its own time ``t_m``, at the IMU sample ``k`` nearest
it, predicted as ``h(x_k + (t_m - t_k) f(x_k))`` (so a 100 Hz INS off the IMU's grid
costs no roll error at 50 rad/s), Joseph form; wrapped channels take the wrapped
innovation ``wrap(z - h)``. Smoother: RTS over the stored filter passes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from aeroid.errors import FlightError
from aeroid.flights import wrap_angle
from aeroid.reconstruction._kinematics import IX, N_STATES, jacobians, rk4_step

_STEP = 1e-30
THETA = IX["theta"]
#: Largest pitch angle the Euler-angle kinematics are trusted with [rad] (85 deg).
MAX_PITCH = np.radians(85.0)


@dataclass(frozen=True)
class Aiding:
    """One aiding source: measurements at IMU indices with their model.

    Attributes
    ----------
    name : str
    index : ndarray of int, shape (m,)
        Nearest IMU sample of each measurement.
    lead : ndarray, shape (m,)
        Measurement time less that sample's time [s].
    values : ndarray, shape (m, d)
    sd : ndarray, shape (d,)
    wrapped : ndarray of bool, shape (d,)
        Channels whose innovation is wrapped to (-pi, pi].
    model : callable
        ``h(x)``, x of shape (N_STATES, c) -> (d, c), element-wise over the columns.
    channels : tuple of str
        The channels' names (for reports), ``d`` of them.
    """

    name: str
    index: np.ndarray
    lead: np.ndarray
    values: np.ndarray
    sd: np.ndarray
    wrapped: np.ndarray
    model: Callable[[np.ndarray], np.ndarray]
    channels: tuple[str, ...] = ()


@dataclass(frozen=True)
class Passes:
    """Smoothed states (n, N) and covariances (n, N, N); the residual check per source.

    ``nis[source]``: ``mean_nis_per_dof`` (1 for a consistent source), ``n_updates``,
    ``n_values``, ``interval`` (the chi-square interval of the mean at two-sided level
    :data:`NIS_LEVEL`) and ``consistent`` (the mean inside it). ``innovations``: each
    source's innovations over their predicted sd (m, d); ``innovation_detail``: per source
    ``t`` (m,) the measurement times [s], ``innovation`` and ``sd`` (m, d) in the
    channels' units (NaN where a measurement was not used).
    """

    states: np.ndarray
    covariance: np.ndarray
    filtered: np.ndarray
    nis: dict[str, dict[str, object]]
    innovations: dict[str, np.ndarray]
    innovation_detail: dict[str, dict[str, np.ndarray]]


#: Two-sided level of the residual check: a consistent source's mean NIS per dof falls
#: outside its interval with this probability.
NIS_LEVEL = 0.002


def _nis_check(total: float, n_values: int, n_updates: int) -> dict[str, object]:
    """Return the residual check of one source: mean NIS per dof against chi-square."""
    if not n_values:
        return {"mean_nis_per_dof": float("nan"), "n_updates": 0, "n_values": 0,
                "interval": (float("nan"), float("nan")), "consistent": False}
    low, high = chi2.ppf([NIS_LEVEL / 2, 1 - NIS_LEVEL / 2], n_values) / n_values
    mean = total / n_values
    return {"mean_nis_per_dof": mean, "n_updates": n_updates, "n_values": n_values,
            "interval": (float(low), float(high)), "consistent": bool(low <= mean <= high)}


def _measurement_jacobian(model: Callable[[np.ndarray], np.ndarray], x: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray]:
    xs = np.tile(x[:, None].astype(complex), (1, N_STATES))
    xs[np.arange(N_STATES), np.arange(N_STATES)] += 1j * _STEP
    h = model(xs)
    return h[:, 0].real, h.imag / _STEP


def run(t: np.ndarray, imu: np.ndarray, imu_sd: np.ndarray, omega_dot: np.ndarray,
        lever: np.ndarray, x0: np.ndarray, p0: np.ndarray, aidings: list[Aiding],
        extra_noise: np.ndarray, imu_sd_per_sample: np.ndarray | None = None) -> Passes:
    """Run the filter and the smoother over the IMU record.

    Parameters
    ----------
    t : ndarray, shape (n,)
        IMU times [s].
    imu : ndarray, shape (n, N_IMU)
        Raw IMU readings; ``imu_sd`` their white-noise sd, shape (N_IMU,).
    omega_dot : ndarray, shape (n, 3)
        Angular acceleration [rad/s^2]; ``lever`` (3,) the triads' mean position [m].
    x0, p0 : ndarray, shape (N,), (N, N)
        Prior at ``t[0]``.
    aidings : list of Aiding
    extra_noise : ndarray, shape (N,)
        Further process-noise density per state [unit^2 / s].
    imu_sd_per_sample : ndarray, shape (n, N_IMU), optional
        The IMU's sd at each sample (a saturated reading's is raised); the step from
        ``k`` to ``k + 1`` takes the larger of the two samples'. Default ``imu_sd``.
    """
    n = len(t)
    eye = np.eye(N_STATES)
    xf = np.empty((n, N_STATES))
    pf = np.empty((n, N_STATES, N_STATES))
    xp = np.empty_like(xf)
    pp = np.empty_like(pf)
    fm = np.empty_like(pf)
    events: dict[int, list[tuple[Aiding, int]]] = {}
    for aid in aidings:
        for j, k in enumerate(aid.index):
            events.setdefault(int(k), []).append((aid, j))
    sums: dict[str, list] = {aid.name: [0.0, 0, 0] for aid in aidings}
    innovations = {aid.name: np.full(aid.values.shape, np.nan) for aid in aidings}
    detail = {aid.name: {"t": t[aid.index] + aid.lead,
                         "innovation": np.full(aid.values.shape, np.nan),
                         "sd": np.full(aid.values.shape, np.nan)} for aid in aidings}
    lever = lever[:, None]
    x, p = x0.astype(float).copy(), p0.astype(float).copy()
    q_imu = np.diag(imu_sd ** 2)
    for k in range(n):
        xp[k], pp[k] = x, p
        od = omega_dot[k][:, None]
        f, a, b = jacobians(x, imu[k], od, lever)
        for aid, j in events.get(k, ()):
            lead = aid.lead[j]
            h, hx = _measurement_jacobian(aid.model, x + lead * f)
            hx = hx @ (eye + lead * a)
            nu = aid.values[j] - h
            nu[aid.wrapped] = wrap_angle(nu[aid.wrapped])
            s = hx @ p @ hx.T + np.diag(aid.sd ** 2)
            gain = np.linalg.solve(s, hx @ p).T
            x = x + gain @ nu
            ikh = eye - gain @ hx
            p = ikh @ p @ ikh.T + gain @ np.diag(aid.sd ** 2) @ gain.T
            stats = sums[aid.name]
            stats[0] += float(nu @ np.linalg.solve(s, nu))
            stats[1] += len(nu)
            stats[2] += 1
            innovations[aid.name][j] = nu / np.sqrt(np.diag(s))
            detail[aid.name]["innovation"][j] = nu
            detail[aid.name]["sd"][j] = np.sqrt(np.diag(s))
        if k in events:
            f, a, b = jacobians(x, imu[k], od, lever)
        xf[k], pf[k] = x, p
        if k == n - 1:
            break
        dt = t[k + 1] - t[k]
        ad = a * dt
        ad2 = ad @ ad
        fk = eye + ad + ad2 / 2.0 + ad2 @ ad / 6.0 + ad2 @ ad2 / 24.0
        bd = (eye + ad / 2.0) @ b * dt
        x = rk4_step(x, imu[k], imu[k + 1], od, lever, dt, f)
        if not np.all(np.isfinite(x)):
            raise FlightError(f"reconstruction: the filter diverged at t = {t[k + 1]:.6g} s")
        if abs(x[THETA]) > MAX_PITCH:
            raise FlightError(f"reconstruction: pitch beyond 85 deg at t = {t[k + 1]:.6g} s "
                              "(the Euler-angle kinematics are singular at 90 deg)")
        if imu_sd_per_sample is not None:
            q_imu = np.diag(np.maximum(imu_sd_per_sample[k], imu_sd_per_sample[k + 1]) ** 2)
        p = fk @ p @ fk.T + bd @ q_imu @ bd.T + np.diag(extra_noise * dt)
        p = 0.5 * (p + p.T)
        fm[k] = fk
    xs = xf.copy()
    ps = pf.copy()
    for k in range(n - 2, -1, -1):
        gain = np.linalg.solve(pp[k + 1], fm[k] @ pf[k]).T
        xs[k] = xf[k] + gain @ (xs[k + 1] - xp[k + 1])
        ps[k] = pf[k] + gain @ (ps[k + 1] - pp[k + 1]) @ gain.T
        ps[k] = 0.5 * (ps[k] + ps[k].T)
    nis = {name: _nis_check(*s) for name, s in sums.items()}
    return Passes(xs, ps, xf, nis, innovations, detail)


def _subset(full: Callable[[np.ndarray], np.ndarray], rows: list[int]
            ) -> Callable[[np.ndarray], np.ndarray]:
    """Return the model of some rows of ``full`` (moved from :mod:`._reconstruct`)."""
    def model(x: np.ndarray) -> np.ndarray:
        return full(x)[rows]

    return model
