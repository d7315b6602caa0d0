"""The paper's cost functions (eqs. 23, 34, 39-42), vectorised over a swarm.

Every cost takes ``theta`` of shape (P, k) (or (k,)) and returns (P,) costs (a float
for a single vector), so one call evaluates a whole PSO swarm.

Weighting (notes, "Objectives")
-------------------------------
``"noise"`` (default)
    Maximum likelihood for Gaussian noise: each channel's residual is divided by the
    channel's noise sd, estimated from the data with
    :func:`aeroid.estimation.estimate_noise_sd` (robust spread of the residual of the 7-point
    SG smoother; for the EBM's reconstructed forces, of the *unsmoothed* series). One
    constant per channel.
``"relative"``
    The paper's form: each residual divided by the measured value. Rates, lateral
    accelerations, F_AZ and M_Y pass through zero in a rolling airframe, so samples
    whose ``|denominator| < guard_fraction * RMS(channel)`` are left out of that
    channel's sum (default ``guard_fraction`` = :data:`GUARD_FRACTION` = 0.05: drops
    the ~4 % of a sinusoid's samples nearest zero, where the weight would exceed 400
    times the channel's typical weight).

Both forms are ``J = (1/N) sum_k sum_c w_kc (z_kc - zhat_kc)^2`` with ``N`` the number
of samples (the guard only removes terms, as in the paper's 1/N normalisation).

Equation-error costs (EBM, SEBM) are quadratic in the coefficients, so
:class:`QuadraticCost` evaluates them exactly as ``J_min + (theta - theta*)^T H
(theta - theta*)`` (microseconds per swarm) and gives the closed-form optimum
``theta*``, the yardstick for the PSO's answer.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from scipy.signal import savgol_filter

from aeroid.estimation._reconstruct import Reconstruction, ebm_regression
from aeroid.estimation._signals import estimate_noise_sd, smooth
from aeroid.flights import Flight, flight_record, model_constants
from aeroid.model import DEFAULT_REL_STEP, PHI, THETA, ForwardModel, P, Q, R

__all__ = [
    "EAM_OUTPUTS",
    "EBM_ROWS",
    "GUARD_FRACTION",
    "SEBM_PROBLEMS",
    "SebmProblem",
    "WEIGHTINGS",
    "OutputErrorCost",
    "QuadraticCost",
    "channel_weights",
    "ebm_cost",
    "sebm_costs",
]

WEIGHTINGS: tuple[str, ...] = ("noise", "relative")
#: Guard of the relative weighting: samples with |measured| below this fraction of the
#: channel RMS are left out (module docstring).
GUARD_FRACTION = 0.05
#: Rows of the EBM cost (eq. 34): F_AX, F_AZ, M_X, M_Y in the (FAX..MZ) layout.
EBM_ROWS: tuple[int, ...] = (0, 2, 3, 4)
class SebmProblem(NamedTuple):
    """One SEBM sub-problem (eqs. 39-42): a load row and the coefficients it estimates.

    ``label`` names the load (:data:`aeroid.model.FM_NAMES` without underscore), ``row``
    its index in the (FAX..MZ) layout, ``coefficients`` the indices into
    :data:`aeroid.model.NAMES`, ``particles`` the paper's swarm size.
    """

    label: str
    row: int
    coefficients: tuple[int, ...]
    particles: int


#: The SEBM sub-problems (eqs. 39-42), written once: SEBM-PSO's four swarms and
#: equation-error's four least-squares problems (``baselines/equation_error.py``).
SEBM_PROBLEMS: tuple[SebmProblem, ...] = (
    SebmProblem("FAX", 0, (0,), 50),
    SebmProblem("FAZ", 2, (1, 2, 3), 150),
    SebmProblem("MX", 3, (4, 5), 100),
    SebmProblem("MY", 4, (6, 7, 8), 150),
)
#: How EAM takes the initial rates (:class:`OutputErrorCost`).
INITIAL_STATES: tuple[str, ...] = ("smoothed", "kinematic")
#: SG window for the initial roll rate [samples] (p is slow; see OutputErrorCost).
EAM_ROLL_WINDOW = 501
#: EAM outputs (eq. 23): triad-1 accelerations and the body rates.
EAM_OUTPUTS: tuple[str, ...] = ("ax1", "ay1", "az1", "p", "q", "r")


def _check_weighting(weighting: str, guard_fraction: float) -> None:
    if weighting not in WEIGHTINGS:
        raise ValueError(f"weighting must be one of {', '.join(WEIGHTINGS)}, got {weighting!r}")
    if not (np.isfinite(guard_fraction) and 0.0 <= guard_fraction < 1.0):
        raise ValueError(f"guard_fraction must be in [0, 1), got {guard_fraction!r}")


def channel_weights(z: np.ndarray, weighting: str = "noise", *,
                    sd: np.ndarray | None = None,
                    guard_fraction: float = GUARD_FRACTION) -> np.ndarray:
    """Return per-sample, per-channel weights ``w`` of ``J = (1/N) sum w (z - zhat)^2``.

    Parameters
    ----------
    z : ndarray, shape (n, m)
        Measured channels (the denominators of the relative form).
    weighting : {"noise", "relative"}
    sd : ndarray, shape (m,), optional
        Noise sd per channel for ``"noise"`` (default :func:`estimate_noise_sd` of ``z``).
    guard_fraction : float
        Relative form only: samples with ``|z| < guard_fraction * RMS`` get weight 0.

    Returns
    -------
    ndarray, shape (n, m)
        ``1 / sd^2`` (noise) or ``1 / z^2`` with guarded samples 0 (relative).
    """
    _check_weighting(weighting, guard_fraction)
    z = np.asarray(z, dtype=float)
    if weighting == "noise":
        sd = estimate_noise_sd(z) if sd is None else np.asarray(sd, dtype=float)
        return np.broadcast_to(1.0 / sd**2, z.shape).copy()
    rms = np.sqrt(np.mean(z * z, axis=0))
    keep = np.abs(z) >= guard_fraction * rms
    keep &= z != 0.0
    w = np.zeros_like(z)
    w[keep] = 1.0 / z[keep] ** 2
    return w


class QuadraticCost:
    """``J(theta) = (1/N) sum_k sum_c w_kc (y_kc - X_kc theta)^2`` for linear models.

    Parameters
    ----------
    X : ndarray, shape (n, m, k)
        Regressors per sample and channel.
    y : ndarray, shape (n, m)
        Targets.
    weights : ndarray, shape (n, m)
        Non-negative weights (:func:`channel_weights`).

    Attributes
    ----------
    hessian : ndarray, shape (k, k)
        ``H = (1/N) sum w X^T X`` (half the Hessian of J).
    theta_opt : ndarray, shape (k,)
        Closed-form minimiser (weighted least squares, columns scaled for conditioning;
        minimum norm if rank deficient).
    cost_min : float
        ``J(theta_opt)`` from the residual form.
    """

    def __init__(self, X: np.ndarray, y: np.ndarray, weights: np.ndarray) -> None:
        X = np.asarray(X, dtype=float)
        y = np.asarray(y, dtype=float)
        weights = np.asarray(weights, dtype=float)
        if X.ndim != 3 or y.shape != X.shape[:2] or weights.shape != y.shape:
            raise ValueError(f"QuadraticCost: shapes X {X.shape}, y {y.shape}, "
                             f"weights {weights.shape} do not fit (n, m, k), (n, m), (n, m)")
        if not (np.all(np.isfinite(X)) and np.all(np.isfinite(y))
                and np.all(np.isfinite(weights)) and np.all(weights >= 0)):
            raise ValueError("QuadraticCost: non-finite regressors, targets or weights")
        self.X, self.y, self.weights = X, y, weights
        self.n_samples = X.shape[0]
        sw = np.sqrt(weights).reshape(-1)
        A = X.reshape(-1, X.shape[2]) * sw[:, None]
        b = y.reshape(-1) * sw
        scale = np.sqrt(np.sum(A * A, axis=0))
        scale[scale == 0] = 1.0
        sol = np.linalg.lstsq(A / scale, b, rcond=None)[0]
        self.theta_opt = sol / scale
        self.hessian = (A.T @ A) / self.n_samples
        self.cost_min = float(self.direct(self.theta_opt))

    @property
    def n_params(self) -> int:
        """Number of coefficients k."""
        return int(self.X.shape[2])

    def __call__(self, theta: np.ndarray) -> np.ndarray | float:
        """Return J for ``theta`` of shape (P, k) -> (P,) or (k,) -> float (quadratic form)."""
        t = np.asarray(theta, dtype=float)
        d = np.atleast_2d(t) - self.theta_opt
        quad = np.einsum("pi,ij,pj->p", d, self.hessian, d)
        cost = self.cost_min + np.maximum(quad, 0.0)
        return float(cost[0]) if t.ndim == 1 else cost

    def direct(self, theta: np.ndarray) -> np.ndarray | float:
        """Return J from the residuals (the definition); same shapes as :meth:`__call__`."""
        t = np.asarray(theta, dtype=float)
        pred = np.einsum("nmk,pk->pnm", self.X, np.atleast_2d(t))
        cost = np.sum(self.weights * (self.y - pred) ** 2, axis=(1, 2)) / self.n_samples
        return float(cost[0]) if t.ndim == 1 else cost


def ebm_cost(flight: Flight, rec: Reconstruction, *, weighting: str = "noise",
             smoothing: str = "both", rows: Sequence[int] = EBM_ROWS,
             guard_fraction: float = GUARD_FRACTION, wind: np.ndarray | None = None
             ) -> QuadraticCost:
    """Return the EBM second-step cost (eq. 34) over the nine coefficients (``wind``:
    :func:`aeroid.estimation.ebm_regression`'s).

    Parameters
    ----------
    flight : Flight
    rec : Reconstruction
        EBM step 1 (:func:`aeroid.estimation.reconstruct`).
    weighting : {"noise", "relative"}
        Noise sd of each channel from the unsmoothed reconstruction ``rec.fm``;
        the relative form divides by the (smoothed, per ``smoothing``) target.
    smoothing : {"both", "forces", "none"}
        See :func:`aeroid.estimation.ebm_regression`.
    rows : sequence of int
        Channels of (F_AX, F_AY, F_AZ, M_X, M_Y, M_Z) used; default the paper's four.
    guard_fraction : float

    Returns
    -------
    QuadraticCost
        Over ``theta`` of shape (P, 9).
    """
    rows = _check_rows(rows)
    X, y = ebm_regression(flight, rec, smoothing=smoothing, wind=wind)
    X, y = X[:, rows], y[:, rows]
    w = channel_weights(y, weighting, sd=estimate_noise_sd(rec.fm[:, rows]),
                        guard_fraction=guard_fraction)
    return QuadraticCost(X, y, w)


def sebm_costs(flight: Flight, rec: Reconstruction, *, weighting: str = "noise",
               smoothing: str = "both", guard_fraction: float = GUARD_FRACTION,
               wind: np.ndarray | None = None) -> list[tuple[str, tuple[int, ...], QuadraticCost]]:
    """Return the four SEBM costs (eqs. 39-42) as ``(label, coefficient indices, cost)``.

    Each cost takes only its own coefficients (1, 3, 2 and 3 of them): F_AX -> Cx;
    F_AZ -> Cza, Czd, Czq; M_X -> Cl0, Clp; M_Y -> Cma, Cmd, Cmq. Weighting and
    smoothing as in :func:`ebm_cost` (with one channel, the noise weighting only
    scales each cost).
    """
    X, y = ebm_regression(flight, rec, smoothing=smoothing, wind=wind)
    sd = estimate_noise_sd(rec.fm)
    out = []
    for label, row, cols, _ in SEBM_PROBLEMS:
        yr = y[:, [row]]
        w = channel_weights(yr, weighting, sd=sd[[row]], guard_fraction=guard_fraction)
        out.append((label, cols, QuadraticCost(X[:, [row]][:, :, list(cols)], yr, w)))
    return out


def _check_rows(rows: Sequence[int]) -> list[int]:
    rows = [int(r) for r in rows]
    if not rows or len(set(rows)) != len(rows) or not all(0 <= r < 6 for r in rows):
        raise ValueError(f"rows must be distinct indices in 0..5 (FAX..MZ), got {rows}")
    return rows


# --------------------------------------------------------------------------------------
# EAM: output error
# --------------------------------------------------------------------------------------
class OutputErrorCost:
    """EAM output-error cost (eq. 23, or its noise-weighted form), vectorised over a swarm.

    Each coefficient set is simulated by :func:`aeroid.model.propagate` (batched
    RK4, all sets at once) from the measured state at the first sample, with the
    measured p, q, r smoothed there (notes, "EAM"), and the measured ``delta`` held over
    each sample interval.

    Initial rates (``initial_state``), a decision the notes leave open in detail:

    * ``"smoothed"`` (default, the notes' decision): q and r are the 7-point quadratic
      SG fit (eq. 32) evaluated at the first sample; p, which varies slowly (roll time
      constant ~3 s), is the quadratic SG fit over ``roll_window`` samples (default
      501, clipped to the record) at the first sample. A 7-point fit leaves ~1 rad/s of
      the paper's roll-rate noise in p0, and the simulated roll angle then drifts by up
      to 1 rad over the record: the cost at the true coefficients grows ~50-fold
      (measured) and the fit bends Cl0, Clp to follow.
    * ``"kinematic"``: p0 from the roll angle instead, ``p = phidot - (q sin phi + r cos
      phi) tan theta`` (eq. 8) with phidot the 7-point SG derivative of the measured
      phi (noise-free in the paper's noise model, so p0 is then nearly exact).

    The outputs are triad 1's accelerations at the estimator's position of triad 1,
    including the lever-arm terms (eq. 28 with eqs. 5-7), and p, q, r. Diverging
    trajectories cost +inf.

    Parameters
    ----------
    flight : Flight
    weighting : {"noise", "relative"}
    guard_fraction : float
    substeps : int
        RK4 steps per sample interval.
    backend : {"auto", "numba", "numpy"}
        Integration and cost backend (same numbers, tested).
    initial_state : {"smoothed", "kinematic"}
        How the initial rates are taken (above).
    roll_window : int
        SG window for p0 with ``"smoothed"`` [samples].
    input : {"hold", "midpoint", "events", "law"}
        How the deflection between samples is modelled (:data:`aeroid.flights.INPUTS`);
        the flight's per-sample channels (density, mass, thrust, inertias) are used.
    delay_s : float
        Actuator time delay of the input [s].

    Attributes
    ----------
    measured : ndarray, shape (n, 6)
        ``ax1, ay1, az1`` [m/s^2], ``p, q, r`` [rad/s].
    weights : ndarray, shape (n, 6)
    state0 : ndarray, shape (9,)
    """

    def __init__(self, flight: Flight, *, weighting: str = "noise",
                 guard_fraction: float = GUARD_FRACTION, substeps: int = 1,
                 backend: str = "auto", initial_state: str = "smoothed",
                 roll_window: int = EAM_ROLL_WINDOW, input: str = "hold",  # noqa: A002
                 delay_s: float = 0.0) -> None:
        _check_weighting(weighting, guard_fraction)
        if initial_state not in INITIAL_STATES:
            raise ValueError(f"initial_state must be one of {', '.join(INITIAL_STATES)}, "
                             f"got {initial_state!r}")
        if int(substeps) < 1:
            raise ValueError(f"substeps must be >= 1, got {substeps}")
        if backend not in ("auto", "numba", "numpy"):
            raise ValueError(f"backend must be auto, numba or numpy, got {backend!r}")
        self.delta = flight["delta"]
        self.measured = np.column_stack([flight[c] for c in EAM_OUTPUTS])
        self.weights = channel_weights(self.measured, weighting, guard_fraction=guard_fraction)
        states = flight.states()
        self.state0 = states[0].copy()
        n_odd = flight.n_samples - 1 + flight.n_samples % 2
        window = min(7, n_odd)
        self.state0[[P, Q, R]] = smooth(states[:, [P, Q, R]], window, min(2, window - 1))[0]
        if initial_state == "smoothed":
            w = min(int(roll_window), n_odd)
            self.state0[P] = smooth(states[:w, P], w, min(2, w - 1))[0]
        else:
            phi, theta = states[0, PHI], states[0, THETA]
            phidot = savgol_filter(states[:, PHI], window, min(2, window - 1), deriv=1,
                                   delta=flight.dt, mode="interp")[0]
            q0, r0 = self.state0[Q], self.state0[R]
            self.state0[P] = phidot - (q0 * np.sin(phi) + r0 * np.cos(phi)) * np.tan(theta)
        self.initial_state = initial_state
        self.record = flight_record(flight, input, delay_s)
        self.model = ForwardModel(model_constants(flight), self.record,
                                  flight.airframe.accel_positions[:1], substeps=substeps,
                                  backend=backend)

    def simulate(self, theta: np.ndarray) -> np.ndarray:
        """Return the predicted states, shape (P, n, 9)."""
        return self.model.states(self.state0, theta)

    def predict(self, theta: np.ndarray, state0: np.ndarray | None = None) -> np.ndarray:
        """Return predicted outputs ``ax1, ay1, az1, p, q, r``, shape (P, n, 6).

        ``state0`` (9,) replaces :attr:`state0` (e.g. initial rates fitted by the polish).
        """
        return self.model.outputs(self.state0 if state0 is None else state0, theta)

    def __call__(self, theta: np.ndarray) -> np.ndarray | float:
        """Return J for ``theta`` (P, 9) -> (P,) or (9,) -> float; non-finite -> +inf."""
        t = np.asarray(theta, dtype=float)
        cost = self.model.cost(self.state0, np.atleast_2d(t), self.measured, self.weights)
        return float(cost[0]) if t.ndim == 1 else cost

    def residuals(self, theta: np.ndarray, state0: np.ndarray | None = None) -> np.ndarray:
        """Return the weighted output errors ``r`` with ``J = sum r^2``, shape (6 n,).

        ``r_kc = sqrt(w_kc / n) (z_kc - zhat_kc)`` for one coefficient set ``theta`` (9,),
        sample-major (the six outputs of a sample are consecutive), simulated from
        ``state0`` (default :attr:`state0`). NaN where the simulation diverged.
        """
        pred = self.predict(np.asarray(theta, dtype=float).reshape(1, -1), state0)[0]
        return (np.sqrt(self.weights / self.model.n_samples) * (self.measured - pred)).ravel()

    def jacobian(self, theta: np.ndarray, state0: np.ndarray | None = None, *,
                 free_states: Sequence[str] = (), rel_step: float = DEFAULT_REL_STEP
                 ) -> np.ndarray:
        """Return ``d r / d (theta, x0)`` of :meth:`residuals`, shape (6 n, 9 + f).

        Columns: the nine coefficients, then the initial-state components named in
        ``free_states`` (e.g. ``("p", "q", "r")``). Central differences of the forward
        model with the relative step ``rel_step``
        (:meth:`aeroid.model.ForwardModel.sensitivities`): all perturbed sets are
        simulated in one batched call (18 for the coefficients alone).
        """
        sens = self.model.sensitivities(self.state0 if state0 is None else state0,
                                        np.asarray(theta, dtype=float),
                                        free_states=free_states, rel_step=rel_step)
        scale = np.sqrt(self.weights / self.model.n_samples)[:, :, None]
        return (-scale * sens).reshape(-1, sens.shape[-1])
