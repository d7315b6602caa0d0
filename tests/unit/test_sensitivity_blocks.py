"""Sensitivities in blocks of time equal the one-pass ones, bit for bit (issue 21).

A 560,000-sample log held the fit check's n x 9 x 12 sensitivity matrix (2.2 kB per
sample). :meth:`ForwardModel.sensitivity_blocks` integrates the perturbed trajectories
once, block by block in time, each block continuing from the previous block's last
state with the same inputs; so the numbers must not change, for a held deflection, a
switch schedule (several pieces per interval) and per-sample exogenous inputs.
"""

from __future__ import annotations

import numpy as np
import pytest

import aeroid.model._sensitivity as sensitivity
from aeroid.flights import flight_record, model_constants
from aeroid.model import ForwardModel, Record, exogenous_table, nominal

#: Block lengths and the blocks they cut the reference flight's 501 samples into: the
#: smallest (the last one widened to 3), uneven, and one that would leave a last block
#: of one sample (501 = 2 x 250 + 1: the second block is widened to 251).
BLOCKS = {2: 250, 37: 14, 250: 2}


def _model(flight, record=None):
    return ForwardModel(model_constants(flight), record or flight_record(flight, "hold"),
                        flight.airframe.accel_positions, substeps=2)


def _blocked(model, x0, theta, size, **kw):
    rows, parts = zip(*model.sensitivity_blocks(x0, theta, block_samples=size, **kw),
                      strict=True)
    starts = [r.start for r in rows]
    assert starts[0] == 0 and rows[-1].stop == model.n_samples
    assert all(a.stop == b.start for a, b in zip(rows, rows[1:], strict=False))
    assert all(r.stop - r.start >= 2 for r in rows)  # a record has two samples or more
    return np.concatenate(parts), len(rows)


@pytest.mark.parametrize(("size", "count"), BLOCKS.items())
def test_time_blocks_give_the_same_numbers(paper_flight, size, count):
    model = _model(paper_flight)
    x0, theta = paper_flight.states()[0], nominal()
    whole = model.sensitivities(x0, theta, free_states=("p", "q", "r"))
    blocks, blocks_made = _blocked(model, x0, theta, size, free_states=("p", "q", "r"))
    assert blocks_made == count
    assert whole.shape == (paper_flight.n_samples, len(model.output_names), 12)
    np.testing.assert_array_equal(blocks, whole)


def test_time_blocks_of_a_switch_schedule_and_exogenous_inputs(paper_flight):
    # pieces within the intervals (a switch at the midpoint) and a density that
    # changes every sample: both are sliced per block
    record = flight_record(paper_flight, "midpoint")
    assert record.n_pieces > 1
    rho = model_constants(paper_flight).rho * np.linspace(1.0, 0.8, record.n_samples)
    exo = exogenous_table(model_constants(paper_flight), record.n_samples, {"rho": rho})
    model = _model(paper_flight, Record(record.dt, record.delta, record.pieces, exo))
    x0, theta = paper_flight.states()[0], nominal()
    whole = model.sensitivities(x0, theta, free_states=("q",))
    blocks, _ = _blocked(model, x0, theta, 37, free_states=("q",))
    np.testing.assert_array_equal(blocks, whole)
    # and the varying density is seen: not the constant-density sensitivities
    constant = _model(paper_flight, record).sensitivities(x0, theta, free_states=("q",))
    assert np.max(np.abs(constant - whole)) > 1e-3 * np.max(np.abs(whole))


def test_the_default_block_follows_the_memory_budget(paper_flight, monkeypatch):
    model = _model(paper_flight)
    x0, theta = paper_flight.states()[0], nominal()
    whole = list(model.sensitivity_blocks(x0, theta, free_states=("p", "q", "r")))
    assert len(whole) == 1  # 501 samples of 24 trajectories: well within 32 MB
    monkeypatch.setattr(sensitivity, "SENSITIVITY_BLOCK_BYTES", 1)  # the smallest blocks
    small = list(model.sensitivity_blocks(x0, theta, free_states=("p", "q", "r")))
    assert len(small) == (model.n_samples - 1) // 2
    np.testing.assert_array_equal(np.concatenate([b for _, b in small]), whole[0][1])


def test_a_block_of_one_sample_is_refused(paper_flight):
    model = _model(paper_flight)
    with pytest.raises(ValueError, match="block_samples must be >= 2, got 1"):
        next(model.sensitivity_blocks(paper_flight.states()[0], nominal(), block_samples=1))


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
