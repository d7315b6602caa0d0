"""The Fisher information written once, summed block by block in time (issues 20, 21).

The blocked sum must equal the sum over the whole sensitivity matrix: the sensitivities
are the same numbers (tests/unit/test_sensitivity_blocks.py), so only the order of the
additions differs. Every floor that calls it (the fit check's, the gyro-only one, the
output-error one) is compared with itself computed in one block.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import aeroid.model._sensitivity as sensitivity
from aeroid.errors import AeroidWarning
from aeroid.estimation import cramer_rao_sd, data_floor, gyro_only_floor
from aeroid.estimation._information import (
    coefficient_information,
    fisher_information,
    information_from_sensitivities,
)
from aeroid.flights import PaperNoise, flight_record, model_constants
from aeroid.model import ForwardModel, Record, nominal

#: Blocked vs one-pass information, each entry relative to sqrt(F_ii F_jj): the sums
#: differ only in the order of additions (measured 3e-16 of the largest entry).
INFORMATION_RTOL = 1e-12
#: Blocked vs one-pass floors (relative): the information of the nine coefficients and
#: three initial rates has a condition number of ~3e14 on the reference flight, so the
#: rounding of the sums above moves its inverse: measured 1.8e-10 on one build of the
#: kernels and 2.0e-9 after the RK4 substep became one compiled function (the sensitivities'
#: last bits moved, so the amplified rounding did too). The bound is set 50x above the
#: larger figure: it depends on last-bit rounding, which differs between CPUs and kernels.
FLOOR_RTOL = 1e-7
RATES = ("p", "q", "r")


def _model(flight, substeps=1):
    return ForwardModel(model_constants(flight), flight_record(flight, "hold"),
                        flight.airframe.accel_positions, substeps=substeps)


def _sd(flight):
    """A per-sample, per-channel sd that is not constant (eq. 43 of the noisy outputs)."""
    model = _model(flight)
    return np.abs(model.outputs(flight.states()[0], nominal())[0]) * 0.01 + 1e-3


def _scaled_error(a, b):
    scale = np.sqrt(np.outer(np.diag(b), np.diag(b)))
    return float(np.max(np.abs(a - b) / scale))


@pytest.mark.parametrize("block", [2, 37, 250])
def test_blocked_information_equals_the_whole_sum(paper_flight, block):
    model, x0, theta = _model(paper_flight), paper_flight.states()[0], nominal()
    sd = _sd(paper_flight)
    whole = information_from_sensitivities(model.sensitivities(x0, theta, free_states=RATES),
                                           sd)
    blocked = fisher_information(model, x0, theta, sd, free_states=RATES,
                                 block_samples=block)
    assert _scaled_error(blocked, whole) < INFORMATION_RTOL
    floor = np.sqrt(np.diag(np.linalg.inv(coefficient_information(whole))))
    floor_blocked = np.sqrt(np.diag(np.linalg.inv(coefficient_information(blocked))))
    np.testing.assert_allclose(floor_blocked, floor, rtol=FLOOR_RTOL)


def test_samples_with_zero_sd_are_left_out(paper_flight):
    # an identity with a second record: zeros after sample 200 give the information of
    # the first 201 samples alone
    model, x0, theta = _model(paper_flight), paper_flight.states()[0], nominal()
    sd = _sd(paper_flight)
    cut = sd.copy()
    cut[201:] = 0.0
    record = model.record
    short = ForwardModel(model.const, Record(record.dt, record.delta[:201],
                                             type(record.pieces)(*(a[:200] for a in
                                                                  record.pieces))),
                         model.positions, substeps=model.substeps)
    expected = fisher_information(short, x0, theta, sd[:201], free_states=RATES)
    blocked = fisher_information(model, x0, theta, cut, free_states=RATES, block_samples=37)
    assert _scaled_error(blocked, expected) < INFORMATION_RTOL


def test_channels_and_per_channel_sd(paper_flight):
    # the p channel alone with sd 2 is a quarter of the p channel's information with sd 1
    model, x0, theta = _model(paper_flight), paper_flight.states()[0], nominal()
    p = model.output_names.index("p")
    one = fisher_information(model, x0, theta, 1.0, channels=[p], block_samples=100)
    two = fisher_information(model, x0, theta, 2.0, channels=[p])
    np.testing.assert_allclose(two, one / 4, rtol=1e-12, atol=0)
    jac = model.sensitivities(x0, theta)[:, p]
    np.testing.assert_allclose(one, jac.T @ jac, rtol=1e-10, atol=1e-12 * np.max(one))


def test_a_diverging_model_gives_nan(paper_flight):
    model, x0 = _model(paper_flight), paper_flight.states()[0]
    theta = nominal() * 1e6  # the trajectory leaves the float range
    with np.errstate(all="ignore"):
        info = fisher_information(model, x0, theta, 1.0, block_samples=50)
    assert info.shape == (len(theta), len(theta)) and np.all(np.isnan(info))


@pytest.mark.parametrize(("kw", "message"), [
    ({"noise_sd": -1.0}, "noise standard deviations must be finite and >= 0"),
    ({"noise_sd": np.nan}, "noise standard deviations must be finite and >= 0"),
    ({"noise_sd": np.ones(7)}, r"noise sd of shape \(7,\) does not fit 501 samples x 9"),
    ({"noise_sd": 1.0, "channels": [9]}, "channels must index the model's 9 outputs"),
    ({"noise_sd": 1.0, "block_samples": 1}, "block_samples must be >= 2, got 1"),
])
def test_bad_input_is_one_line(paper_flight, kw, message):
    model = _model(paper_flight)
    with pytest.raises(ValueError, match=message) as info:
        fisher_information(model, paper_flight.states()[0], nominal(), **kw)
    assert "\n" not in str(info.value)


def _floors(paper_flight, reference_scenario):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AeroidWarning)
        return (data_floor(paper_flight, nominal()), gyro_only_floor(paper_flight, nominal()),
                cramer_rao_sd(reference_scenario, PaperNoise()).to_numpy())


def test_every_floor_is_the_same_in_blocks(paper_flight, reference_scenario, monkeypatch):
    one_block = _floors(paper_flight, reference_scenario)
    monkeypatch.setattr(sensitivity, "SENSITIVITY_BLOCK_BYTES", 200_000)  # 5-30 blocks
    blocks = list(_model(paper_flight).sensitivity_blocks(
        paper_flight.states()[0], nominal(), free_states=RATES))
    assert len(blocks) > 5
    blocked = _floors(paper_flight, reference_scenario)
    for a, b in zip(blocked, one_block, strict=True):
        assert np.all(np.isfinite(b))
        np.testing.assert_allclose(a, b, rtol=FLOOR_RTOL)
