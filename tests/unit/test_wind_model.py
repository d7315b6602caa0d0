"""The wind in the model (issue 26): the air-relative velocity, written once.

References: scipy's rotations (a second library) for the NED-to-body rotation; the
paper's still-air loads (eqs. 2-7 written out here) for zero wind; and Galilean
invariance for a steady wind on a flat earth: the air-relative velocity obeys the
still-air equations, so a flight in a steady wind W started from body velocity
``v0`` is the still-air flight started from ``v0 - R(attitude) W`` with every rate,
angle and accelerometer reading the same and ``u, v, w`` shifted by the rotated wind.
"""

from __future__ import annotations

import numpy as np
import pytest
from closeness import assert_close_in_norm
from scipy.spatial.transform import Rotation

from aeroid.flights import reference_scenario
from aeroid.model import (
    EXOGENOUS,
    HAVE_NUMBA,
    PHI,
    PSI,
    THETA,
    accelerometers,
    as_vector,
    constants,
    exogenous_table,
    propagate,
)
from aeroid.model import _equations as eq

#: One rotation evaluated two ways (sums of three products): rounding only.
ROTATION_RTOL = 1e-14
#: The Galilean identity holds for the ODE exactly; the two RK4 integrations discretise
#: different (equivalent) right-hand sides, so they agree to RK4's truncation error at
#: h = 0.25 ms over 1 s (measured 4e-13 of each state's range, numba and numpy).
GALILEAN_RTOL = 1e-10
#: A steady wind of 5 m/s from the south-west with a small updraft [m/s], NED.
WIND = (3.5, 3.5, -0.5)


def _state(rng: np.random.Generator, n: int = 64) -> eq.State:
    values = rng.uniform(-1.0, 1.0, (len(eq.STATE_NAMES), n))
    values[0] = 500.0 + 10.0 * values[0]  # u: forward flight
    values[6:] *= np.pi  # attitude anywhere
    return eq.State(*values)


def test_ned_to_body_is_scipys_rotation() -> None:
    rng = np.random.default_rng(3)
    x = _state(rng)
    ned = rng.normal(0.0, 5.0, (3, x.u.size))
    body = np.array(eq.ned_to_body(x.phi, x.theta, x.psi, *ned))
    for k in range(x.u.size):
        # body from NED: the inverse of the body-to-NED rotation of the 3-2-1 Euler angles
        r = Rotation.from_euler("ZYX", [x.psi[k], x.theta[k], x.phi[k]])
        assert_close_in_norm(body[:, k], r.inv().apply(ned[:, k]), ROTATION_RTOL)


def test_still_air_loads_are_the_papers_inertial_loads() -> None:
    """Zero wind: eqs. 2-7 on the inertial u, v, w, written out here independently."""
    rng = np.random.default_rng(4)
    x = _state(rng)
    c = eq.Coefficients(*rng.uniform(-2.0, 2.0, len(eq.Coefficients._fields)))
    const = constants(reference_scenario().airframe)
    assert (const.wind_n, const.wind_e, const.wind_d) == (0.0, 0.0, 0.0)
    delta = rng.uniform(-0.1, 0.1, x.u.size)
    loads = np.array(eq.aerodynamic_loads(x, c, delta, const))
    v2 = x.u ** 2 + x.v ** 2 + x.w ** 2
    speed = np.sqrt(v2)
    alpha, beta = np.arctan(x.w / x.u), np.arcsin(x.v / speed)
    qs = 0.5 * const.rho * v2 * const.area
    k = const.diameter / (2.0 * speed)
    paper = np.array([
        qs * c.Cx,
        qs * (c.Cza * beta - c.Czq * k * x.r),
        qs * (c.Cza * alpha + c.Czd * delta + c.Czq * k * x.q),
        qs * const.diameter * (c.Cl0 + c.Clp * k * x.p),
        qs * const.diameter * (c.Cma * alpha + c.Cmd * delta + c.Cmq * k * x.q),
        qs * const.diameter * (-c.Cma * beta + c.Cmq * k * x.r)])
    assert_close_in_norm(loads, paper, ROTATION_RTOL, axis=1)


def test_the_loads_see_the_air_relative_velocity() -> None:
    """A wind W on a state v equals still air on the state v - R W (same attitude, rates)."""
    rng = np.random.default_rng(5)
    x = _state(rng)
    c = eq.Coefficients(*rng.uniform(-2.0, 2.0, len(eq.Coefficients._fields)))
    still = constants(reference_scenario().airframe)
    windy = still._replace(wind_n=WIND[0], wind_e=WIND[1], wind_d=WIND[2])
    wx, wy, wz = (Rotation.from_euler("ZYX", np.column_stack([x.psi, x.theta, x.phi]))
                  .inv().apply(np.array(WIND)).T)
    shifted = x._replace(u=x.u - wx, v=x.v - wy, w=x.w - wz)
    assert_close_in_norm(np.array(eq.aerodynamic_loads(x, c, 0.02, windy)),
                         np.array(eq.aerodynamic_loads(shifted, c, 0.02, still)),
                         ROTATION_RTOL, axis=1)


@pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")
def test_the_compiled_still_air_hook_gives_zeros_and_the_rotation_otherwise() -> None:
    import numba

    from aeroid.model import _compiled  # noqa: F401 - registers the overloads

    compiled = numba.njit(lambda x, k: eq.wind_body(x, k))
    x = eq.State(500.0, 1.0, 2.0, 3.0, 0.1, 0.2, 0.7, 0.1, -2.0)
    still = constants(reference_scenario().airframe)
    assert compiled(x, still) == (0.0, 0.0, 0.0)
    windy = still._replace(wind_n=WIND[0], wind_e=WIND[1], wind_d=WIND[2])
    assert_close_in_norm(np.array(compiled(x, windy)), np.array(eq.wind_body(x, windy)),
                         ROTATION_RTOL)


@pytest.mark.parametrize("backend", ["numba", "numpy"] if HAVE_NUMBA else ["numpy"])
@pytest.mark.parametrize("per_sample", [False, True], ids=["constant", "per-sample"])
def test_a_steady_wind_is_still_air_seen_from_the_moving_air(backend, per_sample) -> None:
    """Galilean invariance on the reference flight (1 s, relay switching, rolling)."""
    s = reference_scenario()
    still = constants(s.airframe)
    windy = still._replace(wind_n=WIND[0], wind_e=WIND[1], wind_d=WIND[2])
    dt, n = s.manoeuvre.dt, 501
    x0 = np.array(s.manoeuvre.initial_state)
    x0[PHI] = 0.3
    x0[PSI] = 0.8  # a heading: the wind's north and east both matter
    delta = np.where(np.arange(n - 1) % 120 < 60, 1.0, -1.0) * s.airframe.delta_max_rad
    c = as_vector(s.coefficient_vector)
    exo = exogenous_table(windy, n) if per_sample else None
    with_wind = propagate(x0, c, delta, dt, windy, substeps=8, backend=backend,
                          exogenous=exo)[0]
    r0 = Rotation.from_euler("ZYX", [x0[PSI], x0[THETA], x0[PHI]]).inv().apply(WIND)
    x0_air = x0.copy()
    x0_air[:3] -= r0
    in_air = propagate(x0_air, c, delta, dt, still, substeps=8, backend=backend)[0]
    assert_close_in_norm(with_wind[:, 3:], in_air[:, 3:], GALILEAN_RTOL, axis=0)
    rotated = Rotation.from_euler("ZYX", with_wind[:, [PSI, THETA, PHI]]).inv().apply(WIND)
    assert_close_in_norm(with_wind[:, :3] - rotated, in_air[:, :3], GALILEAN_RTOL, axis=0)
    # the accelerometers read the same specific force in both
    pos = s.airframe.accel_positions
    held = np.append(delta, delta[-1])
    assert_close_in_norm(accelerometers(with_wind, held, c, windy, pos),
                         accelerometers(in_air, held, c, still, pos), GALILEAN_RTOL)
    # and the wind matters: without it in the model the speed would differ by ~5 m/s
    assert np.max(np.abs(with_wind[:, 0] - in_air[:, 0])) > 1.0


def test_the_wind_is_an_exogenous_input_of_any_sign() -> None:
    const = constants(reference_scenario().airframe)
    table = exogenous_table(const, 3, {"wind_n": [-4.0, 0.0, 4.0], "wind_d": [1.0, 0.0, -1.0]})
    np.testing.assert_array_equal(table[:, EXOGENOUS.index("wind_n")], [-4.0, 0.0, 4.0])
    np.testing.assert_array_equal(table[:, EXOGENOUS.index("wind_e")], 0.0)
    with pytest.raises(ValueError, match="wind_e.*non-finite"):
        exogenous_table(const, 2, {"wind_e": [0.0, np.nan]})
