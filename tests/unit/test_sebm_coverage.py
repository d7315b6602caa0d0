"""SEBM-PSO refuses a model coefficient that none of its sub-problems estimates.

The sub-problems (eqs. 39-42) name coefficients by the paper's problem structure, so a
coefficient added to the model must be placed in one (README, "How to add a
coefficient"); until then SEBM-PSO says so in one line instead of returning garbage.
"""

from __future__ import annotations

import pytest

from aeroid.errors import EstimatorError
from aeroid.estimation import _sebm, make_estimator
from aeroid.estimation._objectives import SEBM_PROBLEMS


def test_sebm_refuses_a_coefficient_in_no_subproblem(clean_flight, monkeypatch):
    # the pitch-moment problem (Cma, Cmd, Cmq) left out: as if three coefficients were new
    monkeypatch.setattr(_sebm, "SEBM_PROBLEMS", SEBM_PROBLEMS[:-1])
    est = make_estimator("sebm-pso", {"n_particles": [5, 5, 5], "n_iterations": 1})
    with pytest.raises(EstimatorError, match=r"^sebm-pso: no sub-problem estimates "
                                             r"Cma, Cmd, Cmq \(SEBM_PROBLEMS"):
        est.fit(clean_flight, rng=0)


def test_sebm_needs_one_swarm_size_per_subproblem():
    with pytest.raises(EstimatorError, match=f"n_particles needs {len(SEBM_PROBLEMS)} swarm"):
        make_estimator("sebm-pso", {"n_particles": [50] * (len(SEBM_PROBLEMS) + 1)})
