"""Generic filter loops on filterpy's EKF and UKF for any discrete-time model (private).

The loops take a :class:`DiscreteModel` (transition ``f``, measurement ``h``, their
Jacobians, batched versions), so the same code runs the 18-state augmented airframe
model of :mod:`baselines.ekf` / :mod:`baselines.ukf` and the small linear models the
tests compare with a hand-written Kalman filter.

How filterpy 2.0 is adapted (its source was read):

* ``ExtendedKalmanFilter.predict`` is linear (``x = F x + B u``, then
  ``P = F P F^T + Q``). :class:`_NonlinearEKF` overrides ``predict_x`` so the state is
  propagated by the nonlinear model, and the loop sets ``F`` to the exact Jacobian
  evaluated at the posterior before calling ``predict``; ``update`` (Joseph form) is
  filterpy's, given ``Hx``/``HJacobian`` callables evaluated once per step.
* ``UnscentedKalmanFilter.compute_process_sigmas`` calls ``fx`` once per sigma point.
  :class:`_BatchedUKF` overrides it to propagate all sigma points in one batched call,
  and ``cross_variance`` (a loop of outer products) by one matrix product, and
  :class:`_MerwePoints` sets the sigma points without filterpy's loop over the rows;
  for the measurement, ``update`` also loops over sigma points with ``hx``: the loop
  evaluates the batched measurement once and hands filterpy a callable that returns the
  precomputed rows in filterpy's iteration order (:class:`_RowFeed`). Mean, covariance,
  cross-covariance and gain are filterpy's.

After every update the covariance is symmetrised, ``P <- (P + P^T) / 2``, and checked
by a Cholesky factorisation: the first sample where it fails (or a diagonal entry is not
positive, or the state is not finite) stops the loop and is reported.
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter, MerweScaledSigmaPoints, UnscentedKalmanFilter


@dataclass(frozen=True)
class DiscreteModel:
    """A discrete-time model ``x_{k+1} = f(x_k, k)``, ``z_k = h(x_k, k)``.

    Attributes
    ----------
    dim_x, dim_z : int
    transition : callable ``(x (dim_x,), k) -> (x_next (dim_x,), F (dim_x, dim_x))``
        State at sample ``k + 1`` from the state at ``k``, and its exact Jacobian.
    observe : callable ``(x (dim_x,), k) -> (z (dim_z,), H (dim_z, dim_x))``
    transition_batch : callable ``(X (n, dim_x), k) -> (n, dim_x)``, optional
        ``transition`` without the Jacobian for many states at once (UKF).
    observe_batch : callable ``(X (n, dim_x), k) -> (n, dim_z)``, optional
    """

    dim_x: int
    dim_z: int
    transition: Callable[[np.ndarray, int], tuple[np.ndarray, np.ndarray]]
    observe: Callable[[np.ndarray, int], tuple[np.ndarray, np.ndarray]]
    transition_batch: Callable[[np.ndarray, int], np.ndarray] | None = None
    observe_batch: Callable[[np.ndarray, int], np.ndarray] | None = None


def with_sensor_errors(model: DiscreteModel, n_errors: int) -> DiscreteModel:
    """Return ``model`` with constant sensor errors appended to its state.

    ``n_errors`` is ``dim_z`` (a bias per measurement) or ``2 dim_z`` (bias, then scale
    factor): the measurement becomes ``(1 + s) h(x) + b``, the errors constant in the
    transition (Jacobian identity), exact Jacobians ``(1 + s) dh/dx``, ``I``, ``diag h``.
    """
    m, n = model.dim_z, model.dim_x
    if n_errors not in (m, 2 * m):
        raise ValueError(f"sensor errors: {n_errors} for {m} measurements (bias, or bias "
                         "and scale factor, per measurement)")

    def split(z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        b = z[..., n:n + m]
        s = z[..., n + m:] if n_errors == 2 * m else np.zeros_like(b)
        return z[..., :n], b, s

    def transition(z: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        x, _, _ = split(z)
        x_next, F = model.transition(x, k)
        out = np.eye(n + n_errors)
        out[:n, :n] = F
        return np.concatenate([x_next, z[n:]]), out

    def observe(z: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        x, b, s = split(z)
        y, H = model.observe(x, k)
        blocks = [(1.0 + s)[:, None] * H, np.eye(m)]
        if n_errors == 2 * m:
            blocks.append(np.diag(y))
        return (1.0 + s) * y + b, np.hstack(blocks)

    transition_batch = observe_batch = None
    if model.transition_batch is not None and model.observe_batch is not None:
        base_f, base_h = model.transition_batch, model.observe_batch

        def transition_batch(Z: np.ndarray, k: int) -> np.ndarray:
            return np.concatenate([base_f(Z[:, :n], k), Z[:, n:]], axis=1)

        def observe_batch(Z: np.ndarray, k: int) -> np.ndarray:
            X, b, s = split(Z)
            return (1.0 + s) * base_h(X, k) + b

    return DiscreteModel(n + n_errors, m, transition, observe, transition_batch,
                         observe_batch)


@dataclass(frozen=True)
class FilterOutput:
    """What a filter pass returns.

    Attributes
    ----------
    x : ndarray, shape (n, dim_x)
        Posterior mean at each sample (rows after a failure are NaN).
    sd : ndarray, shape (n, dim_x)
        Posterior standard deviations (sqrt of the diagonal of P).
    P : ndarray, shape (dim_x, dim_x)
        Posterior covariance at the last good sample.
    failed_at : int or None
        Sample index at which the covariance stopped being positive definite.
    reason : str
    innovation : ndarray, shape (n, dim_z)
        Measurement minus its prediction before each update (rows after a failure NaN).
    innovation_var, noise_var : ndarray, shape (n, dim_z), optional
        Diagonals of the innovation covariance ``S_k = H P_k^- H^T + R_k`` and of the
        measurement-noise covariance ``R_k`` used in each update: ``E[innovation^2] =
        innovation_var`` when the filter's model and noise are right, and
        ``innovation_var - noise_var`` is the part due to the state's uncertainty.
    neg_log_likelihood : float  ``sum_k (log det S_k + e_k' S_k^-1 e_k) / 2`` (NaN: failed)
    """

    x: np.ndarray
    sd: np.ndarray
    P: np.ndarray
    failed_at: int | None
    reason: str
    innovation: np.ndarray
    innovation_var: np.ndarray | None = None
    noise_var: np.ndarray | None = None
    neg_log_likelihood: float = np.nan


class _NonlinearEKF(ExtendedKalmanFilter):
    """filterpy's EKF whose state prediction is the model's nonlinear transition."""

    def __init__(self, dim_x: int, dim_z: int) -> None:
        super().__init__(dim_x, dim_z)
        self.x_next: np.ndarray | None = None

    def predict_x(self, u: object = 0) -> None:
        """Set the prior mean to the precomputed nonlinear prediction ``x_next``."""
        self.x = np.asarray(self.x_next, dtype=float).reshape(-1, 1)


class _BatchedUKF(UnscentedKalmanFilter):
    """filterpy's UKF propagating all sigma points in one batched call."""

    batch_fx: Callable[[np.ndarray], np.ndarray]

    def compute_process_sigmas(self, dt: float, fx: object = None, **fx_args: object) -> None:
        """Propagate every sigma point with one call of ``self.batch_fx``."""
        sigmas = self.points_fn.sigma_points(self.x, self.P)
        self.sigmas_f = np.asarray(self.batch_fx(sigmas), dtype=float)

    def cross_variance(self, x: np.ndarray, z: np.ndarray, sigmas_f: np.ndarray,
                       sigmas_h: np.ndarray) -> np.ndarray:
        """filterpy's state-measurement cross-covariance as one product (its loop of
        outer products over the sigma points, with the plain differences as residuals)."""
        return (self.Wc[:, None] * (sigmas_f - x)).T @ (sigmas_h - z)


class _MerwePoints(MerweScaledSigmaPoints):
    """filterpy's scaled sigma points with the rows set in two array operations."""

    def sigma_points(self, x: np.ndarray, P: np.ndarray) -> np.ndarray:
        """``[x, x + U_k, x - U_k]``, ``U`` filterpy's square root of ``(lambda + n) P``
        (its loop over the rows, the plain difference as ``subtract``)."""
        n = self.n
        x = np.asarray(x, dtype=float).reshape(n)
        lambda_ = self.alpha**2 * (n + self.kappa) - n
        U = self.sqrt((lambda_ + n) * np.atleast_2d(P))
        return np.concatenate([x[None, :], x + U, x - U])


class _RowFeed:
    """Callable returning precomputed rows in call order (filterpy's per-sigma ``hx`` loop)."""

    def __init__(self, rows: np.ndarray) -> None:
        self.rows = rows
        self.i = 0

    def __call__(self, _sigma: np.ndarray) -> np.ndarray:
        row = self.rows[self.i]
        self.i += 1
        return row


#: An updated covariance whose smallest eigenvalue is above ``-ROUNDING_RTOL`` times its
#: largest is positive definite up to rounding: ``P - K S K^T`` cancels to the last digits
#: when a measurement pins a direction exactly (noise-free flights: the measurement sd is
#: 1e-4 of the signal while coefficient variances reach 1e5), and its eigenvalues are
#: then known only to about ``n eps |P|`` (n = 18, eps = 2.2e-16: 4e-15). 1e-12 leaves a
#: factor 250 above that; anything more negative is a real divergence.
ROUNDING_RTOL = 1e-12


def _check(P: np.ndarray, x: np.ndarray) -> tuple[str, np.ndarray]:
    """Return ``('', P)`` when P is positive definite (up to rounding) and x finite.

    A covariance that fails the Cholesky factorisation only by rounding
    (:data:`ROUNDING_RTOL`) is replaced by the nearest positive definite matrix with the
    same eigenvectors (eigenvalues clipped to ``ROUNDING_RTOL`` times the largest);
    otherwise the reason is returned.
    """
    if not np.all(np.isfinite(x)) or not np.all(np.isfinite(P)):
        return "non-finite state or covariance", P
    # a diagonal entry <= 0 fails the factorisation too, and is judged by the same
    # rounding test (the UKF's P - K S K^T left -2e-10 beside 6.7e5 on noise-free flights,
    # 3e-16 relative, and used to stop the filter there)
    try:
        np.linalg.cholesky(P)
        return "", P
    except np.linalg.LinAlgError:
        eig, vec = np.linalg.eigh(P)
        if eig[0] < -ROUNDING_RTOL * eig[-1]:
            return "covariance not positive definite (Cholesky failed)", P
        eig = np.maximum(eig, ROUNDING_RTOL * eig[-1])
        return "", (vec * eig) @ vec.T


def _finish(xs: np.ndarray, sds: np.ndarray, P: np.ndarray, k: int | None,
            reason: str, innovation: np.ndarray, s_var: np.ndarray,
            r_var: np.ndarray, nll: float = np.nan) -> FilterOutput:
    if k is not None:
        for a in (xs, sds, innovation, s_var, r_var):
            a[k:] = np.nan
    return FilterOutput(xs, sds, P, k, reason, innovation, s_var, r_var, float(nll))


@contextlib.contextmanager
def collapsed_warnings() -> Iterator[None]:
    """Issue each warning raised inside once per place, with how often it was raised.

    filterpy inverts the innovation covariance at every sample; on a flight with
    accelerations 1e150 m/s^2 scipy warned "ill-conditioned matrix" 2003 times per pass
    (4006 lines on stderr), each with its own rcond. Here it is one warning:
    ``LinAlgWarning (2003 times in this filter pass; first: ...)``.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield
    seen: dict[tuple, list] = {}
    for w in caught:
        entry = seen.setdefault((w.category, w.filename, w.lineno), [w, 0])
        entry[1] += 1
    for w, count in seen.values():
        text = " ".join(str(w.message).split())
        if count > 1:
            text = f"{text} (and {count - 1} more like it in this filter pass)"
        warnings.warn_explicit(text, w.category, w.filename, w.lineno)


def run_ekf(model: DiscreteModel, x0: np.ndarray, P0: np.ndarray, Q: np.ndarray,
            R: np.ndarray, zs: np.ndarray,
            R_of: Callable[[np.ndarray], np.ndarray] | None = None) -> FilterOutput:
    """Run :func:`_run_ekf` with its repeated warnings collapsed (:func:`collapsed_warnings`)."""
    with collapsed_warnings():
        return _run_ekf(model, x0, P0, Q, R, zs, R_of)


def _run_ekf(model: DiscreteModel, x0: np.ndarray, P0: np.ndarray, Q: np.ndarray,
             R: np.ndarray, zs: np.ndarray,
             R_of: Callable[[np.ndarray], np.ndarray] | None = None) -> FilterOutput:
    """Run filterpy's EKF with the model's nonlinear prediction over measurements ``zs``.

    Sample 0 is an update of the prior ``(x0, P0)`` with ``zs[0]``; each later sample
    is a prediction from the previous one followed by an update.

    Parameters
    ----------
    model : DiscreteModel
    x0 : ndarray, shape (dim_x,)
    P0, Q : ndarray, shape (dim_x, dim_x)
        Initial and per-step process-noise covariance.
    R : ndarray, shape (dim_z, dim_z)
    zs : ndarray, shape (n, dim_z)
    R_of : callable, optional
        ``R_of(z_pred) -> (dim_z, dim_z)``: a measurement-noise covariance that depends
        on the predicted measurement (a per-sample noise model); replaces ``R``.

    Returns
    -------
    FilterOutput
    """
    n = zs.shape[0]
    ekf = _NonlinearEKF(model.dim_x, model.dim_z)
    ekf.x = np.asarray(x0, dtype=float).reshape(-1, 1).copy()
    ekf.P = np.array(P0, dtype=float)
    ekf.Q = np.asarray(Q, dtype=float)
    ekf.R = np.asarray(R, dtype=float)
    xs = np.empty((n, model.dim_x))
    sds = np.empty((n, model.dim_x))
    innov = np.empty((n, model.dim_z))
    s_var = np.empty((n, model.dim_z))
    r_var, nll = np.empty((n, model.dim_z)), 0.0
    for k in range(n):
        if k > 0:
            x_next, F = model.transition(ekf.x.ravel(), k - 1)
            ekf.F = np.asarray(F, dtype=float)
            ekf.x_next = x_next
            ekf.predict()
        z_hat, H = model.observe(ekf.x.ravel(), k)
        H = np.asarray(H, dtype=float)
        z_hat = np.asarray(z_hat, dtype=float).reshape(-1, 1)
        innov[k] = zs[k] - z_hat.ravel()
        R_k = ekf.R if R_of is None else R_of(z_hat.ravel())
        ekf.update(zs[k].reshape(-1, 1), HJacobian=lambda _x, H=H: H,
                   Hx=lambda _x, z_hat=z_hat: z_hat, R=R_k)
        s_var[k] = np.diag(ekf.S)
        r_var[k] = np.diag(R_k)
        nll += 0.5 * (np.linalg.slogdet(ekf.S)[1] + innov[k] @ np.linalg.solve(ekf.S, innov[k]))
        ekf.P = 0.5 * (ekf.P + ekf.P.T)
        reason, ekf.P = _check(ekf.P, ekf.x)
        if reason:
            return _finish(xs, sds, ekf.P, k, reason, innov, s_var, r_var)
        xs[k] = ekf.x.ravel()
        sds[k] = np.sqrt(np.diag(ekf.P))
    return _finish(xs, sds, ekf.P, None, "", innov, s_var, r_var, nll)


def run_ukf(model: DiscreteModel, x0: np.ndarray, P0: np.ndarray, Q: np.ndarray,
            R: np.ndarray, zs: np.ndarray, *, alpha: float = 0.5, beta: float = 2.0,
            kappa: float = 0.0,
            R_of: Callable[[np.ndarray], np.ndarray] | None = None) -> FilterOutput:
    """Run :func:`_run_ukf` with its repeated warnings collapsed (:func:`collapsed_warnings`)."""
    with collapsed_warnings():
        return _run_ukf(model, x0, P0, Q, R, zs, alpha=alpha, beta=beta, kappa=kappa,
                        R_of=R_of)


def _run_ukf(model: DiscreteModel, x0: np.ndarray, P0: np.ndarray, Q: np.ndarray,
             R: np.ndarray, zs: np.ndarray, *, alpha: float = 0.5, beta: float = 2.0,
             kappa: float = 0.0,
             R_of: Callable[[np.ndarray], np.ndarray] | None = None) -> FilterOutput:
    """Run filterpy's UKF (Merwe scaled sigma points) with batched sigma-point propagation.

    Same sequence and arguments as :func:`run_ekf` (``R_of`` gets the sigma points'
    weighted mean measurement), plus the sigma-point parameters
    ``alpha``, ``beta``, ``kappa`` of :class:`filterpy.kalman.MerweScaledSigmaPoints`.
    Needs ``model.transition_batch`` and ``model.observe_batch``.
    """
    if model.transition_batch is None or model.observe_batch is None:
        raise ValueError("run_ukf: the model needs transition_batch and observe_batch")
    n = zs.shape[0]
    points = _MerwePoints(model.dim_x, alpha=alpha, beta=beta, kappa=kappa)
    step = {"k": 0}

    def batch_fx(sigmas: np.ndarray) -> np.ndarray:
        return model.transition_batch(sigmas, step["k"])

    def unused_fx(x: np.ndarray, dt: float) -> np.ndarray:  # filterpy requires an fx
        raise AssertionError("per-sigma fx must not be called: propagation is batched")

    ukf = _BatchedUKF(model.dim_x, model.dim_z, 1.0, hx=None, fx=unused_fx, points=points)
    ukf.batch_fx = batch_fx
    ukf.x = np.asarray(x0, dtype=float).copy()
    ukf.P = np.array(P0, dtype=float)
    ukf.Q = np.asarray(Q, dtype=float)
    ukf.R = np.asarray(R, dtype=float)
    ukf.sigmas_f = points.sigma_points(ukf.x, ukf.P)
    xs = np.empty((n, model.dim_x))
    sds = np.empty((n, model.dim_x))
    innov = np.empty((n, model.dim_z))
    s_var = np.empty((n, model.dim_z))
    r_var, nll = np.empty((n, model.dim_z)), 0.0
    for k in range(n):
        if k > 0:
            step["k"] = k - 1
            try:
                ukf.predict()
            except np.linalg.LinAlgError:
                return _finish(xs, sds, ukf.P, k, "sigma points: Cholesky of P failed", innov,
                               s_var, r_var)
        rows = np.asarray(model.observe_batch(ukf.sigmas_f, k), dtype=float)
        R_k = ukf.R if R_of is None else R_of(points.Wm @ rows)
        ukf.update(zs[k], R=R_k, hx=_RowFeed(rows))
        innov[k] = ukf.y
        s_var[k] = np.diag(ukf.S)
        r_var[k] = np.diag(R_k)
        nll += 0.5 * (np.linalg.slogdet(ukf.S)[1] + innov[k] @ np.linalg.solve(ukf.S, innov[k]))
        ukf.P = 0.5 * (ukf.P + ukf.P.T)
        reason, ukf.P = _check(ukf.P, ukf.x)
        if reason:
            return _finish(xs, sds, ukf.P, k, reason, innov, s_var, r_var)
        xs[k] = ukf.x
        sds[k] = np.sqrt(np.diag(ukf.P))
    return _finish(xs, sds, ukf.P, None, "", innov, s_var, r_var, nll)
