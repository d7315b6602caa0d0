"""Costs of the paper's estimators (aeroid.estimation) against direct forms and scipy."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from aeroid.estimation import estimate_noise_sd, reconstruct
from aeroid.estimation._objectives import (
    EBM_ROWS,
    GUARD_FRACTION,
    OutputErrorCost,
    QuadraticCost,
    channel_weights,
    ebm_cost,
    sebm_costs,
)
from aeroid.model import N_COEFFICIENTS

#: Quadratic form vs residual form: both exact; the difference is round-off of sums of
#: ~1e3 terms with condition ~1e6.
QUADRATIC_RTOL = 1e-8
#: Closed-form minimiser vs scipy.linalg.lstsq (same problem, different algorithm).
LSTSQ_RTOL = 1e-8
#: numba vs numpy EAM cost: same arithmetic in a different order (the numpy path uses
#: the same propagate; only the output/cost evaluation differs).
BACKEND_RTOL = 1e-9
#: Noise-free EAM prediction at the true coefficients vs the measured outputs, max
#: error / channel RMS. Measured 1.6e-3 (q, r: the SG-smoothed initial rates of eq. 32
#: at the first sample, notes "EAM"; RK4 at 2 ms vs the truth's 0.25 ms is ~1e-7).
EAM_PREDICTION_RTOL = 5e-3


@pytest.fixture(scope="module")
def clean_rec(clean_flight):
    return reconstruct(clean_flight)


@pytest.fixture(scope="module")
def paper_rec(paper_flight):
    return reconstruct(paper_flight)


def test_relative_weights_guard_small_denominators() -> None:
    z = np.column_stack([np.sin(np.linspace(0, 20, 1000)), np.full(1000, 2.0)])
    w = channel_weights(z, "relative")
    rms = np.sqrt(np.mean(z**2, axis=0))
    small = np.abs(z) < GUARD_FRACTION * rms
    assert small[:, 0].any()
    assert np.all(w[small] == 0.0)
    np.testing.assert_allclose(w[~small], 1.0 / z[~small] ** 2)
    w0 = channel_weights(z, "relative", guard_fraction=0.0)
    assert np.all(w0[z != 0] > 0)


def test_noise_weights_are_inverse_variance() -> None:
    z = np.random.default_rng(1).standard_normal((500, 3)) * [1.0, 2.0, 4.0]
    w = channel_weights(z, "noise")
    np.testing.assert_allclose(w, np.broadcast_to(1.0 / estimate_noise_sd(z) ** 2, z.shape))
    with pytest.raises(ValueError, match="weighting"):
        channel_weights(z, "ml")


def test_quadratic_cost_equals_residual_form_and_scipy_lstsq() -> None:
    rng = np.random.default_rng(7)
    X = rng.standard_normal((200, 3, 5)) * [1, 10, 100, 1e-2, 1]
    y = rng.standard_normal((200, 3))
    w = rng.uniform(0.1, 2.0, (200, 3))
    cost = QuadraticCost(X, y, w)
    swarm = rng.standard_normal((50, 5))
    np.testing.assert_allclose(cost(swarm), cost.direct(swarm), rtol=QUADRATIC_RTOL)
    sw = np.sqrt(w).reshape(-1)
    ref = scipy.linalg.lstsq(X.reshape(-1, 5) * sw[:, None], y.reshape(-1) * sw)[0]
    np.testing.assert_allclose(cost.theta_opt, ref, rtol=LSTSQ_RTOL)
    # the optimum is a minimum: every other point costs more
    assert np.all(cost.direct(swarm) > cost.cost_min)
    assert isinstance(cost(swarm[0]), float)


@pytest.mark.parametrize("weighting", ["noise", "relative"])
def test_ebm_cost_quadratic_form_on_flight(paper_flight, paper_rec, weighting) -> None:
    cost = ebm_cost(paper_flight, paper_rec, weighting=weighting)
    theta = paper_flight.airframe.prior_vector() * np.random.default_rng(2).uniform(
        0.5, 1.5, (40, N_COEFFICIENTS))
    np.testing.assert_allclose(cost(theta), cost.direct(theta), rtol=QUADRATIC_RTOL)


def test_sebm_costs_sum_to_ebm_cost(paper_flight, paper_rec) -> None:
    """With one noise level per channel, eq. 34's cost is the sum of eqs. 39-42."""
    theta = paper_flight.airframe.prior_vector() * np.random.default_rng(4).uniform(
        0.5, 1.5, (30, N_COEFFICIENTS))
    total = sum(c.direct(theta[:, list(cols)])
                for _, cols, c in sebm_costs(paper_flight, paper_rec))
    ebm = ebm_cost(paper_flight, paper_rec, rows=EBM_ROWS)
    np.testing.assert_allclose(total, ebm.direct(theta), rtol=QUADRATIC_RTOL)
    cols = [c for _, cs, _ in sebm_costs(paper_flight, paper_rec) for c in cs]
    assert sorted(cols) == list(range(N_COEFFICIENTS))


def test_noise_free_ebm_optimum_is_the_truth(clean_flight, clean_rec) -> None:
    # relative error bound: reconstruction error (test_reconstruct) propagated through
    # the fit; measured <= 6e-3 % (Cl0, Clp: the M_X row), other coefficients <= 5e-4 %.
    cost = ebm_cost(clean_flight, clean_rec, weighting="relative")
    err = np.abs(cost.theta_opt / clean_flight.true_coefficients - 1)
    assert np.all(err < 1e-3), err


@pytest.mark.parametrize("weighting", ["noise", "relative"])
def test_eam_cost_backends_agree(paper_flight, weighting) -> None:
    theta = paper_flight.airframe.prior_vector() * np.random.default_rng(9).uniform(
        0.7, 1.3, (12, N_COEFFICIENTS))
    fast = OutputErrorCost(paper_flight, weighting=weighting, backend="numba")(theta)
    slow = OutputErrorCost(paper_flight, weighting=weighting, backend="numpy")(theta)
    np.testing.assert_allclose(fast, slow, rtol=BACKEND_RTOL)


def test_eam_prediction_at_truth_matches_noise_free_data(clean_flight) -> None:
    cost = OutputErrorCost(clean_flight)
    truth = clean_flight.true_coefficients
    pred = cost.predict(truth)[0]
    rms = np.sqrt(np.mean(cost.measured**2, axis=0))
    assert np.all(np.max(np.abs(pred - cost.measured), axis=0) / rms < EAM_PREDICTION_RTOL)
    # and the truth beats a 10 % perturbation by orders of magnitude
    rel = OutputErrorCost(clean_flight, weighting="relative")
    assert rel(truth) < 1e-3 * rel(truth * 1.1)


def test_eam_diverging_particle_costs_inf(clean_flight) -> None:
    bad = clean_flight.true_coefficients.copy()
    bad[6], bad[8] = 300.0, 1e5  # statically unstable, violently undamped pitch
    costs = OutputErrorCost(clean_flight)(np.array([bad, clean_flight.true_coefficients]))
    assert costs[0] == np.inf
    assert np.isfinite(costs[1])


def test_eam_cost_rejects_bad_options(clean_flight) -> None:
    with pytest.raises(ValueError, match="weighting"):
        OutputErrorCost(clean_flight, weighting="paper")
    with pytest.raises(ValueError, match="guard_fraction"):
        OutputErrorCost(clean_flight, weighting="relative", guard_fraction=1.5)


#: Kinematic p0 from the (noise-free in the paper's model) roll angle: a 7-point SG
#: derivative of phi (phi'' ~ 4 rad/s^2 -> error ~ (3 dt)^2 phi''' tiny) vs the truth.
KINEMATIC_P0_ATOL = 1e-3
#: Smoothed p0: quadratic SG over 501 samples at the edge of uniform +-5 % noise on
#: p ~ 49 rad/s (sd 1.42 rad/s): edge-value sd ~ 3 sd / sqrt(501) = 0.19 rad/s; 3 sd.
SMOOTHED_P0_ATOL = 0.6


def test_eam_initial_roll_rate(paper_flight, clean_flight) -> None:
    true_p0 = clean_flight["p"][0]  # the same trajectory without sensor noise
    kin = OutputErrorCost(paper_flight, initial_state="kinematic")
    assert abs(kin.state0[3] - true_p0) < KINEMATIC_P0_ATOL
    smoothed = OutputErrorCost(paper_flight)
    assert abs(smoothed.state0[3] - true_p0) < SMOOTHED_P0_ATOL
    np.testing.assert_array_equal(smoothed.state0[[0, 1, 2, 6, 7, 8]],
                                  paper_flight.states()[0, [0, 1, 2, 6, 7, 8]])
    with pytest.raises(ValueError, match="initial_state"):
        OutputErrorCost(paper_flight, initial_state="zero")
