"""The filter-error method's Dryden gusts: the simulator's shaping filters as gust states.

``gust_model = "dryden"`` (:class:`baselines.filter_error.FilterErrorEstimator`): instead
of three first-order Gauss-Markov gusts in NED (:mod:`baselines._fem_filter`), the gust
states are those of the Dryden shaping filters of MIL-F-8785C the simulator draws its
gusts from (:func:`aeroid.flights.shaping_filters`: longitudinal ``1 / (1 + tau s)``,
transverse ``(1 + sqrt(3) tau s) / (1 + tau s)^2``, ``tau = L / V``, sampled exactly at
``dt``), in the path axes (:func:`aeroid.flights.path_axes`) of the record's mean
velocity, as :mod:`aeroid.estimation._air_dryden` uses them. The filter's state is the
model's state ``x`` and the shaping filters' states ``s`` (:data:`N_GUST`); the wind the
loads see is ``w = w_s + C s`` (``C`` (N_WIND, N_GUST): each filter's output row turned
into NED by its path axis), held over a sample interval as in the first-order filter:

    s_{k+1} = Phi s_k + n_k,    n_k ~ N(0, sigma^2 Q1),    s_0 ~ N(0, sigma^2 P1),

``Phi``, ``Q1``, ``P1`` the unit-sd filters' exact transition, one-step noise and
stationary covariance (started stationary). The model's Jacobians are the first-order
filter's (:func:`baselines._fem_model.gust_functions`, exact CasADi AD) times ``C`` in
the wind's columns. Predict and update compiled to C as :mod:`baselines._fem_model`'s.
``FilterRuns.x`` holds ``[x, w]`` (the wind in NED, steady plus gusts), as the
first-order filter's, so the verdicts downstream read it unchanged.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib

import casadi as ca
import numpy as np

from aeroid.flights import (
    Flight,
    body_to_ned,
    flight_record,
    model_constants,
    path_axes,
    shaping_filters,
)
from aeroid.model import (
    EXOGENOUS,
    N_COEFFICIENTS,
    N_STATE,
    OUTPUT_CHANNELS,
    Buffered,
    Constants,
    symbolic,
)
from baselines._fem_filter import FilterRuns, GustModel
from baselines._fem_model import N_FILTER, N_WIND, gust_functions

#: The shaping filters' orders, read from their definitions (one per path axis).
GUST_ORDERS = tuple(s.phi.shape[0] for s in shaping_filters(1.0, sd=1.0, scale_length_m=1.0,
                                                              airspeed_mps=1.0))
#: The gust states: every shaping filter's.
N_GUST = sum(GUST_ORDERS)
#: The Dryden filter's state: the model's, then the gust states.
N_DRYDEN = N_STATE + N_GUST


@dataclasses.dataclass(frozen=True)
class DrydenGust:
    """The unit-sd Dryden gusts of one flight (module docstring).

    Attributes
    ----------
    phi, q1, p1 : ndarray, shape (N_GUST, N_GUST)
        Transition, one-step noise and stationary covariance for a gust sd of 1 m/s.
    c : ndarray, shape (N_WIND, N_GUST)
        The gusts in NED [m/s] from the gust states.
    axes : ndarray, shape (3, 3)
        The path axes' unit vectors in NED as rows.
    tau : float
        ``L / V`` [s].
    """

    phi: np.ndarray
    q1: np.ndarray
    p1: np.ndarray
    c: np.ndarray
    axes: np.ndarray
    tau: float


def mean_velocity_ned(flight: Flight) -> np.ndarray:
    """The record's mean velocity over the ground in NED [m/s] (the path axes' direction:
    the wind is not known before the fit; 5 m/s in 500 turns them by < 0.6 deg)."""
    x = flight.states()
    rot = body_to_ned(x[:, 6], x[:, 7], x[:, 8])
    return np.mean(np.einsum("nij,nj->ni", rot, x[:, :3]), axis=0)


def dryden_gust(dt: float, scale_length_m: float, speed_mps: float,
                velocity_ned: np.ndarray) -> DrydenGust:
    """The unit-sd shaping filters at ``dt`` [s], ``L`` [m], ``V`` [m/s] in the path axes of
    ``velocity_ned`` (module docstring)."""
    filters = shaping_filters(dt, sd=1.0, scale_length_m=scale_length_m,
                              airspeed_mps=speed_mps)
    axes = path_axes(velocity_ned)
    phi, q1, p1 = (np.zeros((N_GUST, N_GUST)) for _ in range(3))
    c = np.zeros((N_WIND, N_GUST))
    start = 0
    for j, s in enumerate(filters):
        block = slice(start, start + s.phi.shape[0])
        phi[block, block] = s.phi
        q1[block, block] = s.noise_sqrt @ s.noise_sqrt.T
        p1[block, block] = s.stationary
        c[:, block] = np.outer(axes[j], np.ravel(s.c))
        start = block.stop
    return DrydenGust(phi, q1, p1, c, axes, scale_length_m / speed_mps)


@functools.lru_cache(maxsize=8)
def dryden_step_functions(const: Constants, dt: float, substeps: int, n_pieces: int,
                          varying: bool, n_outputs: int, compile_model: bool = True,
                          channels: tuple[str, ...] = (), calibration: tuple[str, ...] = ()
                          ) -> tuple[ca.Function, ca.Function, bool]:
    """Return ``predict, update, compiled``: one EKF step of the Dryden gust filter.

    ``predict(xs, P, theta, steady, sigma2, phi, q1, c, pieces, exo_a, exo_b) -> (xs, P)``
    and ``update(xs, P, theta, steady, c, delta, exo, positions, z, R[, cal, probe]) ->
    (xs, P, nu, S)`` on ``xs = [x, s]`` (N_DRYDEN), ``P`` dense column-major; otherwise as
    :func:`baselines._fem_model.step_functions`.
    """
    f, h = gust_functions(const, dt, substeps, n_pieces, varying, channels, calibration)
    xs = ca.SX.sym("xs", N_DRYDEN)
    P = ca.SX.sym("P", N_DRYDEN, N_DRYDEN)
    theta = ca.SX.sym("theta", N_COEFFICIENTS)
    steady = ca.SX.sym("steady", N_WIND)
    sigma2 = ca.SX.sym("sigma2")
    phi, q1 = ca.SX.sym("phi", N_GUST, N_GUST), ca.SX.sym("q1", N_GUST, N_GUST)
    c = ca.SX.sym("c", N_WIND, N_GUST)
    s = xs[N_STATE:]
    xw = ca.vertcat(xs[:N_STATE], steady + c @ s)
    sym = symbolic.interval_symbols(n_pieces, varying)
    x_next, F = f(xw, theta, *sym)
    A = ca.vertcat(ca.horzcat(F[:, :N_STATE], F[:, N_STATE:] @ c),
                   ca.horzcat(ca.SX.zeros(N_GUST, N_STATE), phi))
    Q = ca.diagcat(ca.SX.zeros(N_STATE, N_STATE), sigma2 * q1)
    P_next = A @ P @ A.T + Q
    predict = ca.Function("fem_dryden_predict" + _tag(channels, calibration),
                          [xs, P, theta, steady, sigma2, phi, q1, c, *sym],
                          [ca.vertcat(x_next, phi @ s), ca.densify(0.5 * (P_next + P_next.T))])
    delta = ca.SX.sym("delta")
    exo = ca.SX.sym("exo", sym.exo_a.shape[0])
    pos = ca.SX.sym("pos", 6)
    z = ca.SX.sym("z", n_outputs + len(channels))
    R = ca.SX.sym("R", n_outputs + len(channels))
    air = [ca.SX.sym("cal", len(calibration)), ca.SX.sym("probe", 3)] if channels else []
    y, Hw = h(xw, theta, delta, exo, pos, *air)
    H = ca.horzcat(Hw[:, :N_STATE], Hw[:, N_STATE:] @ c)
    HP = H @ P
    S = HP @ H.T + ca.diag(R)
    Kt = ca.solve(S, HP)  # K^T = S^-1 H P
    nu = z - y
    P_new = P - HP.T @ Kt
    update = ca.Function("fem_dryden_update" + _tag(channels, calibration),
                         [xs, P, theta, steady, c, delta, exo, pos, z, R, *air],
                         [xs + Kt.T @ nu, ca.densify(0.5 * (P_new + P_new.T)), nu,
                          ca.densify(S)])
    if compile_model:
        built = symbolic.compile_functions([predict, update],
                                           "fem_dryden_step" + _tag(channels, calibration))
        if built is not None:
            return built[0], built[1], True
    return predict, update, False


def _tag(channels: tuple[str, ...], calibration: tuple[str, ...]) -> str:
    """The air-data variants named apart (one process may load several libraries)."""
    if not channels:
        return ""
    return "_air_" + hashlib.sha256(repr((channels, calibration)).encode()).hexdigest()[:8]


def dryden_gust_model(flight: Flight, substeps: int, input: str, delay_s: float,  # noqa: A002
                      compile_model: bool = True, channels: tuple[str, ...] = (),
                      calibration: tuple[str, ...] = (), probe: np.ndarray | None = None
                      ) -> GustModel:
    """As :func:`baselines._fem_filter.gust_model`, with the Dryden filter's predict and
    update (:func:`dryden_step_functions`); run it with :func:`run_dryden_filters`."""
    record = flight_record(flight, input, delay_s)
    const = Constants(*(float(v) for v in model_constants(flight)))
    varying = record.exogenous is not None
    if varying:  # the per-sample values replace the exogenous fields (as gust_model)
        const = const._replace(**dict.fromkeys(EXOGENOUS, 0.0))
    delta, pieces, exo = record.symbolic_inputs()
    predict, update, compiled = dryden_step_functions(
        const, float(record.dt), int(substeps), int(record.n_pieces), varying,
        len(OUTPUT_CHANNELS), compile_model, tuple(channels), tuple(calibration))
    return GustModel(predict, update, delta[0], pieces, exo,
                     flight.airframe.accel_positions.ravel(), float(record.dt), compiled,
                     tuple(channels), tuple(calibration),
                     np.zeros(3) if probe is None else np.asarray(probe, dtype=float))


def run_dryden_filters(model: GustModel, gust: DrydenGust, theta: np.ndarray,
                       steady: np.ndarray, sigma: np.ndarray, x0: np.ndarray,
                       P0x: np.ndarray, R: np.ndarray, zs: np.ndarray,
                       cal: np.ndarray | None = None) -> FilterRuns:
    """Run ``r`` Dryden gust filters over ``zs`` (as :func:`baselines._fem_filter.
    run_filters`, ``gust`` in place of ``decay``; ``model`` from :func:`dryden_gust_model`).

    Parameters
    ----------
    model : GustModel
    gust : DrydenGust
    theta : ndarray, shape (r, N_COEFFICIENTS)
    steady : ndarray, shape (r, N_WIND)
        Steady wind [m/s, NED].
    sigma : ndarray, shape (r,)
        Gust intensity [m/s].
    x0 : ndarray, shape (N_STATE,)
    P0x : ndarray, shape (N_STATE, N_STATE)
    R : ndarray, shape (m,) or (n, m)
    zs : ndarray, shape (n, m)
    cal : ndarray, shape (r, len(model.calibration)), optional

    Returns
    -------
    FilterRuns
        ``x`` (r, n, N_FILTER): the filtered ``[x, w_s + C s]``.
    """
    r = theta.shape[0]
    n, m = zs.shape
    R = np.broadcast_to(np.asarray(R, dtype=float), (n, m))
    x = np.zeros((r, N_DRYDEN))
    x[:, :N_STATE] = x0
    P = np.zeros((r, N_DRYDEN, N_DRYDEN))
    P[:, :N_STATE, :N_STATE] = P0x
    P[:, N_STATE:, N_STATE:] = (sigma**2)[:, None, None] * gust.p1
    cT = gust.c.T.ravel()  # CasADi's column-major C
    predict = Buffered(model.predict.map(r, [False] * 5 + [True] * 6,
                                         [False] * 2),
                       [x.T, np.hstack(list(P)), theta.T, steady.T, (sigma**2)[None],
                        gust.phi.T.ravel(), gust.q1.T.ravel(), cT,
                        model.pieces[:, 0], model.exo[:, 0], model.exo[:, 0]])
    air: list = []
    if model.air_channels:
        cal = np.zeros((r, len(model.calibration))) if cal is None else np.asarray(cal, float)
        air = [np.ascontiguousarray(cal.T), model.probe]
    update = Buffered(model.update.map(r, [False] * 4 + [True] * 6 + [False, True][:len(air)],
                                       [False] * 4),
                      [x.T, np.hstack(list(P)), theta.T, steady.T, cT, model.delta[:1],
                       model.exo[:, 0], model.positions, zs[0], R[0], *air])
    innovation = np.empty((r, n, m))
    S_all = np.empty((r, n, m, m))
    xs = np.empty((r, n, N_FILTER))
    for k in range(n):
        if k > 0:
            predict.inputs[1][:] = P.ravel()
            predict.inputs[8][:] = model.pieces[:, k - 1]
            predict.inputs[9][:] = model.exo[:, k - 1]
            predict.inputs[10][:] = model.exo[:, k]
            x_next, P_next = predict(x.ravel())
            x = x_next.reshape(r, N_DRYDEN)
            P = P_next.reshape(r, N_DRYDEN, N_DRYDEN)
        update.inputs[1][:] = P.ravel()
        update.inputs[5][0] = model.delta[k]
        update.inputs[6][:] = model.exo[:, k]
        update.inputs[8][:] = zs[k]
        update.inputs[9][:] = R[k]
        x_new, P_new, nu, S = update(x.ravel())
        x = x_new.reshape(r, N_DRYDEN).copy()
        P = P_new.reshape(r, N_DRYDEN, N_DRYDEN).copy()
        innovation[:, k] = nu.reshape(r, m)
        S_all[:, k] = S.reshape(r, m, m)
        xs[:, k, :N_STATE] = x[:, :N_STATE]
        xs[:, k, N_STATE:] = steady + x[:, N_STATE:] @ gust.c.T
    ok = (np.all(np.isfinite(innovation), axis=(1, 2)) & np.all(np.isfinite(xs), axis=(1, 2))
          & np.all(np.isfinite(S_all), axis=(1, 2, 3)))
    return FilterRuns(innovation, S_all, ok, xs)

