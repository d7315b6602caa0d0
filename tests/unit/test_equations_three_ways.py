"""Every element-wise equation agrees evaluated three ways: numpy, numba, CasADi.

The model is written once (aeroid.model._equations); this test evaluates each function
on the same random inputs with numpy, inside an njit function (numba compiles the very
Python function, registered as an overload of itself), and on CasADi symbols; a new
coefficient, state or input is covered without touching the test.
"""

from __future__ import annotations

import inspect

import casadi as ca
import numpy as np
import pytest
from closeness import assert_close_in_norm

from aeroid.model import HAVE_NUMBA
from aeroid.model import _equations as eq

#: Three evaluations of the same algebra: rounding only (numba's fast-math may
#: reassociate; the atan hook takes atan(y/x) for x > 0), so each function's outputs
#: are compared at this fraction of their largest magnitude, not element by element
#: (an output that cancels to near zero carries the rounding of the terms it sums).
SAME_RTOL = 1e-12

#: The named-tuple arguments, by their annotation (everything else is a scalar).
TUPLES = {"State": eq.State, "Coefficients": eq.Coefficients, "Constants": eq.Constants,
          "Loads": eq.Loads, "Trig": eq.Trig}


def _arguments(fn, rng: np.random.Generator) -> dict:
    values = {}
    for name, parameter in inspect.signature(fn).parameters.items():
        kind = TUPLES.get(str(parameter.annotation))
        if kind is None:
            values[name] = float(rng.uniform(0.2, 1.0))
            continue
        fields = rng.uniform(0.2, 1.0, len(kind._fields))
        if kind is eq.State:
            fields[0] = 500.0  # u: forward flight
        values[name] = kind(*(float(v) for v in fields))
    return values


def _flat(result) -> np.ndarray:
    return np.asarray([float(v) for v in np.ravel(np.asarray(result, dtype=object))])


@pytest.mark.parametrize("fn", eq.ELEMENT_WISE, ids=lambda f: f.__name__)
def test_numpy_numba_and_casadi_agree(fn) -> None:
    rng = np.random.default_rng(7)
    args = _arguments(fn, rng)
    reference = _flat(fn(**args))
    # CasADi: every scalar and tuple field a symbol, evaluated through a Function
    symbols, numeric, sym_args = [], [], {}
    for name, value in args.items():
        if isinstance(value, tuple):
            fields = [ca.SX.sym(f"{name}_{f}") for f in value._fields]
            symbols += fields
            numeric += list(value)
            sym_args[name] = type(value)(*fields)
        else:
            sym = ca.SX.sym(name)
            symbols.append(sym)
            numeric.append(value)
            sym_args[name] = sym
    out = fn(**sym_args)
    out = out if isinstance(out, tuple) else (out,)
    function = ca.Function("f", symbols, [ca.vertcat(*out)])
    via_casadi = np.asarray(function(*numeric)).ravel()
    assert_close_in_norm(via_casadi, reference, SAME_RTOL)
    if HAVE_NUMBA:
        import numba

        names = list(args)
        source = (f"def call({', '.join(names)}):\n"
                  f"    return fn({', '.join(names)})\n")
        scope = {"fn": fn}
        exec(source, scope)  # noqa: S102 - a wrapper over the parameters' names
        compiled = numba.njit(scope["call"])
        from aeroid.model import _compiled  # noqa: F401 - registers the overloads

        via_numba = _flat(compiled(*args.values()))
        assert_close_in_norm(via_numba, reference, SAME_RTOL)


@pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")
@pytest.mark.parametrize(("y", "x"), [(0.3, 0.5), (0.3, -0.5), (-0.3, -0.5), (0.0, -1.0)])
def test_the_compiled_atan2_hook_is_atan2_in_every_quadrant(y, x) -> None:
    import numba

    from aeroid.model import _compiled  # noqa: F401 - registers the overloads

    compiled = numba.njit(lambda a, b: eq.atan2(a, b))
    assert compiled(y, x) == pytest.approx(np.arctan2(y, x), rel=1e-15, abs=1e-15)


def test_the_output_vector_three_ways_and_the_rigid_body_identity() -> None:
    """eq.outputs (the output vector, written once) gives the same numbers from numpy,
    numba (inside an njit function) and CasADi, in the order of eq.output_names; and the
    difference of two triads' readings is the rigid-body lever arm
    ``wdot x d + w x (w x d)`` computed with np.cross (an independent reference)."""
    rng = np.random.default_rng(11)
    x = eq.State(500.0, *rng.uniform(0.2, 1.0, len(eq.State._fields) - 1))
    c = eq.Coefficients(*rng.uniform(0.2, 1.0, len(eq.Coefficients._fields)))
    const = eq.Constants(*rng.uniform(0.2, 1.0, len(eq.Constants._fields)))
    positions = rng.uniform(-0.5, 0.5, (3, 3))  # three triads: nothing assumes two
    loads = eq.aerodynamic_loads(x, c, 0.3, const)
    names = eq.output_names(len(positions))
    assert names[:4] == ("ax1", "ay1", "az1", "ax2") and names[-3:] == ("p", "q", "r")
    y = eq.outputs(np.empty(len(names)), x, loads, const, positions)
    np.testing.assert_array_equal(y[-3:], [x.p, x.q, x.r])
    w = np.array([x.p, x.q, x.r])
    wdot = np.array(eq.angular_acceleration(x.p, x.q, x.r, loads, const))
    for j in (1, 2):
        d = positions[j] - positions[0]
        lever = np.cross(wdot, d) + np.cross(w, np.cross(w, d))
        assert_close_in_norm(y[3 * j:3 * j + 3] - y[0:3], lever, SAME_RTOL)
    # CasADi: the state a symbol, positions numbers (as the filters' measurement model)
    sx = ca.SX.sym("x", len(eq.State._fields))
    state = eq.State(*(sx[i] for i in range(sx.shape[0])))
    out = eq.outputs(ca.SX.zeros(len(names)), state, eq.aerodynamic_loads(state, c, 0.3, const),
                     const, ca.DM(positions))
    via_casadi = np.asarray(ca.Function("h", [sx], [out])(np.array(x))).ravel()
    assert_close_in_norm(via_casadi, y, SAME_RTOL)
    if HAVE_NUMBA:
        import numba

        from aeroid.model import _compiled  # noqa: F401 - registers the overloads

        @numba.njit
        def call(out, x, loads, const, positions):
            return eq.outputs(out, x, loads, const, positions)

        via_numba = call(np.empty(len(names)), x, loads, const, positions)
        assert_close_in_norm(via_numba, y, SAME_RTOL)
