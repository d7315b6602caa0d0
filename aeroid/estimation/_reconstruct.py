"""EBM step 1: aerodynamic forces and moments from accelerometers and rates (eqs. 28-32).

Eq. 28 for a triad at ``R`` from the c.g., with eqs. 5-7 substituted for ``wdot``
(``wdot = J^-1 M + g(w)``, ``J = diag(Ix, Iy, Iz)``, gyroscopic terms
``g = [0, (Iz - Ix)/Iy p r, (Ix - Iy)/Iz p q]``), is linear in the six unknowns
``FM = [F_AX, F_AY, F_AZ, M_X, M_Y, M_Z]``::

    a_R = [I/m, -[R]x J^-1] FM + (F_T/m e_x - [R]x g(w) + w x (w x R))
        = A_R FM + B_R(w)

Stacking both triads gives the 6x6 matrix ``A`` of eqs. 29-30, which is the same for
every sample (it depends on m, J and the positions only); ``B`` varies with the rates.
``A`` has rank 5 for any geometry (notes, "EBM first step"): two triads cannot see the
angular acceleration along ``R2 - R1``. Decision (notes): three further rows
``J^-1 M = wdot_SG - g(w)`` use Savitzky-Golay derivatives of the measured p, q, r, and
the nine rows are solved per sample by weighted least squares.

Weights (a decision the notes leave open): each row is divided by the noise standard
deviation of its measurement, estimated from the data
(:func:`aeroid.estimation.estimate_noise_sd`): for an
accelerometer channel the robust (MAD) spread of its residual from the 7-point SG
smoother; for a rate-derivative row the same estimate for p, q or r times the noise gain
``||h||`` of the SG derivative filter, and the rate rows are further scaled by
``rate_weight`` (default 1e-3, :data:`RATE_WEIGHT`: measured, the rates then only fix
the direction the accelerometers cannot see). Derivative windows: 9 points, quartic
for q and r (they oscillate at the roll frequency, ~62 samples per cycle); 101 points,
quadratic for p (slow roll-up; the wide window cuts the roll-acceleration noise).
One constant weight per row, so the weighted matrix is the same for all samples and
one pseudo-inverse solves the whole flight (no per-sample ``lstsq``). With
multiplicative noise (eq. 43) the true noise level varies with the signal; a
per-channel constant is the approximation made here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from scipy.signal import savgol_coeffs

from aeroid.estimation._signals import (
    DERIVATIVE_POLYORDER,
    DERIVATIVE_WINDOW,
    ROLL_DERIVATIVE_WINDOW,
    ROLL_POLYORDER,
    SMOOTHING_POLYORDER,
    SMOOTHING_WINDOW,
    estimate_noise_sd,
    rate_derivatives,
    roll_window_samples,
    smooth,
)
from aeroid.flights import Flight, sample_constants
from aeroid.model import FM_NAMES, OUTPUT_CHANNELS, Airframe, Constants, constants, regressors
from aeroid.model import equations as eq

__all__ = [
    "RATE_WEIGHT",
    "SMOOTHING_CHOICES",
    "Reconstruction",
    "accel_only_matrix",
    "ebm_regression",
    "regression_fit",
    "reconstruct",
    "sensor_matrix",
    "sensor_offset",
]

#: Factor on the inverse-noise-sd weight of the three rate-derivative rows. Measured on
#: the reference flight with the paper's noise (8 seeds, second step by least squares):
#: with factor 1 the q, r derivative rows pull the accelerometer-observable directions
#: (their error is dominated by the derivative's bias and the paper's position error is
#: not in the accelerometer sd) and Czq/Cmq errors average 630/370 %; at 1e-2 and below
#: the result no longer changes (83/49 %): the rates then only complete the direction
#: the accelerometers cannot see (rank 5 -> 6). 1e-3 sits on that plateau.
RATE_WEIGHT = 1e-3
#: Names of the nine rows of the step-1 system.
ROW_NAMES: tuple[str, ...] = ("ax1", "ay1", "az1", "ax2", "ay2", "az2", "pdot", "qdot", "rdot")


def _body_rates(omega: np.ndarray) -> eq.State:
    """A state whose only non-zero components are the body rates ``omega`` (n, 3)."""
    zero = np.zeros(omega.shape[0])
    return eq.State(zero, zero, zero, omega[:, 0], omega[:, 1], omega[:, 2], zero, zero, zero)


def _columns(fields) -> np.ndarray:
    """Stack element-wise results (arrays and scalars) as the columns of an (n, k) array."""
    return np.column_stack(np.broadcast_arrays(*fields))


def _unit_loads() -> eq.Loads:
    return eq.Loads(*np.eye(len(FM_NAMES)))  # field j is the unit vector e_j over the loads


def _per_load(const: Constants) -> Constants:
    """Constants with per-sample fields (n,) made (n, 1), to broadcast over the six loads."""
    return Constants(*(np.asarray(v, dtype=float)[:, None] if np.ndim(v) else v
                       for v in const))


def sensor_matrix(const: Constants, positions: np.ndarray) -> np.ndarray:
    """Return ``A`` (3 n_triads, 6), or (n, 3 n_triads, 6) for per-sample mass or inertia.

    Eq. 28 with eqs. 5-7 is affine in the loads, ``a_m = A FM + B(w)``; the columns of
    ``A`` are the model's accelerometer readings for unit loads with no rotation and no
    thrust (those go to ``B``), so this is the model's eq. 28, not a second writing of it.
    """
    still = eq.State(*np.zeros(len(eq.STATE_NAMES)))
    free = _per_load(const._replace(thrust=0.0))
    return np.concatenate([np.stack(np.broadcast_arrays(
        *eq.accelerometer(still, _unit_loads(), free, *pos)), axis=-2)
        for pos in np.asarray(positions, dtype=float)], axis=-2)


def inertia_rows(const: Constants) -> np.ndarray:
    """Return ``[0, J^-1]`` (3, 6), or (n, 3, 6) per sample: eqs. 5-7 per unit load."""
    return np.stack(np.broadcast_arrays(*eq.angular_acceleration(
        0.0, 0.0, 0.0, _unit_loads(), _per_load(const))), axis=-2)


def sensor_offset(const: Constants, positions: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Return ``B(w)`` (n, 3 n_triads): thrust, gyroscopic and centripetal terms of eq. 28."""
    x = _body_rates(omega)
    none = eq.Loads(*np.zeros(len(FM_NAMES)))
    return _columns([axis for pos in np.asarray(positions, dtype=float)
                     for axis in eq.accelerometer(x, none, const, *pos)])


def accel_only_matrix(airframe: Airframe) -> np.ndarray:
    """Return the 6x6 matrix ``A`` of eqs. 29-30 (``a_m = A FM + B``).

    Rows ``ax1, ay1, az1, ax2, ay2, az2``; columns ``F_AX, F_AY, F_AZ, M_X, M_Y, M_Z``;
    triad positions from ``airframe`` (the estimator's view). Its rank is 5 for any
    geometry (the angular acceleration along ``R2 - R1`` is unobservable).

    Returns
    -------
    ndarray, shape (6, 6) [1/kg, 1/(kg m)]
    """
    return sensor_matrix(constants(airframe), airframe.accel_positions)


@dataclass(frozen=True, eq=False)
class Reconstruction:
    """Forces and moments reconstructed from the sensors (EBM step 1).

    Attributes
    ----------
    t : ndarray, shape (n,)
        Time [s].
    fm : ndarray, shape (n, 6)
        ``F_AX, F_AY, F_AZ`` [N], ``M_X, M_Y, M_Z`` [N m] per sample (the paper's
        "measured" forces, Figs. 9-12, before smoothing).
    fm_smooth : ndarray, shape (n, 6)
        ``fm`` smoothed with the SG filter of eq. 32 (``smoothing_window``).
    omega_dot : ndarray, shape (n, 3)
        Angular acceleration implied by the solution, ``J^-1 M + g(w)`` [rad/s^2].
    omega_dot_sg : ndarray, shape (n, 3) or None
        SG derivative of the measured rates [rad/s^2] (None without rate rows).
    row_sd : ndarray, shape (9,)
        Noise sd assumed for the rows ``ax1..az2`` [m/s^2] and ``pdot, qdot, rdot``
        [rad/s^2] (weights are ``1 / row_sd``; the rate rows also times ``rate_weight``).
    fm_sd : ndarray, shape (6,)
        Noise sd of each reconstructed load: the rows' sds propagated through the solve
        (the median over samples when mass or inertia vary) [N, N m].
    residual : ndarray, shape (n, 9)
        Row residuals ``model - measurement`` of the solved system (rate rows NaN when
        not used).
    rate_rows : bool
    rank : int
        Rank of the weighted system matrix (5 without rate rows, 6 with).
    smoothing_window, derivative_window : int
    """

    t: np.ndarray
    fm: np.ndarray
    fm_smooth: np.ndarray
    omega_dot: np.ndarray
    omega_dot_sg: np.ndarray | None
    row_sd: np.ndarray
    fm_sd: np.ndarray
    residual: np.ndarray
    rate_rows: bool
    rank: int
    smoothing_window: int
    derivative_window: int

    def to_frame(self) -> pd.DataFrame:
        """Return a table: ``t``, ``FAX..MZ``, ``FAX_smooth..MZ_smooth``, ``pdot..rdot``."""
        data: dict[str, np.ndarray] = {"t": self.t}
        for j, name in enumerate(FM_NAMES):
            data[name] = self.fm[:, j]
        for j, name in enumerate(FM_NAMES):
            data[f"{name}_smooth"] = self.fm_smooth[:, j]
        for j, name in enumerate(("pdot", "qdot", "rdot")):
            data[name] = self.omega_dot[:, j]
        return pd.DataFrame(data)


def reconstruct(flight: Flight, *, rate_rows: bool = True, rate_weight: float = RATE_WEIGHT,
                smoothing_window: int = SMOOTHING_WINDOW,
                derivative_window: int = DERIVATIVE_WINDOW,
                derivative_polyorder: int = DERIVATIVE_POLYORDER,
                roll_derivative_window: int = ROLL_DERIVATIVE_WINDOW) -> Reconstruction:
    """Reconstruct the aerodynamic forces and moments of every sample (EBM step 1).

    Solves, for all samples at once, the weighted least-squares system whose rows are
    the six accelerometer equations (eq. 28 with eqs. 5-7 substituted, triad positions
    from ``flight.airframe``) and, with ``rate_rows``, three angular-acceleration rows
    from SG derivatives of the measured p, q, r (module docstring; notes, "EBM first
    step"). Thrust, mass and inertia are the airframe's constants.

    Parameters
    ----------
    flight : Flight
    rate_rows : bool
        Add the rate-derivative rows (full rank). Without them the rank-5 system is
        solved in the weighted minimum-norm sense (the unobservable combination, mostly
        ``M_X``, is set to zero): only for studying the paper's formulation.
    rate_weight : float
        Factor on the inverse-noise-sd weight of the three rate rows (1 = pure inverse
        noise sd; default :data:`RATE_WEIGHT`, see there). Must be > 0.
    smoothing_window : int
        Width of the SG smoother applied to ``fm`` for ``fm_smooth`` (1 = none).
    derivative_window, derivative_polyorder : int
        SG derivative of q and r [samples, polynomial order].
    roll_derivative_window : int
        SG derivative width for p (quadratic); clipped to the flight length.

    Returns
    -------
    Reconstruction

    Raises
    ------
    ValueError
        On a bad window or weight.
    """
    if not (np.isfinite(rate_weight) and rate_weight > 0):
        raise ValueError(f"rate_weight must be a positive number, got {rate_weight!r}")
    const = sample_constants(flight)
    n = flight.n_samples
    omega = np.column_stack([flight["p"], flight["q"], flight["r"]])
    positions = flight.airframe.accel_positions
    matrix = sensor_matrix(const, positions)
    n_accel = matrix.shape[-2]
    # the right-hand sides, filled in place (no full-size temporaries beyond one channel
    # group): accelerometers minus B(w), then the rate rows
    z = np.empty((n, n_accel + (omega.shape[1] if rate_rows else 0)))
    z[:, :n_accel] = flight.accelerations().reshape(n, n_accel)
    row_sd = np.full(len(OUTPUT_CHANNELS), np.nan)  # the accelerometer rows, then p, q, r
    row_sd[:n_accel] = estimate_noise_sd(z[:, :n_accel])
    z[:, :n_accel] -= sensor_offset(const, positions, omega)
    wdot_sg = None
    if rate_rows:
        roll_window = roll_window_samples(n, roll_derivative_window)
        wdot_sg = rate_derivatives(flight, window=derivative_window,
                                   polyorder=derivative_polyorder, roll_window=roll_window)
        gains = [np.linalg.norm(savgol_coeffs(w, o, deriv=1, delta=flight.dt, use="dot"))
                 for w, o in ((roll_window, ROLL_POLYORDER),
                              (derivative_window, derivative_polyorder),
                              (derivative_window, derivative_polyorder))]
        row_sd[n_accel:] = estimate_noise_sd(omega) * np.asarray(gains)
        rows = inertia_rows(const)
        if rows.ndim != matrix.ndim:  # one of them per sample
            matrix, rows = (np.broadcast_to(a, (n, *a.shape[-2:])) for a in (matrix, rows))
        matrix = np.concatenate([matrix, rows], axis=-2)
        # eqs. 5-7: wdot = J^-1 M + g(w); the rate rows see J^-1 M = wdot - g(w)
        none = eq.Loads(*np.zeros(len(FM_NAMES)))
        z[:, n_accel:] = wdot_sg
        z[:, n_accel:] -= _columns(eq.angular_acceleration(omega[:, 0], omega[:, 1],
                                                           omega[:, 2], none, const))
    n_rows = matrix.shape[-2]
    weights = 1.0 / row_sd[:n_rows]
    if rate_rows:
        weights[n_accel:] *= rate_weight
    weighted = weights[:, None] * matrix
    gain = np.linalg.pinv(weighted) * weights  # fm = gain z, per sample or shared
    if matrix.ndim == 2:  # one matrix for the whole flight: one pseudo-inverse
        fm = z @ gain.T
        model = fm @ matrix.T
    else:  # per-sample mass or inertia
        fm = np.einsum("kij,kj->ki", gain, z)
        model = np.einsum("kij,kj->ki", matrix, fm)
    model -= z  # now the residual, model - measurement
    del z
    # the sensors' noise propagated into the loads: sqrt(diag(G diag(row_sd^2) G^T))
    fm_sd = np.sqrt(np.median(np.sum((gain * row_sd[:n_rows]) ** 2, axis=-1).reshape(
        -1, len(FM_NAMES)), axis=0))
    rank = int(np.min(np.linalg.matrix_rank(weighted)))
    if n_rows == len(OUTPUT_CHANNELS):
        residual = model
    else:
        residual = np.full((n, len(OUTPUT_CHANNELS)), np.nan)
        residual[:, :n_rows] = model
    del model
    omega_dot = _columns(eq.angular_acceleration(omega[:, 0], omega[:, 1], omega[:, 2],
                                                 eq.Loads(*fm.T), const))
    fm_smooth = smooth(fm, smoothing_window, min(SMOOTHING_POLYORDER, smoothing_window - 1))
    return Reconstruction(t=flight.t, fm=fm, fm_smooth=fm_smooth, omega_dot=omega_dot,
                          omega_dot_sg=wdot_sg, row_sd=row_sd, fm_sd=fm_sd,
                          residual=residual,
                          rate_rows=rate_rows, rank=rank, smoothing_window=smoothing_window,
                          derivative_window=derivative_window)


SMOOTHING_CHOICES: tuple[str, ...] = ("both", "forces", "none")


def ebm_regression(flight: Flight, rec: Reconstruction, *, smoothing: str = "both",
                   window: int | None = None, wind: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Return the EBM step-2 regression ``y ~ X theta`` (eqs. 33-38).

    ``X`` comes from :func:`aeroid.model.regressors` on the measured states
    (u, v, w give V_T, alpha, beta as in eqs. 14-16) and the measured ``delta``; ``y``
    is the reconstructed ``FM``.

    Smoothing (notes, "Smoothing"): ``"forces"`` smooths only ``y`` (the paper's way);
    ``"both"`` (default) smooths ``y`` and every column of ``X`` with the same SG
    filter; ``"none"`` smooths neither. Decision: "both" smooths the regressor columns
    themselves rather than their inputs (alpha, delta, q): the filter is linear, so
    ``smooth(X theta) = smooth(X) theta`` holds exactly and a noise-free flight keeps
    an exact fit.

    Parameters
    ----------
    flight : Flight
    rec : Reconstruction
        From :func:`reconstruct` on the same flight.
    smoothing : {"both", "forces", "none"}
    window : int, optional
        SG width (default ``rec.smoothing_window``).
    wind : ndarray, shape (n, 3), optional
        NED wind per sample [m/s] replacing the constants' (the logged air data as the
        aerodynamic angles: :func:`aeroid.estimation.air_data_wind`).

    Returns
    -------
    X : ndarray, shape (n, 6, 9)
        Rows ``F_AX, F_AY, F_AZ, M_X, M_Y, M_Z``; columns the nine coefficients.
    y : ndarray, shape (n, 6) [N, N m]
    """
    if smoothing not in SMOOTHING_CHOICES:
        raise ValueError(f"smoothing must be one of {', '.join(SMOOTHING_CHOICES)}, "
                         f"got {smoothing!r}")
    if rec.fm.shape[0] != flight.n_samples:
        raise ValueError(f"reconstruction has {rec.fm.shape[0]} samples, flight "
                         f"{flight.n_samples}")
    window = rec.smoothing_window if window is None else int(window)
    const = sample_constants(flight)
    if wind is not None:
        const = const._replace(wind_n=wind[:, 0], wind_e=wind[:, 1], wind_d=wind[:, 2])
    X = regressors(flight.states(), flight["delta"], const)
    if smoothing == "none" or window == 1:
        return X, rec.fm.copy()
    polyorder = min(SMOOTHING_POLYORDER, window - 1)
    y = rec.fm_smooth.copy() if window == rec.smoothing_window else smooth(rec.fm, window,
                                                                          polyorder)
    if smoothing == "both":
        X = smooth(X, window, polyorder, axis=0)
    return X, y


def regression_fit(rec: Reconstruction, X: np.ndarray, y: np.ndarray, theta: np.ndarray,
                   rows: tuple[int, ...]) -> dict[str, dict[str, Any]]:
    """Return the fit-check entries of an EBM second step: residuals and yardsticks.

    For each used row of ``F_AX .. M_Z``: the residual ``y - X theta`` of the regression
    (``fit_residuals``) and, as the yardstick, the sensors' noise propagated into that
    load (``fit_noise_sd``, :attr:`Reconstruction.fm_sd`: the roll moment's comes from
    the wide roll-rate derivative, whose coloured noise a smoother's residual cannot
    see); see :mod:`aeroid.estimation._fitcheck`.

    ``X`` is the (n, 6, 9) array, or an iterable of the ``(start, stop, X[start:stop])``
    blocks of :func:`aeroid.estimation.regressor_blocks` (residuals computed block by block).
    """
    theta = np.asarray(theta, dtype=float)
    blocks = [(0, y.shape[0], X)] if isinstance(X, np.ndarray) else X
    residuals = {FM_NAMES[r]: np.empty(y.shape[0]) for r in rows}
    for start, stop, part in blocks:
        for r in rows:
            residuals[FM_NAMES[r]][start:stop] = y[start:stop, r] - part[:, r] @ theta
    return {"fit_residuals": residuals,
            "fit_noise_sd": {FM_NAMES[r]: float(rec.fm_sd[r]) for r in rows},
            "fit_signals": {FM_NAMES[r]: rec.fm[:, r] for r in rows}}
