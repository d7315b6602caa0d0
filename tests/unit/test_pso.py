"""Unit tests of the paper's modified PSO (aeroid/pso.py, eqs. 17-22)."""

import itertools

import numpy as np
import pytest

from aeroid.estimation._benchmark_functions import (
    ackley,
    griewank,
    rastrigin,
    rosenbrock,
    sphere,
)
from aeroid.estimation._pso import (
    PSOResult,
    interpolation_partners,
    local_best,
    minimize,
    quadratic_vertex,
    ring_neighbours,
    update_velocity_position,
)

# Hand-computed update values are exact decimals; float64 rounding of a few operations.
UPDATE_ATOL = 1e-15
# Vertex of a sampled parabola: a/(2b) from O(1) numbers loses a few ulps.
VERTEX_ATOL = 1e-12
# Sphere is exactly quadratic; the interpolation converges to rounding error.
SPHERE_COST_TOL = 1e-10
# Rosenbrock d=2, 3: the budget below reaches the valley floor to this cost.
ROSENBROCK_COST_TOL = 1e-4
# Rosenbrock d=4 with the ring spreads information slowly: a looser, stated target.
ROSENBROCK4_RING_COST_TOL = 5e-2
# Rastrigin: every non-global local minimum costs >= ~1, so 1e-6 means "global basin found".
RASTRIGIN_COST_TOL = 1e-6
# Distance of the found point from the known minimiser for the easy problems.
POSITION_ATOL = 1e-3


# ---------------------------------------------------------------- update step (eqs. 17-19)


def test_update_matches_hand_computed_3x2_case():
    x = np.array([[0.50, 0.50], [0.20, 0.80], [0.90, 0.10]])
    v = np.array([[0.10, -0.10], [0.05, 0.00], [-0.20, 0.15]])
    pbest = np.array([[0.60, 0.40], [0.20, 0.70], [1.00, 0.30]])
    lbest = np.array([[0.70, 0.50], [0.60, 0.70], [0.80, 0.30]])
    w = np.array([[0.5, 1.0], [0.0, 0.5], [0.5, 0.5]])
    r1 = np.array([[0.5, 0.5], [1.0, 0.0], [0.5, 0.25]])
    r2 = np.array([[0.25, 0.0], [0.25, 1.0], [1.0, 0.5]])
    r_reset = np.array([[-0.11, 0.12], [0.13, -0.14], [0.15, -0.16]])
    # v_new = w v + r1 (pbest - x) + r2 (lbest - x), c1 = c2 = 1:
    # (0,0) 0.05 + 0.05 + 0.05 = 0.15      (0,1) -0.10 - 0.05 + 0 = -0.15
    # (1,0) 0 + 0 + 0.10 = 0.10            (1,1) 0 + 0 - 0.10 = -0.10
    # (2,0) -0.10 + 0.05 - 0.10 = -0.15    (2,1) 0.075 + 0.05 + 0.10 = 0.225 > 0.2 -> -0.16
    expected_v = np.array([[0.15, -0.15], [0.10, -0.10], [-0.15, -0.16]])
    # x + v_new, and (2,1): 0.10 - 0.16 = -0.06 is clipped to 0.
    expected_x = np.array([[0.65, 0.35], [0.30, 0.70], [0.75, 0.0]])
    x_new, v_new = update_velocity_position(
        x, v, pbest, lbest, w=w, r1=r1, r2=r2, r_reset=r_reset, c1=1.0, c2=1.0, v_max=0.2
    )
    np.testing.assert_allclose(v_new, expected_v, rtol=0, atol=UPDATE_ATOL)
    np.testing.assert_allclose(x_new, expected_x, rtol=0, atol=UPDATE_ATOL)
    assert x_new[2, 1] == 0.0


def test_update_uses_c1_c2():
    x = np.array([[0.5]])
    zero = np.zeros((1, 1))
    one = np.ones((1, 1))
    # v = 0 + 2 * 1 * (0.55 - 0.5) + 0.5 * 1 * (0.6 - 0.5) = 0.1 + 0.05 = 0.15
    x_new, v_new = update_velocity_position(
        x, zero, x + 0.05, x + 0.1, w=zero, r1=one, r2=one, r_reset=zero, c1=2.0, c2=0.5
    )
    np.testing.assert_allclose(v_new, [[0.15]], rtol=0, atol=UPDATE_ATOL)
    np.testing.assert_allclose(x_new, [[0.65]], rtol=0, atol=UPDATE_ATOL)


def test_velocity_reset_replaces_exactly_components_over_v_max():
    rng = np.random.default_rng(0)
    n, d, v_max = 50, 4, 0.25
    v = rng.uniform(-0.5, 0.5, size=(n, d))
    v[0, 0], v[0, 1] = 0.25, -0.25  # exactly at the limit: kept (eq. 19 uses |v| > V_max)
    x = np.full((n, d), 0.5)
    zero, one = np.zeros((n, d)), np.ones((n, d))
    r_reset = rng.uniform(-v_max, v_max, size=(n, d))
    # w = 1, r1 = r2 = 0: the raw new velocity is v itself.
    _, v_new = update_velocity_position(
        x, v, x, x, w=one, r1=zero, r2=zero, r_reset=r_reset, v_max=v_max
    )
    over = np.abs(v) > v_max
    assert over.any() and (~over).any()
    np.testing.assert_array_equal(v_new[over], r_reset[over])
    np.testing.assert_array_equal(v_new[~over], v[~over])
    assert v_new[0, 0] == 0.25 and v_new[0, 1] == -0.25
    assert np.all(np.abs(v_new) <= v_max)


def test_update_is_pure():
    rng = np.random.default_rng(1)
    arrays = [rng.random((4, 3)) for _ in range(8)]
    copies = [a.copy() for a in arrays]
    x, v, pb, lb, w, r1, r2, rr = arrays
    update_velocity_position(x, v, pb, lb, w=w, r1=r1, r2=r2, r_reset=0.2 * rr)
    for a, c in zip(arrays, copies, strict=True):
        np.testing.assert_array_equal(a, c)


# ---------------------------------------------------------------- neighbourhood (section 2.1)


def test_ring_neighbours_n5_table():
    expected = np.array(
        [
            [3, 1],  # particle 0 sees 0-2 = -2 -> 3 and 1
            [4, 2],
            [0, 3],
            [1, 4],
            [2, 0],  # particle 4 sees 2 and 5 -> 0
        ]
    )
    np.testing.assert_array_equal(ring_neighbours(5), expected)


def test_ring_neighbours_n450_spot_checks_and_wrap():
    nb = ring_neighbours(450)
    assert nb.shape == (450, 2)
    assert nb[0].tolist() == [448, 1]
    assert nb[1].tolist() == [449, 2]
    assert nb[2].tolist() == [0, 3]
    assert nb[100].tolist() == [98, 101]
    assert nb[448].tolist() == [446, 449]
    assert nb[449].tolist() == [447, 0]
    # Singly linked: if k sees j, j does not see k.
    k = np.arange(450)
    for col in range(2):
        j = nb[:, col]
        assert not np.any((nb[j, 0] == k) | (nb[j, 1] == k))


def test_local_best_ring_and_global():
    pbest_x = np.arange(5.0)[:, None] * np.ones((1, 2))
    cost = np.array([5.0, 1.0, 3.0, np.inf, 2.0])
    # Candidates (self, k-2, k+1): 0:{0,3,1}->1  1:{1,4,2}->1  2:{2,0,3}->2  3:{3,1,4}->1
    # 4:{4,2,0}->4
    lb = local_best(pbest_x, cost, ring_neighbours(5))
    np.testing.assert_array_equal(lb[:, 0], [1, 1, 2, 1, 4])
    lb_global = local_best(pbest_x, cost, None)
    np.testing.assert_array_equal(lb_global[:, 0], [1, 1, 1, 1, 1])


def test_local_best_tie_goes_to_self():
    pbest_x = np.arange(5.0)[:, None]
    lb = local_best(pbest_x, np.ones(5), ring_neighbours(5))
    np.testing.assert_array_equal(lb[:, 0], np.arange(5.0))


def test_interpolation_partners_distinct_and_not_self():
    rng = np.random.default_rng(2)
    for n in (3, 4, 7, 450):
        for _ in range(20):
            nb = interpolation_partners(n, rng)
            i = np.arange(n)
            assert nb.shape == (n, 2)
            assert np.all((nb >= 0) & (nb < n))
            assert np.all(nb[:, 0] != i) and np.all(nb[:, 1] != i)
            assert np.all(nb[:, 0] != nb[:, 1])
    with pytest.raises(ValueError):
        interpolation_partners(2, rng)


def test_interpolation_partners_cover_all_pairs():
    rng = np.random.default_rng(3)
    pairs = {tuple(p) for _ in range(200) for p in interpolation_partners(4, rng)[:1]}
    # Particle 0 has 3 others, hence 6 ordered pairs; 200 draws see them all.
    assert pairs == {p for p in itertools.permutations((1, 2, 3), 2)}


# ---------------------------------------------------------------- interpolation (eqs. 20-22)


def parabola(x):
    return (np.asarray(x) - 0.3) ** 2 + 2.0


def test_vertex_of_known_parabola_any_order():
    points = (0.1, 0.5, 0.9)
    for p in itertools.permutations(points):
        got = quadratic_vertex(*p, *parabola(p), fallback=0.77)
        assert abs(got - 0.3) <= VERTEX_ATOL


def test_vertex_exact_for_dyadic_numbers():
    xs = np.array([0.0, 0.5, 1.0])
    js = (xs - 0.25) ** 2 + 2.0
    assert quadratic_vertex(*xs, *js, fallback=0.9) == 0.25


def test_vertex_vectorised_with_per_particle_costs():
    # Two particles x two dimensions; costs (n, 1) broadcast over dimensions.
    x_i = np.array([[0.1, 0.1], [0.2, 0.0]])
    x_1 = np.array([[0.5, 0.5], [0.4, 0.5]])
    x_2 = np.array([[0.9, 0.9], [0.8, 1.0]])
    j = parabola  # the same parabola along every dimension
    got = quadratic_vertex(
        x_i,
        x_1,
        x_2,
        j(x_i[:, :1]),
        j(x_1[:, :1]),
        j(x_2[:, :1]),
        fallback=np.full((2, 2), 0.77),
    )
    # Dimension 0 samples the parabola itself; dimension 1 of row 0 too (same x).
    np.testing.assert_allclose(got[:, 0], 0.3, rtol=0, atol=VERTEX_ATOL)
    np.testing.assert_allclose(got[0, 1], 0.3, rtol=0, atol=VERTEX_ATOL)
    assert got.shape == (2, 2)


@pytest.mark.parametrize(
    ("xs", "js"),
    [
        ((0.1, 0.5, 0.9), -parabola((0.1, 0.5, 0.9))),  # concave
        ((0.5, 0.1, 0.9), -parabola((0.5, 0.1, 0.9))),  # concave, unordered
        ((0.0, 0.5, 1.0), (1.0, 2.0, 3.0)),  # collinear (dyadic: b is exactly 0)
        ((0.0, 0.5, 1.0), (2.0, 2.0, 2.0)),  # flat
        ((0.3, 0.3, 0.9), (1.0, 1.0, 3.0)),  # coincident points
        ((0.4, 0.4, 0.4), (1.0, 2.0, 3.0)),  # all coincident
        ((0.1, 0.5, 0.9), (np.inf, 2.0, 3.0)),  # non-finite cost
        ((0.1, 0.5, 0.9), (np.nan, 2.0, 3.0)),
    ],
)
def test_vertex_falls_back_when_no_minimum(xs, js):
    for perm in itertools.permutations(range(3)):
        x = [xs[k] for k in perm]
        j = [js[k] for k in perm]
        assert quadratic_vertex(*x, *j, fallback=0.77) == 0.77


def test_vertex_clipped_into_unit_interval():
    xs = np.array([0.1, 0.5, 0.9])
    assert quadratic_vertex(*xs, *((xs - 1.5) ** 2), fallback=0.5) == 1.0
    assert quadratic_vertex(*xs, *((xs + 0.5) ** 2), fallback=0.5) == 0.0


# ---------------------------------------------------------------- minimize: behaviour


def test_positions_never_leave_bounds():
    bounds = [(-3.0, -1.0), (10.0, 1000.0), (0.0, 1e-3)]
    low, high = np.array(bounds).T
    seen = []

    def fun(x):
        seen.append(x.copy())
        # Optimum outside the box, in a corner, pushes particles against the walls.
        return np.sum((x - np.array([5.0, -1.0, 0.5])) ** 2, axis=1)

    res = minimize(fun, bounds, n_particles=20, n_iterations=60, rng=4)
    allx = np.concatenate(seen)
    assert np.all(allx >= low) and np.all(allx <= high)
    assert np.all(res.history_x >= low) and np.all(res.history_x <= high)
    np.testing.assert_allclose(res.x, [-1.0, 10.0, 1e-3], rtol=0, atol=POSITION_ATOL)


def test_nan_and_inf_costs_tolerated():
    def fun(x):
        cost = np.sum((x - 0.5) ** 2, axis=1)
        cost = np.where(x[:, 0] < 0.0, np.nan, cost)  # half the box undefined
        return np.where(x[:, 1] < -1.0, np.inf, cost)

    res = minimize(fun, [(-2.0, 2.0)] * 3, n_particles=30, n_iterations=100, rng=5)
    assert res.success
    np.testing.assert_allclose(res.x, 0.5, rtol=0, atol=POSITION_ATOL)
    assert np.all(np.isfinite(res.history_cost))


def test_all_nan_cost_gives_failure_not_crash():
    res = minimize(
        lambda x: np.full(len(x), np.nan), [(0.0, 1.0)] * 2, n_particles=5, n_iterations=5, rng=0
    )
    assert not res.success
    assert res.cost == np.inf
    assert res.x.shape == (2,)
    assert res.message == ("no finite cost: all 55 evaluated points gave NaN or inf "
                           "(maximum number of iterations reached)")


def test_zero_iterations_says_so():
    res = minimize(sphere, [(-1.0, 1.0)] * 2, n_particles=5, n_iterations=0, rng=0)
    assert res.n_iterations == 0 and res.n_evaluations == 5
    assert res.message == "no iteration run (n_iterations=0): the best point of the initial swarm"


def test_sphere_5d():
    res = minimize(sphere, [(-5.12, 5.12)] * 5, n_particles=40, n_iterations=200, rng=10)
    assert res.cost < SPHERE_COST_TOL
    np.testing.assert_allclose(res.x, 0.0, rtol=0, atol=POSITION_ATOL)


@pytest.mark.parametrize("d", [2, 3])
def test_rosenbrock_low_dim(d):
    res = minimize(rosenbrock, [(-5.0, 10.0)] * d, n_particles=50, n_iterations=400, rng=11)
    assert res.cost < ROSENBROCK_COST_TOL


def test_rosenbrock_4d_ring_and_global():
    bounds = [(-5.0, 10.0)] * 4
    ring = minimize(rosenbrock, bounds, n_particles=200, n_iterations=500, rng=12)
    assert ring.cost < ROSENBROCK4_RING_COST_TOL
    gbest = minimize(
        rosenbrock, bounds, n_particles=200, n_iterations=500, rng=12, topology="global"
    )
    assert gbest.cost < ROSENBROCK_COST_TOL


@pytest.mark.parametrize("d", [2, 3])
def test_rastrigin_low_dim(d):
    res = minimize(rastrigin, [(-5.12, 5.12)] * d, n_particles=40, n_iterations=200, rng=13)
    assert res.cost < RASTRIGIN_COST_TOL


def test_history_is_consistent():
    res = minimize(rastrigin, [(-5.12, 5.12)] * 3, n_particles=20, n_iterations=30, rng=14)
    assert isinstance(res, PSOResult)
    assert res.history_cost.shape == (31,)
    assert res.history_x.shape == (31, 3)
    assert np.all(np.diff(res.history_cost) <= 0.0)
    np.testing.assert_array_equal(rastrigin(res.history_x), res.history_cost)
    assert res.cost == res.history_cost[-1]
    np.testing.assert_array_equal(res.x, res.history_x[-1])
    assert res.n_iterations == 30
    assert res.message == "maximum number of iterations reached"


# ---------------------------------------------------------------- randomness


def run_rastrigin(rng):
    return minimize(rastrigin, [(-5.12, 5.12)] * 3, n_particles=15, n_iterations=20, rng=rng)


def test_same_seed_bitwise_identical():
    a, b = run_rastrigin(42), run_rastrigin(42)
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.history_x, b.history_x)
    np.testing.assert_array_equal(a.history_cost, b.history_cost)
    assert a.cost == b.cost and a.n_evaluations == b.n_evaluations
    c = run_rastrigin(np.random.default_rng(np.random.SeedSequence(42)))
    np.testing.assert_array_equal(a.history_x, c.history_x)


@pytest.mark.parametrize("seed", [1, 2])
def test_seed_draws_the_initial_swarm(seed):
    """The first evaluation is U[0, 1]^(n, d) from default_rng(seed), mapped onto the box."""
    low, high = np.array([-5.12, 0.0, 10.0]), np.array([5.12, 1e-3, 1000.0])
    seen = []

    def fun(x):
        seen.append(x.copy())
        return rastrigin(x)

    minimize(fun, np.column_stack([low, high]), n_particles=15, n_iterations=1, rng=seed)
    expected = low + np.random.default_rng(seed).random((15, 3)) * (high - low)
    np.testing.assert_allclose(seen[0], expected, rtol=1e-15, atol=0)


def test_global_numpy_random_state_untouched():
    np.random.seed(1234)  # noqa: NPY002 -- sets the legacy state this test observes
    before = np.random.get_state(legacy=True)  # noqa: NPY002 -- the state under test
    run_rastrigin(None)
    run_rastrigin(7)
    after = np.random.get_state(legacy=True)  # noqa: NPY002 -- the state under test
    assert before[0] == after[0]
    np.testing.assert_array_equal(before[1], after[1])
    assert before[2:] == after[2:]


# ---------------------------------------------------------------- options and counts


@pytest.mark.parametrize("topology", ["ring", "global"])
@pytest.mark.parametrize("interpolation", [True, False])
def test_n_evaluations_counted(topology, interpolation):
    n, iters, d = 12, 9, 2
    calls = []

    def fun(x):
        calls.append(len(x))
        return sphere(x)

    res = minimize(
        fun,
        [(-1.0, 1.0)] * d,
        n_particles=n,
        n_iterations=iters,
        rng=3,
        topology=topology,
        interpolation=interpolation,
    )
    expected = n * (iters + 1) + (n * iters if interpolation else 0)
    assert res.n_evaluations == sum(calls) == expected
    # One batched call per swarm evaluation.
    assert len(calls) == 1 + iters * (2 if interpolation else 1)
    assert all(c == n for c in calls)


def test_global_without_interpolation_finds_sphere():
    res = minimize(
        sphere,
        [(-5.12, 5.12)] * 3,
        n_particles=30,
        n_iterations=200,
        rng=6,
        topology="global",
        interpolation=False,
    )
    assert res.cost < SPHERE_COST_TOL


def test_callback_stops():
    seen = []

    def callback(iteration, best_x, best_cost):
        seen.append((iteration, best_x.shape, best_cost))
        return iteration == 3

    res = minimize(
        sphere, [(-1.0, 1.0)] * 2, n_particles=5, n_iterations=50, rng=0, callback=callback
    )
    assert [s[0] for s in seen] == [1, 2, 3]
    assert seen[-1][1] == (2,) and seen[-1][2] == res.cost
    assert res.n_iterations == 3
    assert res.history_cost.shape == (4,)
    assert res.message == "stopped by callback"


def test_stall_stopping():
    res = minimize(
        lambda x: np.ones(len(x)),
        [(0.0, 1.0)],
        n_particles=5,
        n_iterations=100,
        rng=0,
        stall_iterations=4,
    )
    assert res.n_iterations == 4
    assert res.message.startswith("stalled")
    assert res.success


def test_x0_seeds_the_swarm():
    x0 = np.array([[1.0, 2.0], [50.0, -50.0]])  # second row clipped into the bounds
    res = minimize(sphere, [(-3.0, 3.0)] * 2, n_particles=5, n_iterations=0, rng=0, x0=x0)
    assert res.n_iterations == 0
    assert res.history_cost.shape == (1,)
    assert res.cost <= 5.0  # at least as good as x0's first row
    res = minimize(sphere, [(-3.0, 3.0)] * 2, n_particles=5, n_iterations=0, rng=0, x0=[0, 0])
    assert res.cost == 0.0
    np.testing.assert_array_equal(res.x, [0.0, 0.0])
    with pytest.raises(ValueError, match="x0"):
        minimize(
            sphere,
            [(-3.0, 3.0)] * 2,
            n_particles=2,
            n_iterations=1,
            interpolation=False,
            x0=np.zeros((3, 2)),
        )


@pytest.mark.parametrize(
    "bounds",
    [
        [(1.0, 0.0)],
        [(0.0, 0.0)],
        [(0.0, 1.0), (2.0, 1.0)],
        [(0.0, np.inf)],
        [(np.nan, 1.0)],
        [0.0, 1.0],
        np.zeros((2, 3)),
        [],
        [("a", "b")],
    ],
)
def test_bad_bounds_raise_one_line(bounds):
    with pytest.raises(ValueError) as info:
        minimize(sphere, bounds, n_particles=5, n_iterations=1, rng=0)
    assert "\n" not in str(info.value)
    assert "bounds" in str(info.value)


def test_bad_options_raise():
    bounds = [(0.0, 1.0)]
    with pytest.raises(ValueError, match="topology"):
        minimize(sphere, bounds, topology="star")
    with pytest.raises(ValueError, match="n_particles"):
        minimize(sphere, bounds, n_particles=2)
    with pytest.raises(ValueError, match="costs"):
        minimize(lambda x: np.zeros(len(x) + 1), bounds, n_particles=5, n_iterations=1)


# ---------------------------------------------------------------- the shared test functions


#: The closed forms evaluated at hand-computed points: exact up to a few ulps of O(10).
CLOSED_FORM_ATOL = 1e-12


@pytest.mark.parametrize(("fun", "x", "expected"), [
    (sphere, [0.0, 0.0, 0.0], 0.0),
    (sphere, [1.0, 2.0, 3.0], 14.0),
    (rosenbrock, [1.0, 1.0, 1.0], 0.0),
    (rosenbrock, [0.0, 0.0], 1.0),  # (1 - 0)^2
    (rosenbrock, [1.0, 2.0], 100.0),  # 100 (2 - 1)^2
    (rosenbrock, [-1.0, 1.0, 0.0], 104.0),  # 0 + 2^2 + 100 (0 - 1)^2 + 0
    (rastrigin, [0.0, 0.0], 0.0),
    (rastrigin, [0.5], 20.25),  # 10 + 0.25 - 10 cos(pi)
    (rastrigin, [1.0, 2.0], 5.0),  # 20 + (1 - 10) + (4 - 10)
    (ackley, [0.0, 0.0, 0.0], 0.0),  # -20 - e + 20 + e
    (ackley, [1.0, 1.0], 20.0 - 20.0 * np.exp(-0.2)),  # cos(2 pi) = 1: -e + e
    (griewank, [0.0, 0.0], 0.0),
    (griewank, [np.pi, 0.0], 2.0 + np.pi**2 / 4000.0),  # 1 + pi^2/4000 - cos(pi) cos(0)
    (griewank, [0.0, np.pi * np.sqrt(2.0)], 2.0 + np.pi**2 / 2000.0),  # x2 / sqrt(2) = pi
])
def test_test_functions_equal_their_closed_forms(fun, x, expected):
    got = fun(np.array([x, x]))
    assert got.shape == (2,)
    np.testing.assert_allclose(got, expected, rtol=0, atol=CLOSED_FORM_ATOL)


@pytest.mark.parametrize("name", ["sphere", "rosenbrock", "rastrigin", "ackley"])
def test_test_functions_equal_pyswarms(name):
    """pyswarms' single_obj has the same formulas (its Ackley only inside [-32, 32])."""
    from aeroid.estimation import _benchmark_functions as ours
    from baselines.pyswarms_gbest import _quiet_pyswarms

    with _quiet_pyswarms():
        from pyswarms.utils.functions import single_obj
    low, high = ours.DOMAINS[name]
    high = min(high, 32.0)
    x = np.random.default_rng(5).uniform(max(low, -32.0), high, size=(50, 7))
    np.testing.assert_allclose(getattr(ours, name)(x), getattr(single_obj, name)(x),
                               rtol=1e-13, atol=1e-13)
