"""Sensors: eq. 28 against a finite difference of the simulated motion; noise statistics."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats
from scipy.integrate import solve_ivp

from aeroid.errors import AirframeError
from aeroid.flights._noise import (
    ACCEL_CHANNELS,
    RATE_CHANNELS,
    GaussianNoise,
    NoNoise,
    PaperNoise,
    make_noise,
    noise_from_dict,
)
from aeroid.flights._simulate import simulate_scenario
from aeroid.model._dynamics import accelerometers, constants, state_derivative

#: Half-width of the 5-point central-difference stencil [s]. Its truncation error
#: (h^4/90 d^6x/dt^6, ~p^6 |R| h^4 / 90 for a point rotating at p = 50 rad/s) is 2e-7 m/s^2
#: here; smaller steps are limited by the integrator's and rounding errors (measured).
FD_STEP_S = 2e-4
#: Finite-difference acceleration versus eq. 28 [m/s^2]: measured 2.1e-7 at readings up
#: to 560 m/s^2; 10x margin. Dropping the wdot x R term would change readings by ~1 m/s^2.
FD_ATOL_MPS2 = 2e-6
#: Kolmogorov-Smirnov test of the relative errors against U[-xi, xi]: with the fixed
#: seed this is deterministic; a p-value below 1e-3 would mean the noise is not uniform.
KS_MIN_PVALUE = 1e-3
#: Sample standard deviation of n Gaussian draws has relative sd 1/sqrt(2 n); accept 5 of it.
GAUSS_SD_SIGMAS = 5.0


def _dcm_body_to_earth(phi: float, theta: float, psi: float) -> np.ndarray:
    """Rotation body -> earth (NED) for 3-2-1 Euler angles: v_E = C v_B."""
    cf, sf, ct, st, cp, sp = (math.cos(phi), math.sin(phi), math.cos(theta), math.sin(theta),
                              math.cos(psi), math.sin(psi))
    rx = np.array([[1, 0, 0], [0, cf, -sf], [0, sf, cf]])
    ry = np.array([[ct, 0, st], [0, 1, 0], [-st, 0, ct]])
    rz = np.array([[cp, -sp, 0], [sp, cp, 0], [0, 0, 1]])
    return rz @ ry @ rx


def _fd_specific_force(state0, delta, coefficients, const, positions):
    """Specific force at ``positions`` from the motion of the sensor points.

    Integrates the state and the c.g. position in the earth frame (dx_E/dt = C v_B) with
    constant ``delta`` over [-2h, 2h], differentiates each sensor point's earth position
    x_E + C R twice (5-point stencil), subtracts gravity and rotates to body axes.
    """
    def rhs(_t, y):
        x = y[:9]
        return np.concatenate([state_derivative(x, delta, coefficients, const),
                               _dcm_body_to_earth(*x[6:9]) @ x[:3]])

    h = FD_STEP_S
    y0 = np.concatenate([state0, np.zeros(3)])
    opts = {"method": "DOP853", "rtol": 1e-13, "atol": 1e-15}
    fwd = solve_ivp(rhs, (0.0, 2 * h), y0, t_eval=[h, 2 * h], **opts)
    bwd = solve_ivp(rhs, (0.0, -2 * h), y0, t_eval=[-h, -2 * h], **opts)
    assert fwd.success and bwd.success
    ys = [bwd.y[:, 1], bwd.y[:, 0], y0, fwd.y[:, 0], fwd.y[:, 1]]  # t = -2h .. 2h
    weights = np.array([-1.0, 16.0, -30.0, 16.0, -1.0]) / (12.0 * h * h)
    gravity_earth = np.array([0.0, 0.0, const.gravity])
    c0 = _dcm_body_to_earth(*state0[6:9])
    out = []
    for pos in positions:
        points = np.array([y[9:] + _dcm_body_to_earth(*y[6:9]) @ pos for y in ys])
        accel_earth = weights @ points
        out.append(c0.T @ (accel_earth - gravity_earth))
    return np.array(out)


@pytest.mark.parametrize("sample", [0, 137, 400])
def test_eq28_equals_finite_difference_of_the_motion(clean_flight, reference_scenario, sample):
    airframe = reference_scenario.airframe
    const = constants(airframe)
    truth = reference_scenario.coefficient_vector
    rng = np.random.default_rng(sample)
    positions = np.vstack([airframe.accel_positions, rng.uniform(-0.5, 0.5, (1, 3))])
    state = clean_flight.states()[sample]
    delta = clean_flight["delta"][sample]
    expected = _fd_specific_force(state, delta, truth, const, positions)
    readings = accelerometers(state, delta, truth, const, positions)
    assert readings.shape == (3, 3)
    np.testing.assert_allclose(readings, expected, rtol=0, atol=FD_ATOL_MPS2)
    # the flight's own channels are these readings at the true positions
    np.testing.assert_allclose(clean_flight.accelerations()[sample], readings[:2], rtol=1e-14,
                               atol=1e-12)


def test_accelerometers_broadcast_over_samples(clean_flight, reference_scenario):
    const = constants(reference_scenario.airframe)
    states = clean_flight.states()[:5]
    delta = clean_flight["delta"][:5]
    pos = reference_scenario.airframe.accel_positions
    batch = accelerometers(states, delta, reference_scenario.coefficient_vector, const, pos)
    assert batch.shape == (5, 2, 3)
    for k in range(5):
        one = accelerometers(states[k], delta[k], reference_scenario.coefficient_vector, const, pos)
        np.testing.assert_array_equal(batch[k], one)


# --- noise ---------------------------------------------------------------------------
NOISY = (*ACCEL_CHANNELS, *RATE_CHANNELS)
CLEAN = ("t", "delta", "u", "v", "w", "alpha", "beta", "phi", "theta", "psi")


def test_paper_noise_is_uniform_multiplicative(clean_flight, paper_flight):
    xi = PaperNoise().accelerations_xi
    assert PaperNoise().rates_xi == xi
    rel = np.column_stack([paper_flight[c] / clean_flight[c] - 1.0 for c in NOISY])
    assert rel.min() >= -xi * (1 + 1e-12)
    assert rel.max() <= xi * (1 + 1e-12)
    # the range is filled: P(no draw in the top 0.5 % among 4509) = 0.995^4509 ~ 2e-10
    assert rel.min() < -0.99 * xi and rel.max() > 0.99 * xi
    uniform = stats.uniform(loc=-xi, scale=2 * xi).cdf
    assert stats.kstest(rel.ravel(), uniform).pvalue > KS_MIN_PVALUE
    for j in range(rel.shape[1]):  # each channel on its own (9 tests: Bonferroni)
        assert stats.kstest(rel[:, j], uniform).pvalue > KS_MIN_PVALUE / rel.shape[1]
    # channels are independent: no correlation between the draws of different channels
    corr = np.corrcoef(rel, rowvar=False)
    assert np.max(np.abs(corr - np.eye(len(NOISY)))) < 5 / math.sqrt(len(rel))


def test_paper_noise_leaves_other_channels_clean(clean_flight, paper_flight):
    for c in CLEAN:
        np.testing.assert_array_equal(paper_flight[c], clean_flight[c])


def test_paper_noise_perturbs_the_estimators_positions_within_xi(paper_flight,
                                                                 reference_scenario):
    true = np.array(paper_flight.metadata["true_accel_positions_m"])
    np.testing.assert_array_equal(true, reference_scenario.airframe.accel_positions)
    seen = paper_flight.airframe.accel_positions
    xi = PaperNoise().accel_position_xi
    nonzero = true != 0
    rel = seen[nonzero] / true[nonzero] - 1.0
    assert np.all(np.abs(rel) <= xi)
    assert np.all(rel != 0)
    np.testing.assert_array_equal(seen[~nonzero], 0.0)  # multiplicative: zeros stay zero


def test_same_seed_same_flight_and_different_seed_different_noise(reference_scenario,
                                                                   paper_flight, clean_flight):
    again = simulate_scenario(reference_scenario, PaperNoise(), rng=1)
    np.testing.assert_array_equal(again.data.to_numpy(), paper_flight.data.to_numpy())
    assert again.airframe == paper_flight.airframe
    other = simulate_scenario(reference_scenario, PaperNoise(), rng=2)
    for c in NOISY:
        assert not np.any(other[c] == paper_flight[c])
    assert other.airframe.accel_positions[0, 0] != paper_flight.airframe.accel_positions[0, 0]
    generator = simulate_scenario(reference_scenario, PaperNoise(),
                                  rng=np.random.default_rng(1))
    np.testing.assert_array_equal(generator.data.to_numpy(), paper_flight.data.to_numpy())


def test_gaussian_noise_standard_deviation(reference_scenario, clean_flight):
    noise = GaussianNoise(accel_sd_mps2=0.2, rate_sd_radps=0.01, position_sd_m=0.002)
    flight = simulate_scenario(reference_scenario, noise, rng=3)
    for names, sd in ((ACCEL_CHANNELS, 0.2), (RATE_CHANNELS, 0.01)):
        err = np.column_stack([flight[c] - clean_flight[c] for c in names]).ravel()
        n = err.size
        assert abs(err.mean()) < GAUSS_SD_SIGMAS * sd / math.sqrt(n)
        assert err.std(ddof=1) == pytest.approx(sd, rel=GAUSS_SD_SIGMAS / math.sqrt(2 * n))
        assert stats.normaltest(err).pvalue > KS_MIN_PVALUE
    diff = flight.airframe.accel_positions - reference_scenario.airframe.accel_positions
    assert np.all(np.abs(diff) < 5 * 0.002) and np.all(diff != 0)


def test_no_noise_changes_nothing(reference_scenario, clean_flight):
    assert clean_flight.airframe == reference_scenario.airframe
    channels = {c: clean_flight[c] for c in NOISY}
    out = NoNoise().corrupt(channels, np.random.default_rng(0))
    for c in NOISY:
        np.testing.assert_array_equal(out[c], channels[c])


def test_make_noise_and_round_trip():
    noise = make_noise("paper", accelerations_xi=0.02)
    assert noise == PaperNoise(accelerations_xi=0.02)
    assert noise_from_dict(noise.to_dict()) == noise
    assert noise_from_dict(GaussianNoise().to_dict()) == GaussianNoise()
    with pytest.raises(ValueError, match="unknown noise model 'laplace'"):
        make_noise("laplace")
    with pytest.raises(ValueError, match="unknown option"):
        make_noise("gaussian", sigma=1.0)


@pytest.mark.parametrize(("name", "options", "message"), [
    ("paper", {"rates_xi": "x"}, "noise model 'paper': rates_xi must be a finite number >= 0, "
                                 "got 'x'"),
    ("paper", {"accelerations_xi": True}, "accelerations_xi must be a finite number >= 0"),
    ("paper", {"accel_position_xi": -0.1}, "accel_position_xi must be a finite number >= 0"),
    ("gaussian", {"accel_sd_mps2": [0.05]}, "accel_sd_mps2 must be a finite number >= 0"),
    ("gaussian", {"rate_sd_radps": float("nan")}, "rate_sd_radps must be a finite number"),
    ("laplace", {}, "unknown noise model 'laplace'"),
])
def test_noise_options_are_checked_at_construction(name, options, message):
    with pytest.raises(AirframeError) as info:
        make_noise(name, **options)
    assert message in str(info.value) and "\n" not in str(info.value)
