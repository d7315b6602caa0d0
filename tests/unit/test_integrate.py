"""RK4: closed forms, scipy's solve_ivp, and the numba and numpy backends against each other."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from aeroid.model import N_COEFFICIENTS, N_STATE
from aeroid.model._dynamics import constants, state_derivative
from aeroid.model._integrate import HAVE_NUMBA, PARALLEL_MIN_SETS, propagate, rk4

#: RK4 on dx/dt = -x is multiplication by the degree-4 Taylor polynomial of exp(-h) each
#: step; evaluating the same polynomial directly differs only by rounding over <= 100 steps.
RK4_LINEAR_RTOL = 1e-13
#: Global RK4 error on dx/dt = -x at T = 1 is ~T h^4 e^-T / 120; the ratio of errors at h
#: and h/2 must be 16 to within the next-order term (O(h) relative, h <= 0.1 here).
ORDER_RATIO_RANGE = (14.0, 17.0)
#: solve_ivp (DOP853, rtol 1e-11) versus propagate with 32 RK4 substeps (62.5 us): RK4's
#: global error there is 1.6e-11 of each channel's range (measured; 4e-9 at 8 substeps,
#: 1.7e-5 at 1, falling 16x per halving), so the bound leaves a factor ~6.
SOLVE_IVP_RTOL = 1e-10
#: numba (fast-math: reassociation, FMA) versus numpy: rounding-level differences grown
#: through 500 steps; measured 7e-14 of each channel's range.
BACKEND_RTOL = 1e-12
#: The kernel's shifted sine and cosine versus libm's sin(a + d): a few ulp of 1.
SINCOS_ATOL = 1e-15

needs_numba = pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")


def _scaled_error(a: np.ndarray, b: np.ndarray) -> float:
    """Max |a - b| over samples and sets, relative to each state channel's max |b|."""
    scale = np.max(np.abs(b), axis=tuple(range(b.ndim - 1)))
    scale = np.where(scale > 0, scale, 1.0)
    return float(np.max(np.abs(a - b) / scale))


def test_rk4_linear_equals_closed_form_step_polynomial():
    h, n = 0.05, 100
    x0 = np.array([[1.0, -2.0], [0.5, 3.0]])
    out = rk4(lambda t, x: -x, x0, 0.0, h, n)
    growth = 1.0 - h + h**2 / 2 - h**3 / 6 + h**4 / 24
    expected = x0[None] * growth ** np.arange(n + 1)[:, None, None]
    assert out.shape == (n + 1, 2, 2)
    np.testing.assert_allclose(out, expected, rtol=RK4_LINEAR_RTOL)


def test_rk4_is_fourth_order_against_exp():
    errors = []
    for h in (0.1, 0.05, 0.025):
        n = round(1.0 / h)
        out = rk4(lambda t, x: -x, np.array([1.0]), 0.0, h, n)
        errors.append(abs(out[-1, 0] - math.exp(-1.0)))
        # leading term of the global error: T h^4 e^{-T} / 120
        assert errors[-1] == pytest.approx(h**4 * math.exp(-1.0) / 120, rel=0.1)
    for coarse, fine in zip(errors, errors[1:], strict=False):
        assert ORDER_RATIO_RANGE[0] < coarse / fine < ORDER_RATIO_RANGE[1]


def test_rk4_passes_time_to_the_right_hand_side():
    # dx/dt = t, x(0) = 0: RK4 integrates polynomials of degree <= 3 exactly -> t^2 / 2
    out = rk4(lambda t, x: np.full_like(x, t), np.zeros(1), 0.0, 0.1, 10)
    np.testing.assert_allclose(out[:, 0], (0.1 * np.arange(11)) ** 2 / 2, rtol=1e-13, atol=1e-15)


def _solve_ivp_held(state0, coefficients, delta, dt, const):
    """Integrate each sample interval with DOP853 from the previous interval's end."""
    x = np.array(state0, dtype=float)
    out = [x]
    for d in delta:
        sol = solve_ivp(lambda t, s, d=d: state_derivative(s, d, coefficients, const),
                        (0.0, dt), x, method="DOP853", rtol=1e-11, atol=1e-12)
        assert sol.success
        x = sol.y[:, -1]
        out.append(x)
    return np.array(out)


@pytest.fixture(scope="module")
def ivp_reference(clean_flight, reference_scenario):
    """solve_ivp over the first 100 intervals (0.2 s, 6 relay switches) of the window."""
    const = constants(reference_scenario.airframe)
    delta = clean_flight["delta"][:100]
    truth = reference_scenario.coefficient_vector
    ref = _solve_ivp_held(clean_flight.states()[0], truth, delta, clean_flight.dt, const)
    return ref, delta, const


@pytest.mark.parametrize("backend", [pytest.param("numba", marks=needs_numba), "numpy"])
def test_propagate_equals_solve_ivp(ivp_reference, clean_flight, reference_scenario, backend):
    ref, delta, const = ivp_reference
    truth = reference_scenario.coefficient_vector
    fine = propagate(ref[0], truth, delta, clean_flight.dt, const, substeps=32, backend=backend)
    assert fine.shape == (1, len(delta) + 1, N_STATE)
    assert _scaled_error(fine[0], ref) < SOLVE_IVP_RTOL
    # and the error is RK4's: halving the step divides it by ~16
    e1 = _scaled_error(propagate(ref[0], truth, delta, clean_flight.dt, const, substeps=1,
                                 backend=backend)[0], ref)
    e2 = _scaled_error(propagate(ref[0], truth, delta, clean_flight.dt, const, substeps=2,
                                 backend=backend)[0], ref)
    assert e1 > 100 * SOLVE_IVP_RTOL
    assert 12.0 < e1 / e2 < 20.0


def test_propagate_matches_the_recorded_flight(clean_flight, reference_scenario):
    # the simulator latches delta at each sample and integrates 8 substeps: one batched
    # call over the window with the recorded delta must give the recorded states
    const = constants(reference_scenario.airframe)
    states = clean_flight.states()
    out = propagate(states[0], reference_scenario.coefficient_vector,
                    clean_flight["delta"][:-1], clean_flight.dt, const, substeps=8)
    assert _scaled_error(out[0], states) < BACKEND_RTOL


@needs_numba
def test_numba_and_numpy_backends_agree(clean_flight, reference_scenario):
    rng = np.random.default_rng(7)
    n_sets = PARALLEL_MIN_SETS + 4  # takes the parallel kernel
    spread = 1 + 0.4 * (rng.random((n_sets, N_COEFFICIENTS)) - 0.5)
    coefficients = reference_scenario.coefficient_vector * spread
    const = constants(reference_scenario.airframe)
    args = (clean_flight.states()[0], coefficients, clean_flight["delta"][:-1], clean_flight.dt,
            const)
    fast = propagate(*args, backend="numba")
    slow = propagate(*args, backend="numpy")
    assert fast.shape == slow.shape == (n_sets, clean_flight.n_samples, N_STATE)
    assert _scaled_error(fast, slow) < BACKEND_RTOL
    # the serial kernel (few sets) gives the parallel kernel's numbers
    few = propagate(args[0], coefficients[:3], *args[2:], backend="numba")
    assert _scaled_error(few, fast[:3]) < BACKEND_RTOL
    # and asked for by name for many sets (the UKF's sigma points), and the reverse
    serial = propagate(*args, backend="numba", parallel=False)
    assert _scaled_error(serial, fast) < BACKEND_RTOL
    threaded = propagate(args[0], coefficients[:3], *args[2:], backend="numba", parallel=True)
    assert _scaled_error(threaded, few) < BACKEND_RTOL


@needs_numba
def test_sincos_shift_equals_libm():
    # the kernel's sin(a + d), cos(a + d) by the addition theorem, both branches
    from aeroid.model._compiled import sincos_shift as _sincos_shift

    rng = np.random.default_rng(3)
    steps = np.concatenate([np.geomspace(1e-10, 0.3, 40), [0.0999999, 0.1, 1.0, 3.0]])
    for a in rng.uniform(-7, 7, 20):
        for d in np.concatenate([steps, -steps]):
            s, c = _sincos_shift(math.sin(a), math.cos(a), d)
            assert abs(s - math.sin(a + d)) < SINCOS_ATOL
            assert abs(c - math.cos(a + d)) < SINCOS_ATOL


@needs_numba
def test_backends_agree_with_large_steps(clean_flight, reference_scenario):
    # 20 ms steps: the roll angle moves 0.5 rad per half step (the kernel's libm branch)
    const = constants(reference_scenario.airframe)
    args = (clean_flight.states()[0], reference_scenario.coefficient_vector,
            clean_flight["delta"][:200:10], 10 * clean_flight.dt, const)
    fast = propagate(*args, backend="numba")
    slow = propagate(*args, backend="numpy")
    assert np.all(np.isfinite(slow))
    assert _scaled_error(fast, slow) < BACKEND_RTOL


def test_propagate_broadcasts_states_and_coefficients(clean_flight, reference_scenario):
    const = constants(reference_scenario.airframe)
    x0 = clean_flight.states()[:3]
    delta = clean_flight["delta"][:20]
    truth = reference_scenario.coefficient_vector
    batched = propagate(x0, truth, delta, clean_flight.dt, const)
    for i in range(3):
        single = propagate(x0[i], truth, delta, clean_flight.dt, const)
        np.testing.assert_array_equal(batched[i], single[0])


@pytest.mark.parametrize("backend", [pytest.param("numba", marks=needs_numba), "numpy"])
def test_diverging_set_gives_non_finite_values_not_an_exception(clean_flight, reference_scenario,
                                                                backend):
    const = constants(reference_scenario.airframe)
    coefficients = np.tile(reference_scenario.coefficient_vector, (2, 1))
    coefficients[0, 8] = 1e7  # hugely negative pitch damping -> divergence
    out = propagate(clean_flight.states()[0], coefficients, clean_flight["delta"][:-1],
                    clean_flight.dt, const, backend=backend)
    assert not np.all(np.isfinite(out[0]))
    assert np.all(np.isfinite(out[1]))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"coefficients": np.zeros(8)}, "coefficients must have shape"),
        ({"state0": np.zeros((2, 8))}, "state0 must have shape"),
        ({"state0": np.ones((3, N_STATE)),
          "coefficients": np.ones((2, N_COEFFICIENTS))}, "do not broadcast"),
        ({"substeps": 0}, "substeps must be >= 1"),
        ({"dt": -0.002}, "dt must be a positive"),
        ({"backend": "fortran"}, "unknown backend"),
    ],
)
def test_propagate_rejects_bad_input(clean_flight, reference_scenario, kwargs, message):
    args = {"state0": clean_flight.states()[0],
            "coefficients": reference_scenario.coefficient_vector, "delta": np.zeros(3),
            "dt": 0.002, "const": constants(reference_scenario.airframe)}
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        propagate(**args)


def test_the_one_rk4_step_is_simpson_on_a_quadrature_for_numpy_and_casadi():
    """rk4_stages, the step shared by the numpy backend and CasADi: on dx/dt = u(t) with
    u given at the step's start, middle and end it is Simpson's rule
    x + h/6 (u0 + 4 um + u1), exactly (up to rounding), for numpy arrays and CasADi
    symbols alike."""
    import casadi as ca

    from aeroid.model._integrate import rk4_stages

    h, u = 0.3, (np.array([1.0, -2.0]), np.array([0.5, 4.0]), np.array([-3.0, 0.25]))
    x0 = np.array([2.0, 1.0])
    simpson = x0 + h / 6 * (u[0] + 4 * u[1] + u[2])
    step = rk4_stages(lambda x, ui: ui + 0 * x, x0, h, (u[0],), (u[1],), (u[2],))
    np.testing.assert_allclose(step, simpson, rtol=1e-15)
    sx, su = ca.SX.sym("x", 2), [ca.SX.sym(f"u{i}", 2) for i in range(3)]
    sym = rk4_stages(lambda x, ui: ui + 0 * x, sx, h, (su[0],), (su[1],), (su[2],))
    via_casadi = np.asarray(ca.Function("s", [sx, *su], [sym])(x0, *u)).ravel()
    np.testing.assert_allclose(via_casadi, simpson, rtol=1e-15)
    # and a state-dependent right-hand side: dx/dt = -x gives the degree-4 polynomial
    decay = rk4_stages(lambda x: -x, x0, h, (), (), ())
    np.testing.assert_allclose(decay, x0 * (1 - h + h**2 / 2 - h**3 / 6 + h**4 / 24),
                               rtol=RK4_LINEAR_RTOL)
