"""Gauss-Newton's trial points evaluated with their Jacobian (baselines/_gauss_newton.py).

While steps are accepted at their first trial, the next trial is evaluated with its
Jacobian (one model evaluation per iteration instead of two). Reference: the same fit
with every trial evaluated by the outputs alone (the solver before this change): the
same parameters, standard errors and cost, in fewer evaluations.
"""

from __future__ import annotations

import numpy as np
import pytest

import baselines._gauss_newton as gn
from baselines.output_error import OutputErrorEstimator

#: The two fits evaluate the same graphs at the same points (measured: equal bit for
#: bit); a margin of a few roundings.
SAME_RTOL = 1e-12


@pytest.mark.parametrize("options", [{}, {"estimate_delay": True, "delay_s": 3e-4}])
def test_trials_with_their_jacobian_leave_the_fit_unchanged(paper_flight, monkeypatch,
                                                            options):
    est = OutputErrorEstimator(compile_model=False, **options)
    fast = est.fit(paper_flight, rng=0)
    monkeypatch.setattr(gn, "_trial", lambda prob, p, with_jacobian: (prob.residuals(p), None))
    plain = est.fit(paper_flight, rng=0)
    assert fast.success and plain.success
    assert fast.n_iterations == plain.n_iterations
    np.testing.assert_allclose(fast.theta, plain.theta, rtol=SAME_RTOL)
    np.testing.assert_allclose(fast.stderr, plain.stderr, rtol=SAME_RTOL)
    assert fast.cost == pytest.approx(plain.cost, rel=SAME_RTOL)
    np.testing.assert_allclose(fast.info["parameters"], plain.info["parameters"],
                               rtol=SAME_RTOL, atol=1e-15)
    assert fast.n_evaluations < plain.n_evaluations
