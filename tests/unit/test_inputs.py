"""The model's inputs in time: schedules cut per interval, exogenous tables, and the
integrators (numba, numpy, CasADi) against scipy's solve_ivp with the exact inputs."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from aeroid.model import (
    EXOGENOUS,
    HAVE_NUMBA,
    N_COEFFICIENTS,
    N_STATE,
    ForwardModel,
    Record,
    Schedule,
    constants,
    exogenous_table,
    propagate,
    state_derivative,
    symbolic,
    symbolic_record,
    with_exogenous,
)

DT = 0.002
#: RK4 with 4 substeps of 0.5 ms against DOP853 at 1e-12: local error ~ (h p)^5 / 120 with
#: p ~ 50 rad/s (roll) over 100 intervals; measured max 2e-9 of each channel's range.
RK4_RTOL = 1e-7
#: Two evaluations of the same algebra in a different order (numba fast-math, CasADi).
SAME_RTOL = 1e-11


@pytest.fixture(scope="module")
def setup(reference_scenario, clean_flight):
    const = constants(reference_scenario.airframe)
    x0 = clean_flight.states()[0]
    return const, x0, reference_scenario.coefficient_vector


def test_hold_schedule_is_the_logged_sequence() -> None:
    t = np.arange(6) * DT
    d = np.array([1, 1, -1, -1, 1, 1.0])
    sched = Schedule.hold(t, d)
    np.testing.assert_array_equal(sched.at(t), d)
    pieces = sched.segments(t)
    assert pieces.end.shape == (5, 1)
    np.testing.assert_array_equal(pieces.start[:, 0], d[:-1])
    np.testing.assert_array_equal(pieces.stop[:, 0], d[:-1])


def test_midpoint_and_shifted_schedules_cut_the_intervals() -> None:
    t = np.arange(6) * DT
    d = np.array([1, 1, -1, -1, 1, 1.0])
    mid = Schedule.midpoint(t, d).segments(t)
    # the changes between samples 1-2 and 3-4 happen halfway through those intervals
    np.testing.assert_array_equal(mid.end[[1, 3], 0], [0.5, 0.5])
    np.testing.assert_array_equal(mid.start[1], [1.0, -1.0])
    np.testing.assert_array_equal(mid.start[3], [-1.0, 1.0])
    np.testing.assert_array_equal(mid.end[[0, 2, 4], 0], [1.0, 1.0, 1.0])
    late = Schedule.hold(t, d).shifted(0.25 * DT)
    np.testing.assert_array_equal(late.at(t), [1, 1, 1, -1, -1, 1])
    pieces = late.segments(t)
    np.testing.assert_allclose(pieces.end[2, 0], 0.25, rtol=1e-12)
    np.testing.assert_array_equal(pieces.start[2], [1.0, -1.0])


def test_events_and_ramps_give_values_at_and_between_samples() -> None:
    t = np.arange(6) * DT
    ev = Schedule.events(1.0, [0.0031, 0.0052], [-1.0, 1.0])
    np.testing.assert_array_equal(ev.at(t), [1, 1, -1, 1, 1, 1])
    assert ev.at(0.0031) == -1.0 and ev.before(0.0031) == 1.0
    ramp = Schedule(np.array([0.003, 0.005]), np.array([1.0, -1.0]))
    # linear from +1 at 3 ms to -1 at 5 ms: 0 at the 4 ms sample
    np.testing.assert_allclose(ramp.at(t), [1, 1, 0, -1, -1, -1], atol=1e-12)
    pieces = ramp.segments(t)
    np.testing.assert_allclose(pieces.end[1], [0.5, 1.0])
    np.testing.assert_allclose(pieces.start[1], [1.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(pieces.stop[1], [1.0, 0.0], atol=1e-12)


def test_knots_within_rounding_of_a_sample_make_no_sliver() -> None:
    t = np.arange(4) * DT
    sched = Schedule.events(1.0, [2 * DT * (1 + 1e-13)], [-1.0])
    assert sched.segments(t).end.shape[1] == 1


@pytest.mark.parametrize("bad", [
    lambda: Schedule(np.array([1.0, 0.0]), np.array([0.0, 1.0])),
    lambda: Schedule(np.array([0.0]), np.array([np.nan])),
    lambda: Schedule.events(0.0, [1.0, 2.0], [1.0]),
    lambda: Record(0.002, np.zeros(5), Schedule.hold(np.arange(4.0), np.zeros(4)).segments(
        np.arange(4.0))),
])
def test_bad_schedules_and_records_are_one_line(bad) -> None:
    with pytest.raises(ValueError) as info:
        bad()
    assert "\n" not in str(info.value)


def test_exogenous_table_checks_names_lengths_and_signs(reference_scenario) -> None:
    const = constants(reference_scenario.airframe)
    table = exogenous_table(const, 3, {"rho": [0.4, 0.41, 0.42]})
    assert table.shape == (3, len(EXOGENOUS))
    np.testing.assert_array_equal(table[:, EXOGENOUS.index("rho")], [0.4, 0.41, 0.42])
    np.testing.assert_array_equal(table[:, EXOGENOUS.index("mass")], const.mass)
    for per_sample, message in (({"mach": [1, 2, 3]}, "not one of"),
                                ({"rho": [1, 2]}, "2 values for 3"),
                                ({"mass": [1, -1, 1]}, "positive")):
        with pytest.raises(ValueError, match=message):
            exogenous_table(const, 3, per_sample)


def _scipy_reference(x0, theta, const, t, schedule, rho_of_t=None):
    """DOP853 through every knot of the schedule, with the exact deflection and density."""
    knots = np.unique(np.concatenate([t, schedule.times[(schedule.times > t[0])
                                                         & (schedule.times < t[-1])]]))
    x = x0.copy()
    out = [x0]
    for a, b in zip(knots[:-1], knots[1:], strict=True):
        mid = 0.5 * (a + b)
        slope = (schedule.before(b) - schedule.at(a)) / (b - a)

        def rhs(tt, y, a=a, slope=slope):
            c = const if rho_of_t is None else const._replace(rho=rho_of_t(tt))
            return state_derivative(y, schedule.at(a) + slope * (tt - a), theta, c)

        del mid
        x = solve_ivp(rhs, (a, b), x, method="DOP853", rtol=1e-12, atol=1e-12).y[:, -1]
        if np.any(np.isclose(b, t, rtol=0, atol=1e-15)):
            out.append(x)
    return np.array(out)


@pytest.mark.parametrize("backend", ["numpy", pytest.param("numba", marks=pytest.mark.skipif(
    not HAVE_NUMBA, reason="numba not installed"))])
def test_pieces_and_exogenous_equal_solve_ivp(setup, backend) -> None:
    const, x0, theta = setup
    n = 41
    t = 5.0 + np.arange(n) * DT
    rng = np.random.default_rng(1)
    switches = np.sort(rng.uniform(t[0] + 0.001, t[-1] - 0.001, 6))
    values = np.where(np.arange(6) % 2 == 0, -0.14, 0.14)
    sched = Schedule(np.concatenate([np.repeat(switches[:4], 2), [t[30] + 0.0003,
                                                                  t[33] + 0.0011]]),
                     np.concatenate([np.column_stack([np.r_[0.14, values[:3]],
                                                      values[:4]]).ravel(), [0.14, -0.14]]))
    rho = lambda tt: const.rho * (1.0 - 0.02 * (tt - t[0]))  # noqa: E731 - a 2 %/s climb
    table = exogenous_table(const, n, {"rho": rho(t)})
    states = propagate(x0, theta, sched.segments(t), DT, const, substeps=4, backend=backend,
                       exogenous=table)[0]
    reference = _scipy_reference(x0, theta, const, t, sched, rho)
    scale = np.ptp(reference, axis=0) + 1e-9
    assert np.max(np.abs(states - reference) / scale) < RK4_RTOL


@pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")
def test_numba_numpy_and_casadi_agree_on_pieces_and_exogenous(setup) -> None:
    const, x0, theta = setup
    n = 21
    t = 5.0 + np.arange(n) * DT
    sched = Schedule.midpoint(t, np.where(np.arange(n) % 5 < 2, 0.14, -0.14)).shifted(3e-4)
    table = exogenous_table(const, n, {"rho": np.linspace(0.41, 0.40, n),
                                       "mass": np.linspace(70.0, 69.5, n)})
    record = Record.scheduled(sched, t, table)
    a = propagate(x0, theta, record.pieces, DT, const, backend="numba", exogenous=table)[0]
    b = propagate(x0, theta, record.pieces, DT, const, backend="numpy", exogenous=table)[0]
    np.testing.assert_allclose(a, b, rtol=SAME_RTOL, atol=SAME_RTOL * np.ptp(b, axis=0).max())
    # CasADi, one interval at a time
    f, _ = symbolic.augmented_functions(const, DT, 1, record.n_pieces, True)
    _, pieces, exo = record.symbolic_inputs()
    z = np.concatenate([x0, theta])
    for k in range(n - 1):
        z = np.asarray(f(z, pieces[:, k], exo[:, k], exo[:, k + 1])[0]).ravel()
        np.testing.assert_allclose(z[:N_STATE], a[k + 1], rtol=SAME_RTOL,
                                   atol=SAME_RTOL * np.abs(a).max())
    # the output-error record graph equals the forward model's outputs
    positions = np.array([[0.6, 0.0, 0.0], [-0.6, 0.01, 0.01]])
    simulate, _, _ = symbolic_record(const, DT, 1, n, (), (), False, record.n_pieces, True)
    y = np.asarray(simulate(np.ones(N_COEFFICIENTS), theta, x0, *record.symbolic_inputs(),
                            positions.ravel()))
    expected = ForwardModel(const, record, positions).outputs(x0, theta)[0]
    np.testing.assert_allclose(y, expected, rtol=SAME_RTOL,
                               atol=SAME_RTOL * np.abs(expected).max())


def test_exogenous_constants_are_element_wise_for_casadi(setup) -> None:
    const, _, _ = setup
    row = ca.SX.sym("row", len(EXOGENOUS))
    symbolic_const = with_exogenous(const, row)
    fun = ca.Function("f", [row], [ca.vertcat(*symbolic_const)])
    values = np.arange(1.0, 1.0 + len(EXOGENOUS))
    expected = with_exogenous(const, values)
    np.testing.assert_array_equal(np.asarray(fun(values)).ravel(), np.array(expected))


def test_a_jump_a_rounding_error_after_a_sample_is_at_the_sample() -> None:
    # the knot snaps onto the sample: a jump there, not a ramp over the next interval
    t = np.arange(5) * 0.1
    pieces = Schedule(np.array([0, 0.2 + 1e-15, 0.2 + 1e-15]),
                      np.array([1, 1, -1.0])).segments(t)
    np.testing.assert_array_equal(pieces.start[:, 0], [1, 1, -1, -1])
    np.testing.assert_array_equal(pieces.stop[:, 0], [1, 1, -1, -1])
