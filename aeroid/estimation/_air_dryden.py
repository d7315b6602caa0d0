"""The wind the air data imply, smoothed with the simulator's Dryden gust model.

The alternative to :mod:`aeroid.estimation._air_smoother`'s random walk: the wind is a
steady wind (three constants, diffuse start) plus Dryden gusts, the outputs of the
shaping filters of MIL-F-8785C that aeroid's simulator draws them from
(:func:`aeroid.flights.shaping_filters`: longitudinal ``1 / (1 + tau s)``, transverse
``(1 + sqrt(3) tau s) / (1 + tau s)^2``, ``tau = L / V``, sampled exactly at ``dt``), in
the simulator's path axes (:func:`aeroid.flights.path_axes`: ``u_g`` along the air
velocity, ``v_g`` horizontal, ``w_g`` completing the triad), started in their stationary
distribution. State (:data:`N_STATES`): the steady wind (NED), the longitudinal filter's
state and the two transverse filters' states; the measurement is the implied wind
(NED) with the probe's white noise ``R_k`` of :mod:`aeroid.estimation._air_smoother`.

The gust sd is the maximum of the innovations' likelihood over :data:`SD_GRID`, refined
by a parabola through the three best points in ``log sd`` (its curvature gives the
standard error of ``log sd``); the scale length ``L`` is the likelihood's too, over
:data:`LENGTH_FACTORS` times MIL-F-8785C's 533.4 m, when the record tells it (the profile
likelihood at its best ``L`` above that at 533.4 m by more than
:data:`LENGTH_LOGLIK_MARGIN`, a likelihood-ratio test at 5 %), else 533.4 m; the note
says which. Over a record of about one ``tau`` the data see the gusts' short-lag
increments, ``2 sd^2 / tau`` per second, better than ``sd`` and ``L`` apart.

What a smoother of the air data alone can do: where the gusts and the probe noise cross
(~15 Hz at sd 3 m/s, 500 m/s, 0.1 deg vanes; 1 / tau is ~0.16 Hz), the Dryden spectra
are their ``q / omega^2`` tails (``q = 2 sd^2 V / L`` along the path, 1.5x that across),
as is the random walk's, so both smoothers' errors are nearly the same, the Wiener floor
``sqrt(q r dt) / 2`` in variance per axis (``r`` the noise variance per sample), whatever
the model's low-frequency shape. Measured (``benchmarks/bench_air_data.py``, 8 seeds):
the smoothed wind 0.283 m/s RMS off the truth in Dryden sd 3 against the random walk's
0.284, and the same as the smoother told the true sd and length.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy import stats

from aeroid.flights import MIL_SCALE_LENGTH_M, path_axes, shaping_filters

#: The state: steady wind NED (3), longitudinal (1), lateral (2) and vertical (2) gusts.
STEADY = slice(0, 3)
N_STATES = 8
#: The gust sd tried [m/s]: 0 (a steady wind) and 0.01..31.6 m/s, 10^(1/8) apart.
SD_GRID = np.concatenate([[0.0], 10.0 ** np.arange(-2.0, 1.501, 0.125)])
#: Scale lengths tried, in units of MIL-F-8785C's 533.4 m (tau 0.12-8 s at 540 m/s).
LENGTH_FACTORS = 2.0 ** np.arange(-2.0, 4.01, 1.0)
#: The profile log-likelihood of the best scale length must exceed MIL-F-8785C's by this
#: to be taken (else the record cannot tell it): half the chi-square(1) point of 5 %
#: Bonferroni-split over the other lengths (3.48; the plain 95 % point, 1.92, took a
#: wrong length on 6 of 40 records of MIL's gusts, this one on 2 of 40:
#: benchmarks/bench_air_data_dryden.py).
LENGTH_LOGLIK_MARGIN = 0.5 * float(stats.chi2.ppf(1 - 0.05 / (len(LENGTH_FACTORS) - 1), 1))
#: The diffuse start of the steady wind [m/s] (as the random walk's).
DIFFUSE_SD_MPS = 1e3


def dryden_system(dt: float, scale_length_m: float, airspeed_mps: float,
                  axes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Return ``F, Q1, P1, H`` of the steady wind plus Dryden gusts of unit sd.

    ``F`` (8, 8) the exact one-step transition, ``Q1`` and ``P1`` (8, 8) the process noise
    and the stationary covariance for a gust sd of 1 m/s (zero in the steady block),
    ``H`` (3, 8) the wind in NED from the state; ``axes`` (3, 3) the path axes' unit
    vectors in NED as rows (:func:`aeroid.flights.path_axes`).
    """
    filters = shaping_filters(dt, sd=1.0, scale_length_m=scale_length_m,
                              airspeed_mps=airspeed_mps)
    f = np.eye(N_STATES)
    q = np.zeros((N_STATES, N_STATES))
    p = np.zeros((N_STATES, N_STATES))
    h = np.zeros((3, N_STATES))
    h[:, STEADY] = np.eye(3)
    start = 3
    for j, s in enumerate(filters):
        block = slice(start, start + s.phi.shape[0])
        f[block, block] = s.phi
        q[block, block] = s.noise_sqrt @ s.noise_sqrt.T
        p[block, block] = s.stationary
        h[:, block] = np.outer(axes[j], np.ravel(s.c))
        start = block.stop
    return f, q, p, h


def _filter(z: np.ndarray, r: np.ndarray, systems: list[tuple], *, keep: bool = False,
            steady_sd_mps: float = DIFFUSE_SD_MPS) -> tuple[np.ndarray, Any]:
    """Kalman filter of ``z`` (n, 3) with noise ``r`` (n, 3, 3), one per system in
    ``systems`` (``(F, Q, P0, H)`` each, g of them, batched). Returns the log-likelihoods
    (g,) (the first sample's term, which carries the diffuse start, left out) and, with
    ``keep``, the predicted and filtered means and covariances of the first system;
    ``steady_sd_mps`` the steady wind's prior sd (0: no steady wind)."""
    f, q, p, h = (np.stack(a) for a in zip(*systems, strict=True))
    g = len(systems)
    p = p.copy()
    p[:, STEADY, STEADY] = steady_sd_mps**2 * np.eye(3)
    f_t, h_t = np.swapaxes(f, 1, 2), np.swapaxes(h, 1, 2)
    x = np.zeros((g, N_STATES))
    loglik = np.zeros(g)
    stored: tuple[list[np.ndarray], ...] = ([], [], [], [])
    for k in range(len(z)):
        if k:
            x = np.einsum("gij,gj->gi", f, x)
            p = f @ p @ f_t + q
        if keep:
            stored[0].append(x[0].copy())
            stored[1].append(p[0].copy())
        ph = p @ h_t  # (g, 8, 3)
        s = h @ ph + r[k]
        s_inv = np.linalg.inv(s)
        e = z[k] - np.einsum("gij,gj->gi", h, x)
        if k:
            _, logdet = np.linalg.slogdet(s)
            loglik -= 0.5 * (logdet + np.einsum("gi,gij,gj->g", e, s_inv, e)
                             + 3 * math.log(2 * math.pi))
        gain = ph @ s_inv
        x = x + np.einsum("gij,gj->gi", gain, e)
        p = p - gain @ np.swapaxes(ph, 1, 2)
        p = 0.5 * (p + np.swapaxes(p, 1, 2))
        if keep:
            stored[2].append(x[0].copy())
            stored[3].append(p[0].copy())
    return loglik, (stored if keep else None)


def _scaled(system: tuple, sd: float) -> tuple:
    """``system`` (unit sd) for the gust sd ``sd`` [m/s]: ``Q`` and ``P0`` times sd^2."""
    f, q1, p1, h = system
    return f, sd * sd * q1, sd * sd * p1, h


def _refine(grid: np.ndarray, loglik: np.ndarray) -> tuple[float, float]:
    """The maximum of a parabola through the best grid point and its neighbours in
    ``log sd``, and the standard error of ``log sd`` from its curvature (inf at an edge
    or where the likelihood is flat)."""
    best = int(np.argmax(loglik))
    if best < 2 or best == len(grid) - 1:  # sd = 0, the first positive sd, or the edge
        return float(grid[best]), math.inf
    x = np.log(grid[best - 1:best + 2])
    a, b, _ = np.polyfit(x, loglik[best - 1:best + 2], 2)
    if a >= 0:
        return float(grid[best]), math.inf
    return float(np.exp(np.clip(-b / (2 * a), x[0], x[2]))), float(1.0 / math.sqrt(-2 * a))


def fit_dryden(z: np.ndarray, r: np.ndarray, dt: float, air_velocity_ned: np.ndarray, *,
               gust_sd_mps: float | None = None, scale_length_m: float | None = None,
               steady_sd_mps: float = DIFFUSE_SD_MPS) -> dict[str, Any]:
    """Fit (or take) the Dryden gusts' sd and scale length and smooth ``z`` (module
    docstring).

    ``z`` (n, 3) [m/s] the implied wind NED, ``r`` (n, 3, 3) its noise covariances,
    ``air_velocity_ned`` (3,) [m/s] the mean air velocity (path axes and ``V``),
    ``steady_sd_mps`` [m/s] the steady wind's prior sd (default diffuse; 0: none, the
    gusts alone).
    Returns ``wind`` (n, 3), ``covariance`` (n, 3, 3), ``state_covariance`` (n, 8, 8),
    ``gains`` (n, 8, 8) (the RTS gains), ``h`` (3, 8), ``gust_sd_mps``,
    ``log_sd_se`` (the standard error of ``log sd``; inf: not determined; 0: given),
    ``scale_length_m``, ``length_source`` ("given", "likelihood" or "MIL-F-8785C"),
    ``log_likelihood`` and ``steady_log_likelihood`` (sd = 0).
    """
    speed = float(np.linalg.norm(air_velocity_ned))
    axes = path_axes(air_velocity_ned)
    lengths = ([float(scale_length_m)] if scale_length_m is not None
               else list(MIL_SCALE_LENGTH_M * LENGTH_FACTORS))
    grid = SD_GRID if gust_sd_mps is None else np.array([0.0, float(gust_sd_mps)])
    units = [dryden_system(dt, length, speed, axes) for length in lengths]
    if gust_sd_mps is not None and scale_length_m is not None:  # one pass: sd, then 0
        best_l, source, length, sd, se = 0, "given", lengths[0], float(gust_sd_mps), 0.0
        loglik, kept = _filter(z, r, [_scaled(units[0], s) for s in (sd, 0.0)], keep=True,
                               steady_sd_mps=steady_sd_mps)
        steady = float(loglik[1])
    else:
        flat, _ = _filter(z, r, [_scaled(u, s) for u in units for s in grid],
                          steady_sd_mps=steady_sd_mps)
        profile = flat.reshape(len(lengths), len(grid))
        best_l = int(np.argmax(np.max(profile, axis=1)))
        source = "given" if scale_length_m is not None else "likelihood"
        if scale_length_m is None:
            mil = int(np.argmin(np.abs(LENGTH_FACTORS - 1.0)))
            if np.max(profile[best_l]) - np.max(profile[mil]) <= LENGTH_LOGLIK_MARGIN:
                best_l, source = mil, "MIL-F-8785C"
        length = float(lengths[best_l])
        sd, se = (_refine(grid, profile[best_l]) if gust_sd_mps is None
                  else (float(gust_sd_mps), 0.0))
        loglik, kept = _filter(z, r, [_scaled(units[best_l], sd)], keep=True,
                               steady_sd_mps=steady_sd_mps)
        steady = float(np.max(profile[best_l][grid == 0.0]))
    x_pred, p_pred, x_filt, p_filt = (np.array(a) for a in kept)
    f, _, _, h = units[best_l]
    n = len(z)
    states = np.empty((n, N_STATES))
    cov = np.empty((n, N_STATES, N_STATES))
    gains = np.zeros((n, N_STATES, N_STATES))
    # Rauch-Tung-Striebel gains G_k = P_f,k F^T P_p,k+1^-1 (a pseudo-inverse: without a
    # steady wind, or at sd 0, its block of P_p is zero, and so is G's)
    gains[:-1] = np.swapaxes(np.linalg.pinv(p_pred[1:], rcond=1e-12, hermitian=True)
                             @ (f @ p_filt[:-1]), 1, 2)
    states[-1], cov[-1] = x_filt[-1], p_filt[-1]
    for k in range(n - 2, -1, -1):
        gain = gains[k]
        states[k] = x_filt[k] + gain @ (states[k + 1] - x_pred[k + 1])
        c = p_filt[k] + gain @ (cov[k + 1] - p_pred[k + 1]) @ gain.T
        cov[k] = 0.5 * (c + c.T)
    return {"wind": states @ h.T, "covariance": h @ cov @ h.T, "state_covariance": cov,
            "gains": gains, "h": h, "gust_sd_mps": sd, "log_sd_se": se,
            "scale_length_m": length, "length_source": source,
            "log_likelihood": float(loglik[0]),
            "steady_log_likelihood": steady}


def increment_intensity(gust_sd_mps: float, scale_length_m: float, airspeed_mps: float
                        ) -> float:
    """The longitudinal gusts' short-lag increments per second, ``2 sd^2 V / L``
    [(m/s)^2/s]: the random walk's intensity the Dryden model looks like at high frequency."""
    return 2.0 * gust_sd_mps**2 * airspeed_mps / scale_length_m


__all__ = ["DIFFUSE_SD_MPS", "LENGTH_FACTORS", "N_STATES", "SD_GRID", "dryden_system",
           "fit_dryden", "increment_intensity"]
