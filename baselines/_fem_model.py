"""The filter-error method's model: the transition and measurement with the wind as states.

A variant of the EKF's steady-wind functions (:mod:`baselines._kalman_wind`), built the
same way from the model's public face (:func:`aeroid.model.with_wind_symbols`,
:mod:`aeroid.model.symbolic`): the wind ``w`` [m/s, NED] enters the loads as the model's
wind, held over the sample interval. Two differences, both for speed (the filter-error
method runs the filter once per parameter and iteration): the coefficients are an input,
not states, so the Jacobians have only the columns of ``[x, w]`` (12 of the EKF's 21); and
:func:`step_functions` wraps them into the filter's prediction and update, covariance
included, compiled to C (:func:`aeroid.model.symbolic.compile_functions`, cached on disk;
the first build compiles for ~5 s), falling back to CasADi's virtual machine (same
numbers) without a compiler. ``tests/unit/test_filter_error.py`` checks the transition and
measurement against the EKF's functions, the filter against filterpy's EKF.

With air data (``channels``: the probe's alpha, beta, airspeed; ``calibration``: their
flow-angle calibration, :mod:`baselines._fem_air`) the measurement has those rows after
the IMU's: output-error's and the EKF's probe outputs
(:func:`baselines._oe_airdata._probe_outputs`: the model's air-relative velocity with the
filter's wind, plus ``omega x r`` at the probe), not written again; the update then also
takes the calibration ``cal`` and the probe's position ``probe`` [m, body].
"""

from __future__ import annotations

import functools
import hashlib

import casadi as ca

from aeroid.model import N_COEFFICIENTS, N_STATE, Constants, symbolic, with_wind_symbols
from baselines._kalman_wind import WIND_NAMES
from baselines._oe_airdata import _probe_outputs

#: The wind's components, north, east, down.
N_WIND = len(WIND_NAMES)
#: The filter's state: the model's state, then the wind.
N_FILTER = N_STATE + N_WIND


@functools.lru_cache(maxsize=8)
def gust_functions(const: Constants, dt: float, substeps: int, n_pieces: int,
                   varying: bool, channels: tuple[str, ...] = (),
                   calibration: tuple[str, ...] = ()) -> tuple[ca.Function, ca.Function]:
    """Return ``f, h`` (CasADi SX) for the filter's state ``xw = [x, w]``.

    ``f(xw, theta, pieces, exo_a, exo_b) -> (x_next (N_STATE,), dx_next/dxw (N_STATE,
    N_FILTER))``: one RK4 interval (``substeps`` steps) with the wind ``w`` added to the
    model's (constants, or each exogenous row); ``h(xw, theta, delta, exo, positions) ->
    (y (m,), dy/dxw (m, N_FILTER))``: the outputs at a sample. Jacobians dense, exact (AD).
    With air-data ``channels``, ``h(xw, theta, delta, exo, positions, cal, probe)``: the
    IMU's outputs, then the probe's (module docstring).
    """
    xw = ca.SX.sym("xw", N_FILTER)
    theta = ca.SX.sym("theta", N_COEFFICIENTS)
    sym = symbolic.interval_symbols(n_pieces, varying)
    delta = ca.SX.sym("delta")
    exo = ca.SX.sym("exo", sym.exo_a.shape[0])
    pos = ca.SX.sym("pos", 6)
    x = xw[:N_STATE]
    const_w, sym_w, wind_row = with_wind_symbols(const, sym, xw[N_STATE:])
    x_next = symbolic.interval_step_symbolic(x, theta, sym_w, const_w, dt, substeps)
    f = ca.Function("f_fem", [xw, theta, *sym], [x_next, ca.densify(ca.jacobian(x_next, xw))])
    sample = symbolic.sample_constants(const_w, exo + wind_row)
    y = symbolic.measurement(x, delta, theta, pos, sample)
    if not channels:
        h = ca.Function("h_fem", [xw, theta, delta, exo, pos],
                        [y, ca.densify(ca.jacobian(y, xw))])
        return f, h
    cal, probe = ca.SX.sym("cal", len(calibration)), ca.SX.sym("probe", 3)
    y = ca.vertcat(y, _probe_outputs(x, sample, probe, cal, channels, calibration))
    h = ca.Function("h_fem_air", [xw, theta, delta, exo, pos, cal, probe],
                    [y, ca.densify(ca.jacobian(y, xw))])
    return f, h


@functools.lru_cache(maxsize=8)
def step_functions(const: Constants, dt: float, substeps: int, n_pieces: int,
                   varying: bool, n_outputs: int, compile_model: bool = True,
                   channels: tuple[str, ...] = (), calibration: tuple[str, ...] = ()
                   ) -> tuple[ca.Function, ca.Function, bool]:
    """Return ``predict, update, compiled``: one EKF step of the gust filter in C.

    ``predict(xw, P, theta, steady, decay, q, pieces, exo_a, exo_b) -> (xw, P)``: the
    model's transition of ``x`` (:func:`gust_functions`' ``f``), the wind decaying towards
    ``steady`` by ``decay`` with process-noise variance ``q`` per component, ``P <- A P
    A^T + Q``; ``update(xw, P, theta, delta, exo, positions, z, R) -> (xw, P, nu, S)``:
    the innovation ``nu = z - h``, ``S = H P H^T + diag(R)``, ``K = P H^T S^-1``,
    ``xw + K nu`` and ``P - K H P`` (symmetrised). ``P`` and ``S`` dense, column-major.
    The covariance algebra in C instead of numpy: one call per step and filter batch.
    With air-data ``channels`` (``n_outputs`` counts the IMU's only): ``update(xw, P, theta,
    delta, exo, positions, z, R, cal, probe)``, ``z`` and ``R`` with the probe's channels
    after the IMU's.
    """
    f, h = gust_functions(const, dt, substeps, n_pieces, varying, channels, calibration)
    xw = ca.SX.sym("xw", N_FILTER)
    P = ca.SX.sym("P", N_FILTER, N_FILTER)
    theta = ca.SX.sym("theta", N_COEFFICIENTS)
    steady = ca.SX.sym("steady", N_WIND)
    decay, q = ca.SX.sym("decay"), ca.SX.sym("q")
    sym = symbolic.interval_symbols(n_pieces, varying)
    x_next, F = f(xw, theta, *sym)
    wind = xw[N_STATE:]
    A = ca.vertcat(F, ca.horzcat(ca.SX.zeros(N_WIND, N_STATE), decay * ca.SX.eye(N_WIND)))
    Q = ca.diagcat(ca.SX.zeros(N_STATE, N_STATE), q * ca.SX.eye(N_WIND))
    P_next = A @ P @ A.T + Q
    predict = ca.Function("fem_predict", [xw, P, theta, steady, decay, q, *sym],
                          [ca.vertcat(x_next, steady + decay * (wind - steady)),
                           ca.densify(0.5 * (P_next + P_next.T))])
    delta = ca.SX.sym("delta")
    exo = ca.SX.sym("exo", sym.exo_a.shape[0])
    pos = ca.SX.sym("pos", 6)
    z = ca.SX.sym("z", n_outputs + len(channels))
    R = ca.SX.sym("R", n_outputs + len(channels))
    air = [ca.SX.sym("cal", len(calibration)), ca.SX.sym("probe", 3)] if channels else []
    y, H = h(xw, theta, delta, exo, pos, *air)
    HP = H @ P
    S = HP @ H.T + ca.diag(R)
    Kt = ca.solve(S, HP)  # K^T = S^-1 H P
    nu = z - y
    P_new = P - HP.T @ Kt
    # the air-data variants named apart (one process may load both libraries)
    tag = "" if not channels else "_air_" + hashlib.sha256(
        repr((channels, calibration)).encode()).hexdigest()[:8]
    if tag:
        predict = ca.Function(f"fem_predict{tag}", [xw, P, theta, steady, decay, q, *sym],
                              predict(xw, P, theta, steady, decay, q, *sym))
    update = ca.Function(f"fem_update{tag}", [xw, P, theta, delta, exo, pos, z, R, *air],
                         [xw + Kt.T @ nu, ca.densify(0.5 * (P_new + P_new.T)), nu,
                          ca.densify(S)])
    if compile_model:
        built = symbolic.compile_functions([predict, update], f"fem_step{tag}")
        if built is not None:
            return built[0], built[1], True
    return predict, update, False
