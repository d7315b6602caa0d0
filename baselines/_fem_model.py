"""The filter-error method's model: the transition and measurement with the wind as states.

A variant of the EKF's steady-wind functions (:mod:`baselines._kalman_wind`), built the
same way from the model's public face (:func:`aeroid.model.with_wind_symbols`,
:mod:`aeroid.model.symbolic`): the wind ``w`` [m/s, NED] enters the loads as the model's
wind, held over the sample interval. Two differences, both for speed (the filter-error
method runs the filter once per parameter and iteration): the coefficients are an input,
not states, so the Jacobians have only the columns of ``[x, w]`` (12 of the EKF's 21); and
the functions are compiled to C (:func:`aeroid.model.symbolic.compile_functions`, cached
on disk), falling back to CasADi's virtual machine (same numbers) without a compiler.
``tests/unit/test_filter_error.py`` checks them against the EKF's functions.
"""

from __future__ import annotations

import functools

import casadi as ca

from aeroid.model import N_COEFFICIENTS, N_STATE, Constants, symbolic, with_wind_symbols
from baselines._kalman_wind import WIND_NAMES

#: The wind's components, north, east, down.
N_WIND = len(WIND_NAMES)
#: The filter's state: the model's state, then the wind.
N_FILTER = N_STATE + N_WIND


@functools.lru_cache(maxsize=8)
def gust_functions(const: Constants, dt: float, substeps: int, n_pieces: int,
                   varying: bool, compile_model: bool = True
                   ) -> tuple[ca.Function, ca.Function, bool]:
    """Return ``f, h, compiled`` for the filter's state ``xw = [x, w]``.

    ``f(xw, theta, pieces, exo_a, exo_b) -> (x_next (N_STATE,), dx_next/dxw (N_STATE,
    N_FILTER))``: one RK4 interval (``substeps`` steps) with the wind ``w`` added to the
    model's (constants, or each exogenous row); ``h(xw, theta, delta, exo, positions) ->
    (y (m,), dy/dxw (m, N_FILTER))``: the outputs at a sample. Jacobians dense, exact (AD).
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
    y = symbolic.measurement(x, delta, theta, pos,
                             symbolic.sample_constants(const_w, exo + wind_row))
    h = ca.Function("h_fem", [xw, theta, delta, exo, pos], [y, ca.densify(ca.jacobian(y, xw))])
    if compile_model:
        built = symbolic.compile_functions([f, h], "fem")
        if built is not None:
            return built[0], built[1], True
    return f, h, False
