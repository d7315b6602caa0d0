"""Sensitivities in blocks of parameters equal the all-at-once ones, bit for bit (issue 21).

A 560,000-sample log integrated all 24 perturbed trajectories of the fit check's floor at
once; :meth:`ForwardModel.sensitivities` now integrates them in blocks within
``SENSITIVITY_BLOCK_BYTES``, and the gyro-only floor perturbs only Cl0, Clp and p0.
Each trajectory is integrated on its own either way, so the numbers must not change.
"""

from __future__ import annotations

import numpy as np

import aeroid.model._forward as forward
from aeroid.flights import flight_record, model_constants
from aeroid.model import ForwardModel, nominal


def _model(flight):
    return ForwardModel(model_constants(flight), flight_record(flight, "hold"),
                        flight.airframe.accel_positions, substeps=2)


def test_one_parameter_per_block_gives_the_same_numbers(paper_flight, monkeypatch):
    model = _model(paper_flight)
    x0, theta = paper_flight.states()[0], nominal()
    whole = model.sensitivities(x0, theta, free_states=("p", "q", "r"))
    monkeypatch.setattr(forward, "SENSITIVITY_BLOCK_BYTES", 1)  # every block one parameter
    blocks = model.sensitivities(x0, theta, free_states=("p", "q", "r"))
    assert whole.shape == (paper_flight.n_samples, len(model.output_names), 12)
    np.testing.assert_array_equal(blocks, whole)


def test_a_subset_of_coefficients_is_those_columns(paper_flight):
    model = _model(paper_flight)
    x0, theta = paper_flight.states()[0], nominal()
    whole = model.sensitivities(x0, theta, free_states=("p",))
    part = model.sensitivities(x0, theta, free_states=("p",), coefficients=[5, 4])
    np.testing.assert_array_equal(part, whole[:, :, [5, 4, 9]])
    # and the columns are derivatives: Clp's against a wider central difference
    step = 1e-3 * abs(theta[5])
    up, down = theta.copy(), theta.copy()
    up[5] += step
    down[5] -= step
    wide = (model.outputs(x0, up)[0] - model.outputs(x0, down)[0]) / (2 * step)
    scale = np.max(np.abs(wide), axis=0)
    assert np.all(np.abs(part[:, :, 0] - wide) <= 1e-4 * scale + 1e-12)
