"""Equations of motion (eqs. 2-10): rigid-body identities, conservation laws, eq. 29's rank."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aeroid.estimation import accel_only_matrix
from aeroid.model import N_COEFFICIENTS
from aeroid.model._airframe import reference_airframe
from aeroid.model._atmosphere import G0
from aeroid.model._dynamics import (
    N_STATE,
    PHI,
    PSI,
    U,
    W,
    accelerometers,
    aero_forces_moments,
    air_data,
    constants,
    derivative_from_forces,
    regressors,
    state_derivative,
)
from aeroid.model._integrate import HAVE_NUMBA, propagate

#: Two evaluations of the same algebra in a different order: rounding only.
IDENTITY_RTOL = 1e-12
#: Central difference of smooth functions with step 1e-6: truncation ~1e-12 relative,
#: rounding ~1e-10 relative; measured below 1e-9.
FD_RTOL = 1e-7
#: RK4 (1 ms steps, spin 30 rad/s, coning frequency ~30 rad/s) on torque- and force-free
#: motion: the amplitude error of RK4 on a rotation is (W h)^6 / 144 per step, ~1e-8 over
#: 1000 steps; phase error (W h)^5 / 120 per step gives ~3e-7 rad on the closed form.
INVARIANT_RTOL = 1e-7
#: Phase error of that rotation, ~2e-7 rad over 1000 steps: bounds the closed-form rates
#: (amplitude 2.2 rad/s) and the direction of the earth-frame velocity (5x margin).
PHASE_RTOL = 1e-6
CLOSED_FORM_ATOL = 2e-6

BACKENDS = ["numpy", pytest.param("numba", marks=pytest.mark.skipif(not HAVE_NUMBA,
                                                                    reason="numba missing"))]


def _random_states(rng: np.random.Generator, n: int) -> np.ndarray:
    x = np.empty((n, N_STATE))
    x[:, 0] = rng.uniform(300, 700, n)
    x[:, 1:3] = rng.uniform(-20, 20, (n, 2))
    x[:, 3] = rng.uniform(-60, 60, n)
    x[:, 4:6] = rng.uniform(-3, 3, (n, 2))
    x[:, 6] = rng.uniform(-math.pi, math.pi, n)
    x[:, 7] = rng.uniform(-1.2, 1.2, n)
    x[:, 8] = rng.uniform(-math.pi, math.pi, n)
    return x


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def _dcm_body_to_earth(phi, theta, psi):
    cf, sf, ct, st, cp, sp = (np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta),
                              np.cos(psi), np.sin(psi))
    rx = np.array([[1, 0, 0], [0, cf, -sf], [0, sf, cf]])
    ry = np.array([[ct, 0, st], [0, 1, 0], [-st, 0, ct]])
    rz = np.array([[cp, -sp, 0], [sp, cp, 0], [0, 0, 1]])
    return rz @ ry @ rx


@pytest.fixture(scope="module")
def const():
    return constants(reference_airframe())


def test_constants_of_the_reference_airframe(const):
    assert const.rho == pytest.approx(0.4127, abs=5e-5)  # ISA at 10 km (reference README)
    assert const.area == pytest.approx(math.pi * 0.127**2 / 4, rel=1e-15)
    assert const.gravity == G0
    assert (const.mass, const.ix, const.iy, const.iz, const.thrust) == (70.0, 0.18, 40.0, 40.0,
                                                                       740.0)


def test_air_data_closed_forms():
    state = np.zeros((3, N_STATE))
    state[:, U] = 3.0
    state[0, W] = 3.0  # alpha = 45 deg
    state[1, 1] = 4.0  # v = 4: V = 5, beta = asin(4/5)
    state[2, W] = -3.0 * math.tan(0.1)
    speed, alpha, beta = air_data(state)
    np.testing.assert_allclose(speed, [math.sqrt(18), 5.0, 3 / math.cos(0.1)], rtol=1e-15)
    np.testing.assert_allclose(alpha, [math.pi / 4, 0.0, -0.1], rtol=1e-14, atol=1e-16)
    np.testing.assert_allclose(beta, [0.0, math.asin(0.8), 0.0], rtol=1e-14, atol=1e-16)


def test_regressors_times_coefficients_equal_forces_and_moments(const, reference_scenario):
    rng = np.random.default_rng(11)
    states = _random_states(rng, 50)
    delta = rng.choice([-0.14, 0.14], 50)
    coefficients = reference_scenario.coefficient_vector * rng.uniform(0.5, 1.5,
                                                                       (50, N_COEFFICIENTS))
    fm = aero_forces_moments(states, delta, coefficients, const)
    via_regressors = np.einsum("nij,nj->ni", regressors(states, delta, const), coefficients)
    np.testing.assert_allclose(via_regressors, fm, rtol=IDENTITY_RTOL,
                               atol=IDENTITY_RTOL * np.abs(fm).max())


def test_rotational_equations_are_eulers_equations(const, reference_scenario):
    # I wdot + w x (I w) = M, exact for Iy = Iz (eq. 5 has no (Iy - Iz) q r term)
    rng = np.random.default_rng(12)
    states = _random_states(rng, 20)
    fm = aero_forces_moments(states, 0.1, reference_scenario.coefficient_vector, const)
    xdot = derivative_from_forces(states, fm, const)
    inertia = np.diag([const.ix, const.iy, const.iz])
    for x, m, xd in zip(states, fm[:, 3:], xdot, strict=True):
        omega = x[3:6]
        expected = np.linalg.solve(inertia, m - np.cross(omega, inertia @ omega))
        np.testing.assert_allclose(xd[3:6], expected, rtol=IDENTITY_RTOL, atol=1e-12)
    # with Iy != Iz the model differs from Euler's equations by exactly that term in pdot
    skewed = const._replace(iz=30.0)
    x = states[0]
    xd = derivative_from_forces(x, fm[0], skewed)
    assert xd[3] == pytest.approx(fm[0, 3] / skewed.ix, rel=1e-15)


def test_translational_and_euler_angle_kinematics_in_the_earth_frame(const, reference_scenario):
    # d/dt (C v_B) = C (F_A + F_T) / m + g_E, and the Euler rates rotate C as C [w]x:
    # both checked by a central difference along the model's own derivative.
    rng = np.random.default_rng(13)
    eps = 1e-6
    for x in _random_states(rng, 10):
        delta = 0.14
        coefficients = reference_scenario.coefficient_vector
        xd = state_derivative(x, delta, coefficients, const)
        fm = aero_forces_moments(x, delta, coefficients, const)
        eta, eta_dot = x[PHI:PSI + 1], xd[PHI:PSI + 1]
        c_plus = _dcm_body_to_earth(*(eta + eps * eta_dot))
        c_minus = _dcm_body_to_earth(*(eta - eps * eta_dot))
        c0 = _dcm_body_to_earth(*eta)
        dc = (c_plus - c_minus) / (2 * eps)
        np.testing.assert_allclose(dc, c0 @ _skew(x[3:6]), rtol=0,
                                   atol=FD_RTOL * np.abs(x[3:6]).max())
        v_plus = c_plus @ (x[:3] + eps * xd[:3])
        v_minus = c_minus @ (x[:3] - eps * xd[:3])
        accel_earth = (v_plus - v_minus) / (2 * eps)
        force = fm[:3] + np.array([const.thrust, 0, 0])
        expected = c0 @ force / const.mass + np.array([0, 0, const.gravity])
        np.testing.assert_allclose(accel_earth, expected, rtol=0,
                                   atol=FD_RTOL * np.abs(x[3:6]).max() * np.abs(x[:3]).max())


@pytest.mark.parametrize("backend", BACKENDS)
def test_torque_free_spinning_body_conserves_momentum_and_energy(const, backend):
    # aerodynamics, gravity and thrust off; Ix != Iy = Iz
    free = const._replace(gravity=0.0, thrust=0.0)
    p0, q0, r0 = 30.0, 2.0, -1.0
    x0 = np.array([300.0, 5.0, -3.0, p0, q0, r0, 0.1, 0.2, 0.3])
    dt, n = 1e-3, 1000
    out = propagate(x0, np.zeros(N_COEFFICIENTS), np.zeros(n), dt, free, backend=backend)[0]
    inertia = np.array([free.ix, free.iy, free.iz])
    omega = out[:, 3:6]
    momentum = np.linalg.norm(omega * inertia, axis=1)
    energy = 0.5 * np.sum(inertia * omega**2, axis=1)
    np.testing.assert_allclose(momentum, momentum[0], rtol=INVARIANT_RTOL)
    np.testing.assert_allclose(energy, energy[0], rtol=INVARIANT_RTOL)
    # force-free: |v_B| and the earth-frame velocity are constant
    np.testing.assert_allclose(np.linalg.norm(out[:, :3], axis=1), np.linalg.norm(x0[:3]),
                               rtol=INVARIANT_RTOL)
    v_earth = np.array([_dcm_body_to_earth(*s[6:9]) @ s[:3] for s in out[::100]])
    np.testing.assert_allclose(v_earth, np.broadcast_to(v_earth[0], v_earth.shape),
                               rtol=0, atol=PHASE_RTOL * np.linalg.norm(x0[:3]))
    # closed form for Iy = Iz: p constant, (q, r) rotate at W = (Iy - Ix) / Iy p
    t = dt * np.arange(n + 1)
    rate = (free.iy - free.ix) / free.iy * p0
    np.testing.assert_allclose(out[:, 3], p0, rtol=1e-14)
    np.testing.assert_allclose(out[:, 4], q0 * np.cos(rate * t) + r0 * np.sin(rate * t),
                               atol=CLOSED_FORM_ATOL)
    np.testing.assert_allclose(out[:, 5], r0 * np.cos(rate * t) - q0 * np.sin(rate * t),
                               atol=CLOSED_FORM_ATOL)


# --- eq. 29: the accelerometer-only system --------------------------------------------
def _eq29_matrix(positions: np.ndarray, mass: float, inertia: np.ndarray) -> np.ndarray:
    """A (6 x 6): readings of both triads per unit [FAX, FAY, FAZ, MX, MY, MZ].

    Eq. 28 with wdot = I^-1 M (eqs. 5-7; the gyroscopic terms go to B):
    a_R = F / m + (I^-1 M) x R = F / m - [R]x I^-1 M.
    """
    inv = np.diag(1.0 / inertia)
    return np.vstack([np.hstack([np.eye(3) / mass, -_skew(r) @ inv]) for r in positions])


def test_eq29_matrix_equals_the_implemented_eq28(const, clean_flight, reference_scenario):
    # The library's A (EBM step 1, read off the model's eq. 28) against the closed form
    # written here from the paper, and A FM + B = accelerometers() on the reference flight
    # (B: the gyroscopic and centripetal terms and the thrust, also written here)
    inertia = np.array([const.ix, const.iy, const.iz])
    positions = reference_scenario.airframe.accel_positions
    a = accel_only_matrix(reference_scenario.airframe)
    closed = _eq29_matrix(positions, const.mass, inertia)
    np.testing.assert_allclose(a, closed, rtol=1e-14, atol=1e-14 * np.abs(closed).max())
    state = clean_flight.states()[200]
    delta = clean_flight["delta"][200]
    truth = reference_scenario.coefficient_vector
    fm = aero_forces_moments(state, delta, truth, const)
    omega = state[3:6]
    gyro = -np.cross(omega, inertia * omega) / inertia
    b = np.concatenate([np.array([const.thrust, 0, 0]) / const.mass + np.cross(gyro, pos)
                        + np.cross(omega, np.cross(omega, pos)) for pos in positions])
    readings = accelerometers(state, delta, truth, const, positions).ravel()
    np.testing.assert_allclose(a @ fm + b, readings, rtol=1e-12, atol=1e-12)


def _random_airframe(rng: np.random.Generator):
    inertia = np.array([rng.uniform(0.1, 1.0), *np.repeat(rng.uniform(5, 50), 2)])
    if rng.random() < 0.5:
        inertia = rng.uniform(0.1, 50.0, 3)  # no symmetry at all
    positions = rng.uniform(-1.0, 1.0, (2, 3))
    return reference_airframe().replace(
        mass_kg=float(rng.uniform(10, 100)), ix_kgm2=float(inertia[0]),
        iy_kgm2=float(inertia[1]), iz_kgm2=float(inertia[2]),
        accel1_position_m=tuple(positions[0]), accel2_position_m=tuple(positions[1]))


def test_eq29_accelerometer_only_system_has_rank_5():
    # the matrix the reconstruction uses, for random geometries, mass and inertia
    rng = np.random.default_rng(29)
    for _ in range(25):
        airframe = _random_airframe(rng)
        a = accel_only_matrix(airframe)
        positions = airframe.accel_positions
        inertia = np.array([airframe.ix_kgm2, airframe.iy_kgm2, airframe.iz_kgm2])
        assert np.linalg.matrix_rank(a) == 5
        null = np.linalg.svd(a)[2][-1]
        assert np.linalg.norm(a @ null) < 1e-12 * np.linalg.norm(a)
        force, moment = null[:3], null[3:]
        wdot = moment / inertia
        baseline = positions[1] - positions[0]
        # the unseen angular acceleration lies along R2 - R1 ...
        assert np.linalg.norm(np.cross(wdot, baseline)) < 1e-10 * np.linalg.norm(wdot) * \
            np.linalg.norm(baseline)
        # ... with the force that cancels its tangential acceleration at R1
        np.testing.assert_allclose(force / airframe.mass_kg, np.cross(positions[0], wdot),
                                   rtol=1e-8, atol=1e-10 * np.linalg.norm(wdot))


def test_eq29_rank_5_on_the_reference_geometry(const):
    inertia = np.array([const.ix, const.iy, const.iz])
    positions = reference_airframe().accel_positions
    a = accel_only_matrix(reference_airframe())
    assert np.linalg.matrix_rank(a) == 5
    null = np.linalg.svd(a)[2][-1]
    wdot = null[3:] / inertia
    baseline = positions[1] - positions[0]
    cosine = abs(wdot @ baseline) / (np.linalg.norm(wdot) * np.linalg.norm(baseline))
    assert cosine == pytest.approx(1.0, abs=1e-12)
