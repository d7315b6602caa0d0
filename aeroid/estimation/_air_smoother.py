"""The wind the air data imply, smoothed by a Kalman smoother whose gust level is fitted.

The wind per sample that the logged angles (and airspeed) imply,
:func:`aeroid.estimation.air_data_wind`, is the true wind plus the probe's white noise
mapped through the attitude: in body axes the vane noise is ``V sd_beta`` across (y) and
``V sd_alpha`` down (z), the airspeed's noise along the air velocity (x; without an
airspeed channel that component is the inertial speed's, noise-free). In north-east-down
axes, where the wind is slow, the noise's covariance turns with the roll:
``R_k = C_k^T diag(s_x^2, s_y^2, s_z^2) C_k`` (``C_k`` NED to body at sample k). The
three sd ``s`` are measured from the data: the 4th differences of the implied wind in
body axes (:func:`aeroid.estimation.difference_noise_sd`), where the wind turns with the
roll at ~8 Hz, which 4th differences at 500 Hz reduce by ~1e-4.

The wind is a random walk in NED, ``w_{k+1} = w_k + e_k``, ``e_k ~ N(0, q dt I)``, of
unknown intensity ``q`` [(m/s)^2/s]: ``q = 0`` is a steady wind (the smoother is then the
noise-weighted mean of the record), a Dryden gust field of sd ``s_g`` and time constant
``tau`` has increments of ``2 s_g^2 / tau`` per second at short lags. ``q`` is the
maximum of the innovations' likelihood over a grid of :data:`Q_GRID` (q = 0 and
1e-6..1e4 in steps of 10^0.25: q within a factor 1.8 of its maximum, a likelihood within
a fraction of a unit of it) and the Rauch-Tung-Striebel smoother gives the wind and its
covariance per sample. Diffuse start (sd :data:`DIFFUSE_SD_MPS`); the first sample's
likelihood term, which carries the diffuse prior, is left out.

This replaces a fixed smoothing window (Savitzky-Golay over ``air_data_window_s``), which
must be long for a steady wind and short for gusts: the data choose.

``model = "dryden"`` smooths with a steady wind plus the simulator's Dryden gusts instead
(:mod:`aeroid.estimation._air_dryden`, their sd and scale length by maximum likelihood).
Measured against the random walk (``benchmarks/bench_air_data.py``, 8 seeds, 0.1 deg
vanes): the same wind error (0.283 against 0.284 m/s RMS in Dryden sd 3) and the same
coefficients within the seeds' scatter in every air, at twice the cost (1.5 s against
0.75 s per equation-error fit): at the frequencies where gusts and probe noise cross both
models are the same ``q / omega^2`` spectrum. The random walk stays the default.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from aeroid.errors import EstimatorError
from aeroid.estimation._air_dryden import fit_dryden, increment_intensity
from aeroid.estimation._signals import difference_noise_sd
from aeroid.flights import Flight
from aeroid.model import equations

#: The random walk's intensities tried [(m/s)^2/s] (module docstring).
Q_GRID = np.concatenate([[0.0], 10.0 ** np.arange(-6.0, 4.01, 0.25)])
#: The smoother's wind models (module docstring; :mod:`aeroid.estimation._air_dryden`).
SMOOTHER_MODELS = ("random-walk", "dryden")
#: The diffuse start's sd [m/s]: far above any wind a rocket flies in.
DIFFUSE_SD_MPS = 1e3
#: Smallest noise sd per body axis, relative to the speed: without an airspeed channel
#: the implied wind along the path is the inertial speed's (noise-free, ~1e-12 m/s), kept
#: above rounding so that R stays invertible.
MIN_NOISE_RELATIVE = 1e-9


@dataclass(frozen=True)
class SmoothedWind:
    """The smoother's answer: ``wind`` (n, 3) and ``covariance`` (n, 3, 3) NED [m/s],
    ``intensity`` q [(m/s)^2/s] (0: steady), ``noise_sd_body`` (3,) [m/s] the implied
    wind's white noise along body x, y, z, ``log_likelihood`` at ``intensity``, and
    ``steady_log_likelihood`` at q = 0 (their difference tests a steady wind)."""

    wind: np.ndarray
    covariance: np.ndarray
    intensity: float
    noise_sd_body: np.ndarray
    log_likelihood: float
    steady_log_likelihood: float
    mean_covariance: np.ndarray  # (3, 3) [m^2/s^2] of the record-mean wind's error
    #: ``"random-walk"`` or ``"dryden"`` (:mod:`aeroid.estimation._air_dryden`); with
    #: Dryden, ``intensity`` is the gusts' short-lag increment ``2 sd^2 V / L``, and
    #: ``dryden`` holds ``gust_sd_mps``, ``log_sd_se``, ``scale_length_m``,
    #: ``length_source`` and ``airspeed_mps``.
    model: str = "random-walk"
    dryden: dict[str, Any] | None = None


def _ned_to_body(flight: Flight) -> np.ndarray:
    """(n, 3, 3) rotation matrices, body = C @ ned, from the model's ``ned_to_body``."""
    phi, theta, psi = (flight[c] for c in ("phi", "theta", "psi"))
    return np.stack([np.stack(equations.ned_to_body(phi, theta, psi, *e), axis=1)
                     for e in np.eye(3)], axis=2)


def _filter(z: np.ndarray, r: np.ndarray, q: np.ndarray, dt: float, *, keep: bool = False
            ) -> tuple[np.ndarray, Any]:
    """Kalman filter of random walks (one per intensity in ``q``, shape (g,)) measured by
    ``z`` (n, 3) with noise covariances ``r`` (n, 3, 3). Returns the log-likelihoods (g,)
    and, with ``keep``, the filtered and predicted means and covariances."""
    n, g = len(z), len(q)
    x = np.zeros((g, 3))
    p = np.broadcast_to(DIFFUSE_SD_MPS**2 * np.eye(3), (g, 3, 3)).copy()
    step = (q * dt)[:, None, None] * np.eye(3)
    loglik = np.zeros(g)
    stored: tuple[list[np.ndarray], ...] = ([], [], [], [])  # filled with ``keep``
    for k in range(n):
        if k:
            p = p + step  # predict: x unchanged
        if keep:
            stored[0].append(x.copy())
            stored[1].append(p.copy())
        s = p + r[k]
        s_inv = np.linalg.inv(s)
        e = z[k] - x
        if k:  # the first term carries the diffuse start
            _, logdet = np.linalg.slogdet(s)
            loglik -= 0.5 * (logdet + np.einsum("gi,gij,gj->g", e, s_inv, e)
                             + 3 * np.log(2 * np.pi))
        gain = p @ s_inv
        x = x + np.einsum("gij,gj->gi", gain, e)
        p = p - gain @ p
        p = 0.5 * (p + np.swapaxes(p, 1, 2))
        if keep:
            stored[2].append(x.copy())
            stored[3].append(p.copy())
    return loglik, (stored if keep else None)


def smooth_air_wind(flight: Flight, implied: np.ndarray, *,
                    intensity: float | None = None, model: str = "random-walk",
                    gust_sd_mps: float | None = None,
                    scale_length_m: float | None = None) -> SmoothedWind:
    """Return ``implied`` (n, 3) [m/s] NED, the wind the flight's air data imply per sample
    (:func:`aeroid.estimation.air_data_wind`, unsmoothed), Kalman-smoothed (module
    docstring); ``intensity`` [(m/s)^2/s] fixes the random walk's q (default: the
    likelihood's maximum over :data:`Q_GRID`). ``model`` (:data:`SMOOTHER_MODELS`):
    ``"dryden"`` smooths with a steady wind plus Dryden gusts
    (:mod:`aeroid.estimation._air_dryden`), whose ``gust_sd_mps`` [m/s] and
    ``scale_length_m`` [m] are fixed when given (default: the likelihood's).
    """
    if model not in SMOOTHER_MODELS:
        raise EstimatorError(f"air-data wind smoother must be one of "
                          f"{', '.join(SMOOTHER_MODELS)}, got {model!r}")
    unused = {"intensity": intensity} if model == "dryden" else {
        "gust_sd_mps": gust_sd_mps, "scale_length_m": scale_length_m}
    if any(v is not None for v in unused.values()):
        raise EstimatorError(f"air-data wind smoother {model!r} takes no "
                          + ", ".join(k for k, v in unused.items() if v is not None))
    z = np.asarray(implied, dtype=float)
    c = _ned_to_body(flight)
    body = np.einsum("nbk,nk->nb", c, z)
    speed = float(np.mean(np.sqrt(sum(flight[k] ** 2 for k in ("u", "v", "w")))))
    sd = np.asarray(difference_noise_sd(body)[0], dtype=float).reshape(-1)
    sd = np.maximum(sd, MIN_NOISE_RELATIVE * speed)
    r = np.einsum("nbi,b,nbj->nij", c, sd**2, c)
    dt = float(flight.dt)
    if model == "dryden":
        return _dryden(flight, z, c, r, sd, gust_sd_mps, scale_length_m)
    grid = Q_GRID if intensity is None else np.array([0.0, float(intensity)])
    loglik, _ = _filter(z, r, grid, dt)
    best = int(np.argmax(loglik)) if intensity is None else 1
    q = grid[best : best + 1]
    _, (x_pred, p_pred, x_filt, p_filt) = _filter(z, r, q, dt, keep=True)
    x_s, p_s = x_filt[-1][0].copy(), p_filt[-1][0].copy()
    wind = np.empty((len(z), 3))
    cov = np.empty((len(z), 3, 3))
    gains = np.empty((len(z), 3, 3))
    wind[-1], cov[-1] = x_s, p_s
    for k in range(len(z) - 2, -1, -1):  # Rauch-Tung-Striebel
        gain = p_filt[k][0] @ np.linalg.inv(p_pred[k + 1][0])
        x_s = x_filt[k][0] + gain @ (x_s - x_pred[k + 1][0])
        p_s = p_filt[k][0] + gain @ (p_s - p_pred[k + 1][0]) @ gain.T
        wind[k], cov[k], gains[k] = x_s, 0.5 * (p_s + p_s.T), gain
    return SmoothedWind(wind, cov, float(q[0]), sd, float(loglik[best]), float(loglik[0]),
                        _mean_covariance(cov, gains))


def _dryden(flight: Flight, z: np.ndarray, c: np.ndarray, r: np.ndarray, sd: np.ndarray,
            gust_sd_mps: float | None, scale_length_m: float | None) -> SmoothedWind:
    """The Dryden smoother's :class:`SmoothedWind` (:mod:`aeroid.estimation._air_dryden`);
    the path axes and ``V`` from the record-mean air velocity (inertial less implied)."""
    inertial = np.einsum("nbk,nb->nk", c, np.stack([flight[k] for k in ("u", "v", "w")],
                                                   axis=1))
    air = np.mean(inertial - z, axis=0)
    out = fit_dryden(z, r, float(flight.dt), air, gust_sd_mps=gust_sd_mps,
                     scale_length_m=scale_length_m)
    speed = float(np.linalg.norm(air))
    h = out["h"]
    mean_state = _mean_covariance(out["state_covariance"], out["gains"])
    info = {k: out[k] for k in ("gust_sd_mps", "log_sd_se", "scale_length_m",
                                "length_source")}
    return SmoothedWind(out["wind"], out["covariance"],
                        increment_intensity(out["gust_sd_mps"], out["scale_length_m"], speed),
                        sd, out["log_likelihood"], out["steady_log_likelihood"],
                        h @ mean_state @ h.T, "dryden", {**info, "airspeed_mps": speed})


def dryden_note(smoothed: SmoothedWind) -> str:
    """The note's words for the Dryden smoother's answer (what it chose and how)."""
    d = smoothed.dryden or {}
    se = d.get("log_sd_se", math.inf)
    how = ("given" if se == 0 else "by maximum likelihood" + (
        f", se {100 * se:.2g} %" if math.isfinite(se) else ", its se not determined"))
    length = {"given": "given", "likelihood": "by maximum likelihood",
              "MIL-F-8785C": "MIL-F-8785C's: the likelihood cannot tell it"}
    sd = ", ".join(f"{v:.2g}" for v in smoothed.noise_sd_body)
    return ("the wind they imply Kalman-smoothed as a steady wind plus Dryden gusts in the "
            f"flight-path axes (gust sd {d.get('gust_sd_mps', math.nan):.3g} m/s ({how}), "
            f"scale length {d.get('scale_length_m', math.nan):.4g} m "
            f"({length.get(d.get('length_source', ''), '?')}); probe noise {sd} m/s along "
            "body x, y, z)")


def _mean_covariance(cov: np.ndarray, gains: np.ndarray) -> np.ndarray:
    """The covariance (3, 3) of the smoothed wind's error averaged over the record.

    The smoother's errors are correlated: ``Cov(e_j, e_k) = G_j ... G_{k-1} P_k`` for
    ``j < k`` (``G`` the RTS gains, ``P_k`` the smoothed covariances), so with
    ``D_k = I + D_{k-1} G_{k-1}`` the sum over ``j <= k`` is ``D_k P_k`` and the mean's
    covariance ``sum_k (D_k P_k + (D_k P_k)^T - P_k) / n^2``. A steady wind (q = 0) has
    every ``G = I`` and gives ``P`` itself.
    """
    n, m = cov.shape[:2]
    d = np.eye(m)
    total = np.zeros((m, m))
    for k in range(n):
        if k:
            d = np.eye(m) + d @ gains[k - 1]
        dp = d @ cov[k]
        total += dp + dp.T - cov[k]
    return 0.5 * (total + total.T) / n**2


__all__ = ["DIFFUSE_SD_MPS", "Q_GRID", "SMOOTHER_MODELS", "SmoothedWind", "dryden_note",
           "smooth_air_wind"]
