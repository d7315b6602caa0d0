"""Saturated samples leave output-error's likelihood (baselines._gauss_newton.Problem.mask)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aeroid.errors import EstimatorError
from aeroid.flights import reference_scenario, simulate_scenario
from aeroid.flights._noise import GaussianNoise
from aeroid.model import OUTPUT_CHANNELS
from baselines._gauss_newton import Problem, gauss_newton
from baselines.equation_error import EquationErrorEstimator
from baselines.output_error import OutputErrorEstimator

#: Two fits of the same problem by the same arithmetic up to the order of sums: the
#: parameters agree to rounding of the cost's sums (1e-16 relative, magnified by the
#: Gauss-Newton solve's condition, ~1e6 here).
IDENTITY_RTOL = 1e-8


@pytest.fixture(scope="module")
def flight():
    noise = GaussianNoise(accel_sd_mps2=0.5, rate_sd_radps=0.02, position_sd_m=0.0)
    return simulate_scenario(reference_scenario(), noise, rng=4)


class _Rows:
    """The model's outputs at some rows only: the log with the other samples removed."""

    def __init__(self, model, keep):
        self.model, self.keep = model, keep

    def outputs(self, p):
        return self.model.outputs(p)[self.keep]

    def outputs_jacobian(self, p):
        y, J = self.model.outputs_jacobian(p)
        return y[self.keep], J[:, self.keep]


@pytest.mark.parametrize("noise_model", ["channel", "signal"])
def test_masked_fit_equals_fit_without_the_samples(flight, noise_model):
    est = OutputErrorEstimator(noise_model=noise_model, equation_error_start=False,
                               max_iterations=8)
    prob = est.problem(flight)
    n = len(prob.z)
    drop = np.zeros(n, dtype=bool)
    drop[100:180] = drop[600:650] = True  # as a saturated stretch would
    mask = np.repeat(~drop[:, None], len(OUTPUT_CHANNELS), axis=1)
    masked = dataclasses.replace(prob, mask=mask)
    removed = Problem(z=prob.z[~drop], model=_Rows(prob.model, ~drop), r_floor=prob.r_floor,
                      noise_model=noise_model, prior_mean=prob.prior_mean,
                      prior_weight=prob.prior_weight)
    p0 = np.zeros(prob.model.scale.size)
    p0[:9] = flight.airframe.prior_vector() / prob.model.scale[:9]
    a = gauss_newton(masked, p0, max_iterations=8, tol=1e-3)
    b = gauss_newton(removed, p0, max_iterations=8, tol=1e-3)
    assert a.n_iterations == b.n_iterations
    np.testing.assert_allclose(a.p, b.p, rtol=IDENTITY_RTOL)
    np.testing.assert_allclose(a.nll, b.nll, rtol=1e-12)
    # and the mask changed the fit: the full record's fit is elsewhere
    full = gauss_newton(prob, p0, max_iterations=8, tol=1e-3)
    assert np.max(np.abs(full.p - a.p)) > 1e3 * IDENTITY_RTOL * np.max(np.abs(a.p))


def test_one_channel_masked_likelihood_is_the_closed_form(flight):
    """Per-channel masks: the cost at a point is Klein & Morelli's over the entries in."""
    prob = OutputErrorEstimator(noise_model="channel").problem(flight)
    mask = np.ones(prob.z.shape, dtype=bool)
    mask[200:260, OUTPUT_CHANNELS.index("p")] = False
    masked = dataclasses.replace(prob, mask=mask)
    p = np.zeros(prob.model.scale.size)
    p[:9] = 1.0  # the prior
    e_full = prob.z - prob.model.outputs(p)
    e = masked.residuals(p)
    var = masked.noise(e)
    want = 0.0
    for c in range(len(OUTPUT_CHANNELS)):
        used = e_full[mask[:, c], c]
        r = max(np.mean(used**2), prob.r_floor[c])
        want += 0.5 * used.size * np.log(r) + 0.5 * np.sum(used**2) / r
    got = 0.5 * np.sum(np.log(var)) + 0.5 * np.sum(e * e / var)
    np.testing.assert_allclose(got, want, rtol=1e-12)


def test_output_error_reads_the_flights_saturated_samples(flight):
    meta = {**flight.metadata, "saturated": {"p": list(range(200, 260))}}
    marked = dataclasses.replace(flight, metadata=meta)
    prob = OutputErrorEstimator().problem(marked)
    assert prob.mask is not None and int(np.sum(~prob.mask)) == 60
    assert not prob.mask[200:260, OUTPUT_CHANNELS.index("p")].any()
    # the record model carries it (Problem takes the model's mask) through the fit's steps
    p0 = np.zeros(prob.model.scale.size)
    p0[:9] = 1.0
    fit = gauss_newton(prob, p0, max_iterations=2, tol=1e-3)
    assert np.all(fit.e[200:260, OUTPUT_CHANNELS.index("p")] == 0.0)
    assert np.all(fit.r_diag[200:260, OUTPUT_CHANNELS.index("p")] == 1.0)
    # a method that cannot leave them out refuses the flight, in one line
    with pytest.raises(EstimatorError, match="60 saturated sample"):
        EquationErrorEstimator().fit(marked, rng=0)
