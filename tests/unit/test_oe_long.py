"""Output-error on a long record: the record evaluated in pieces (baselines/_oe_record.py).

A record longer than ``piece_samples`` is integrated piece by piece, each piece's graph
started from the state and sensitivity the previous one ended with. Reference: the same
record's whole graph (one piece): the same operations in the same order, so the outputs,
the Jacobian and the fit are equal bit for bit (measured: 0.0 difference), compared here
to rounding.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest

import baselines.output_error as oe
from aeroid.flights import GaussianNoise, reference_scenario, simulate
from baselines._oe_record import DELAY_STEP_S, RecordModel
from baselines.output_error import OutputErrorEstimator

#: The pieces against the whole graph: the same floating-point operations (measured
#: difference 0.0); a margin of a few roundings of the largest entry.
PIECES_RTOL = 1e-13
#: A short piece, so that the reference flight's 501 samples make several pieces.
SHORT_PIECE = 128


def _flight(n_samples: int, seed: int = 5):
    s = reference_scenario()
    window = (5.0, 5.0 + (n_samples - 1) * s.manoeuvre.dt)
    manoeuvre = dataclasses.replace(s.manoeuvre, window_s=window)
    return simulate(s.airframe, s.coefficient_vector, manoeuvre, GaussianNoise(), rng=seed)


def _models(flight, piece: int, **options):
    """The record model of ``flight`` in pieces of ``piece`` samples and whole."""
    est = OutputErrorEstimator(compile_model=False, **options)
    whole = est.problem(flight).model
    assert not whole.chained
    kwargs = {"input": est.input, "substeps": whole.substeps, "x0_free": whole.x0_free,
              "position_free": whole.position_free, "compiled": False, "x0": whole.x0,
              "scale": whole.scale, "delay_s": whole.delay_s,
              "estimate_delay": whole.estimate_delay, "imu_errors": whole.imu_errors}
    pieces = RecordModel(flight, piece_samples=piece, **kwargs)
    assert pieces.chained
    return pieces, whole


def _point(model, seed: int = 0) -> np.ndarray:
    """Parameters off the prior (coefficients 5 %, the other offsets 0.01)."""
    rng = np.random.default_rng(seed)
    p = 0.01 * rng.standard_normal(model.scale.size)
    p[:9] = 1.0 + 0.05 * rng.standard_normal(9)
    if model.estimate_delay:
        p[model.n_graph] = 0.3  # a delay inside a sample interval
    return p


@pytest.mark.parametrize("n_samples", [1 + 3 * (SHORT_PIECE - 1), 2 + 3 * (SHORT_PIECE - 1),
                                       SHORT_PIECE + 1])
def test_pieces_equal_the_whole_record(n_samples):
    # a record that ends exactly on a piece, one sample past it, and two pieces
    flight = _flight(n_samples)
    pieces, whole = _models(flight, SHORT_PIECE)
    p = _point(whole)
    y_p, J_p = pieces.outputs_jacobian(p)
    y_w, J_w = whole.outputs_jacobian(p)
    assert y_p.shape == y_w.shape == (n_samples, 9)
    assert J_p.shape == J_w.shape
    np.testing.assert_allclose(y_p, y_w, rtol=0, atol=PIECES_RTOL * np.max(np.abs(y_w)))
    np.testing.assert_allclose(J_p, J_w, rtol=0, atol=PIECES_RTOL * np.max(np.abs(J_w)))
    np.testing.assert_allclose(pieces.outputs(p), y_w, rtol=0,
                               atol=PIECES_RTOL * np.max(np.abs(y_w)))


def test_pieces_equal_the_whole_record_with_delay_and_imu_errors():
    # the delay's column is a difference of records evaluated with another schedule
    flight = _flight(300)
    pieces, whole = _models(flight, 100, estimate_delay=True, imu_errors="bias+scale",
                            estimate_initial_velocity=True)
    p = _point(whole, seed=1)
    y_p, J_p = pieces.outputs_jacobian(p)
    y_w, J_w = whole.outputs_jacobian(p)
    np.testing.assert_allclose(y_p, y_w, rtol=0, atol=PIECES_RTOL * np.max(np.abs(y_w)))
    for c in range(J_w.shape[2]):
        atol = PIECES_RTOL * np.max(np.abs(J_w[:, :, c]))
        if c == whole.n_graph:  # the delay's: a difference quotient of the outputs
            atol = PIECES_RTOL * np.max(np.abs(y_w)) * whole.delay_scale / DELAY_STEP_S
        np.testing.assert_allclose(J_p[:, :, c], J_w[:, :, c], rtol=0, atol=atol)


def test_fit_of_reference_flight_in_pieces_equals_the_whole_fit(paper_flight, monkeypatch):
    est = OutputErrorEstimator(compile_model=False)
    whole = est.fit(paper_flight, rng=0)
    monkeypatch.setattr(oe, "RecordModel",
                        functools.partial(RecordModel, piece_samples=SHORT_PIECE))
    pieces = est.fit(paper_flight, rng=0)
    assert whole.success and pieces.success
    assert pieces.n_iterations == whole.n_iterations
    np.testing.assert_allclose(pieces.theta, whole.theta, rtol=PIECES_RTOL)
    np.testing.assert_allclose(pieces.stderr, whole.stderr, rtol=PIECES_RTOL)
    assert pieces.cost == pytest.approx(whole.cost, rel=PIECES_RTOL)


def test_piece_of_fewer_than_two_samples_is_refused():
    flight = _flight(20)
    whole = OutputErrorEstimator(compile_model=False).problem(flight).model
    with pytest.raises(ValueError, match="piece_samples must be >= 2"):
        RecordModel(flight, input="hold", substeps=2, x0_free=whole.x0_free,
                    position_free=whole.position_free, compiled=False, x0=whole.x0,
                    scale=whole.scale, delay_s=0.0, estimate_delay=False, piece_samples=1)
