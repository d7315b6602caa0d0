"""The filter-error method's filter: an EKF with NED gust states, many parameter sets at once.

The filter's state is the model's state ``x`` and the wind ``w`` [m/s, NED] the loads see
(the air's velocity over the ground: a steady part ``w_s``, a parameter, plus a gust
``g = w - w_s``). Each gust component is a first-order Gauss-Markov process, Dryden's
first-order approximation (time constant ``tau = L / V``, intensity ``sigma``):

    g_{k+1} = a g_k + n_k,    a = exp(-dt / tau),    n_k ~ N(0, sigma^2 (1 - a^2) I),

started stationary (``g_0 ~ N(0, sigma^2 I)``). Over a sample interval the wind is held
at ``w_k`` in the loads. The transition and measurement of ``[x, theta, w]`` and their
exact Jacobians are the EKF's steady-wind functions (:mod:`baselines._kalman_wind`,
CasADi AD of the model written once in :mod:`aeroid.model`): the wind there is constant,
here it decays towards ``w_s`` (``F_ww = a I``) and carries the gusts' process noise. The
coefficients ``theta`` are parameters, not states: their columns of the Jacobians are
dropped. Gusts fixed in the air turn in body axes at the roll rate; in NED they do not,
and the measurement's Jacobian ``H = dh/d(x, w)`` turns with the roll angle: the gain is
time-varying (the README's section on the failed steady-gain prototype).

The runs of one call are independent filters (the finite-difference perturbations of
:mod:`baselines._fem_fit`), evaluated together: one CasADi call per sample maps the
transition over all runs, the covariance algebra is batched numpy.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import casadi as ca
import numpy as np

from aeroid.flights import Flight, flight_record, model_constants
from aeroid.model import EXOGENOUS, N_STATE, Buffered, Constants
from baselines._fem_model import N_FILTER, N_WIND, gust_functions


class FilterRuns(NamedTuple):
    """The innovations of ``r`` filter runs over ``n`` samples, ``m`` outputs.

    Attributes
    ----------
    innovation : ndarray, shape (r, n, m)
        Measurement minus its prediction before each update.
    S : ndarray, shape (r, n, m, m)
        Innovation covariance ``H P^- H^T + R``.
    ok : ndarray, shape (r,), bool
        False where a run's state or covariance stopped being finite or S positive definite.
    x : ndarray, shape (r, n, N_FILTER)
        Filtered state ``[x, w]`` at each sample.
    """

    innovation: np.ndarray
    S: np.ndarray
    ok: np.ndarray
    x: np.ndarray


@dataclass(frozen=True)
class GustModel:
    """The flight's transition and measurement with the wind as states (CasADi).

    Build with :func:`gust_model`. ``f(xw, theta, pieces, exo_a, exo_b) -> (x_next,
    dx_next/dxw)`` and ``h(xw, theta, delta, exo, positions) -> (y, dy/dxw)`` for the
    filter's state ``xw = [x, w]`` (:mod:`baselines._fem_model`).
    """

    f: ca.Function
    h: ca.Function
    delta: np.ndarray
    pieces: np.ndarray
    exo: np.ndarray
    positions: np.ndarray
    dt: float
    compiled: bool

    @property
    def n_samples(self) -> int:
        """Samples of the record."""
        return int(self.delta.size)


def gust_model(flight: Flight, substeps: int, input: str, delay_s: float,  # noqa: A002
               compile_model: bool = True) -> GustModel:
    """The model of ``flight`` with the wind as states, accelerometers at the airframe's
    positions (:func:`baselines._fem_model.gust_functions`)."""
    record = flight_record(flight, input, delay_s)
    const = Constants(*(float(v) for v in model_constants(flight)))
    varying = record.exogenous is not None
    if varying:  # the per-sample values replace the exogenous fields (as wind_model)
        const = const._replace(**dict.fromkeys(EXOGENOUS, 0.0))
    delta, pieces, exo = record.symbolic_inputs()
    f, h, compiled = gust_functions(const, float(record.dt), int(substeps),
                                    int(record.n_pieces), varying, compile_model)
    return GustModel(f, h, delta[0], pieces, exo, flight.airframe.accel_positions.ravel(),
                     float(record.dt), compiled)


_WIND = slice(N_STATE, N_FILTER)


def run_filters(model: GustModel, theta: np.ndarray, steady: np.ndarray, sigma: np.ndarray,
                decay: float, x0: np.ndarray, P0x: np.ndarray, R: np.ndarray,
                zs: np.ndarray) -> FilterRuns:
    """Run ``r`` gust filters over the measurements ``zs`` (module docstring).

    Parameters
    ----------
    model : GustModel
    theta : ndarray, shape (r, N_COEFFICIENTS)
        Coefficients of each run.
    steady : ndarray, shape (r, N_WIND)
        Steady wind of each run [m/s, NED].
    sigma : ndarray, shape (r,)
        Gust intensity of each run [m/s].
    decay : float
        ``a = exp(-dt / tau)``.
    x0 : ndarray, shape (N_STATE,)
        The model's state at the first sample (every run).
    P0x : ndarray, shape (N_STATE, N_STATE)
        Its covariance.
    R : ndarray, shape (m,) or (n, m)
        Measurement-noise variances (per channel, or per sample and channel).
    zs : ndarray, shape (n, m)

    Returns
    -------
    FilterRuns
    """
    r = theta.shape[0]
    n, m = zs.shape
    R = np.broadcast_to(np.asarray(R, dtype=float), (n, m))
    # numpy buffers shared with CasADi (aeroid.model.Buffered); column-major (., r) inputs
    per_run = [False, False, True, True, True]  # xw, theta per run; the record's shared
    f = Buffered(model.f.map(r, per_run, [False, False]),
                 [np.zeros((N_FILTER, r)), theta.T, model.pieces[:, 0], model.exo[:, 0],
                  model.exo[:, 0]])
    h = Buffered(model.h.map(r, per_run, [False, False]),
                 [np.zeros((N_FILTER, r)), theta.T, model.delta[:1], model.exo[:, 0],
                  model.positions])
    x = np.empty((r, N_FILTER))
    x[:, :N_STATE] = x0
    x[:, _WIND] = steady
    P = np.zeros((r, N_FILTER, N_FILTER))
    P[:, :N_STATE, :N_STATE] = P0x
    P[:, _WIND, _WIND] = (sigma**2)[:, None, None] * np.eye(N_WIND)
    q = (sigma**2 * (1.0 - decay**2))[:, None, None] * np.eye(N_WIND)
    A = np.zeros((r, N_FILTER, N_FILTER))
    A[:, _WIND, _WIND] = decay * np.eye(N_WIND)
    eye_m = np.eye(m)
    innovation = np.empty((r, n, m))
    S_all = np.empty((r, n, m, m))
    xs = np.empty((r, n, N_FILTER))
    ok = np.ones(r, dtype=bool)
    for k in range(n):
        if k > 0:
            f.inputs[2][:] = model.pieces[:, k - 1]  # Buffered's input buffers, in place
            f.inputs[3][:] = model.exo[:, k - 1]
            f.inputs[4][:] = model.exo[:, k]
            x_next, F = f(x.ravel())
            A[:, :N_STATE, :] = F.reshape(r, N_FILTER, N_STATE).transpose(0, 2, 1)
            x[:, _WIND] = steady + decay * (x[:, _WIND] - steady)
            x[:, :N_STATE] = x_next.reshape(r, N_STATE)
            P = A @ P @ A.transpose(0, 2, 1)
            P[:, _WIND, _WIND] += q
        h.inputs[2][0] = model.delta[k]
        h.inputs[3][:] = model.exo[:, k]
        y, H = h(x.ravel())
        H = H.reshape(r, N_FILTER, m)  # H^T per run
        HP = H.transpose(0, 2, 1) @ P  # H P, (r, m, N_FILTER)
        S = S_all[:, k]
        np.matmul(HP, H, out=S)
        S += R[k] * eye_m
        nu = innovation[:, k]
        np.subtract(zs[k], y.reshape(r, m), out=nu)
        try:
            Kt = np.linalg.solve(S, HP)  # K^T = S^-1 H P
        except np.linalg.LinAlgError:
            ok[:] = False
            break
        x += (nu[:, None, :] @ Kt)[:, 0]  # K nu
        P = P - HP.transpose(0, 2, 1) @ Kt  # (I - K H) P = P - P H^T K^T
        P = 0.5 * (P + P.transpose(0, 2, 1))
        xs[:, k] = x
    else:
        ok &= (np.all(np.isfinite(innovation), axis=(1, 2))
               & np.all(np.isfinite(xs), axis=(1, 2)))
    return FilterRuns(innovation, S_all, ok, xs)
