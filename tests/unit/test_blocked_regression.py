"""Equation-error on time blocks: the regressors a block at a time equal the one-shot ones."""

from __future__ import annotations

import numpy as np
import pytest

import baselines.equation_error as ee
from aeroid import estimation as rc
from aeroid.estimation._fitcheck import data_noise_levels, data_noise_sd
from aeroid.model import FM_NAMES, OUTPUT_CHANNELS
from baselines.equation_error import EquationErrorEstimator, solve_subproblems

#: The blocked path copies the same numbers into the same layout: measured bit-identical
#: (0.0) on the reference flights; 1e-12 relative is the brief's bar, kept as the bound.
BLOCKED_RTOL = 1e-12
#: Forces several blocks on the reference flight (501 samples), one shorter than the
#: SG window's half-width at the end included.
SMALL_BLOCK = 62


def _leaves(value, prefix=""):
    """Numeric leaves of nested dicts, ``{path: float array}``."""
    if isinstance(value, dict):
        out = {}
        for key, item in value.items():
            out.update(_leaves(item, f"{prefix}.{key}"))
        return out
    try:
        return {prefix: np.asarray(value, dtype=float)}
    except (TypeError, ValueError):
        return {}


@pytest.mark.parametrize("smoothing", ["none", "both", "forces"])
@pytest.mark.parametrize("block", [SMALL_BLOCK, 3, 10**9])
def test_blocks_concatenate_to_the_one_shot_regressors(clean_flight, smoothing, block):
    rec = rc.reconstruct(clean_flight)
    X, y = rc.ebm_regression(clean_flight, rec, smoothing=smoothing)
    parts = list(rc.regressor_blocks(clean_flight, smoothing=smoothing, block=block))
    assert parts[0][0] == 0 and parts[-1][1] == clean_flight.n_samples
    assert all(a[1] == b[0] for a, b in zip(parts, parts[1:], strict=False))
    np.testing.assert_array_equal(np.concatenate([p for _, _, p in parts]), X)
    np.testing.assert_array_equal(rc.regression_target(rec, smoothing=smoothing), y)


def test_blocked_smoothing_keeps_the_one_shot_ends(clean_flight):
    """A block at each end shorter than the window: the SG end fit still sees the first
    and last window of the log, not of the block (a wrong end fit changes X there)."""
    rec = rc.reconstruct(clean_flight)
    X, _ = rc.ebm_regression(clean_flight, rec, smoothing="both")
    n = clean_flight.n_samples
    last = list(rc.regressor_blocks(clean_flight, smoothing="both", block=n - 2))
    np.testing.assert_array_equal(last[-1][2], X[-2:])
    np.testing.assert_array_equal(last[0][2], X[:-2])


def test_bad_block_is_refused(clean_flight):
    with pytest.raises(ValueError, match="block"):
        next(rc.regressor_blocks(clean_flight, block=0))


@pytest.mark.parametrize("options", [{}, {"smoothing": "both"}, {"lateral_rows": True},
                                     {"covariance": "ols"}])
@pytest.mark.parametrize("which", ["paper_flight", "clean_flight"])
def test_blocked_fit_equals_one_block(request, monkeypatch, which, options):
    """Estimate, standard errors, covariance, cost and the fit check: several blocks
    against one block holding the whole log."""
    flight = request.getfixturevalue(which)
    results = []
    for block in (SMALL_BLOCK, flight.n_samples):
        monkeypatch.setattr(ee, "BLOCK_SAMPLES", block)
        results.append(EquationErrorEstimator(**options).fit(flight, rng=0))
    blocked, whole = results
    assert flight.n_samples > 4 * SMALL_BLOCK
    for name in ("theta", "stderr", "covariance", "cost"):
        np.testing.assert_allclose(getattr(blocked, name), getattr(whole, name),
                                   rtol=BLOCKED_RTOL, atol=0, err_msg=name)
    check_b, check_w = _leaves(blocked.info["fit_check"]), _leaves(whole.info["fit_check"])
    assert check_b.keys() == check_w.keys() and len(check_b) > 4
    for key, value in check_w.items():
        np.testing.assert_allclose(check_b[key], value, rtol=BLOCKED_RTOL, atol=0,
                                   err_msg=key)
    assert blocked.warnings == whole.warnings


@pytest.mark.parametrize("smoothing", ["none", "both"])
def test_blocked_subproblems_equal_the_one_shot_array(paper_flight, smoothing):
    """solve_subproblems on the (n, 6, 9) array (the one-shot path) and on its blocks;
    regression_fit's residuals y - X theta likewise."""
    rec = rc.reconstruct(paper_flight)
    X, y = rc.ebm_regression(paper_flight, rec, smoothing=smoothing)
    sd = rc.estimate_noise_sd(rec.fm)
    whole = solve_subproblems(X, y, sd, lateral_rows=True)
    blocked = solve_subproblems(
        rc.regressor_blocks(paper_flight, smoothing=smoothing, block=SMALL_BLOCK), y, sd,
        lateral_rows=True)
    for a, b in zip(whole[:3], blocked[:3], strict=True):
        np.testing.assert_allclose(b, a, rtol=BLOCKED_RTOL, atol=0)
    rows = (0, 2, 3, 4)
    fit_whole = rc.regression_fit(rec, X, y, whole[0], rows)["fit_residuals"]
    fit_blocked = rc.regression_fit(
        rec, rc.regressor_blocks(paper_flight, smoothing=smoothing, block=SMALL_BLOCK), y,
        whole[0], rows)["fit_residuals"]
    for name, e in fit_whole.items():
        # independent: the residual straight from the array
        row = FM_NAMES.index(name)
        np.testing.assert_allclose(e, y[:, row] - X[:, row] @ whole[0], rtol=0,
                                   atol=1e-12 * np.abs(y[:, row]).max())
        np.testing.assert_allclose(fit_blocked[name], e, rtol=0,
                                   atol=BLOCKED_RTOL * np.abs(y[:, row]).max())


@pytest.mark.parametrize("which", ["paper_flight", "clean_flight"])
def test_noise_levels_by_groups_equal_all_channels_at_once(request, which):
    """data_noise_levels takes the channels a few at a time; every count of channels
    gives the levels of one pass over all of them (data_noise_sd on the whole table)."""
    flight = request.getfixturevalue(which)
    names = tuple(OUTPUT_CHANNELS)
    for k in range(1, len(names) + 1):
        levels = data_noise_levels(flight, names[:k])
        assert tuple(levels) == names[:k]
        whole = np.atleast_1d(data_noise_sd(flight, flight._columns(names[:k])))
        np.testing.assert_allclose(list(levels.values()), whole, rtol=BLOCKED_RTOL, atol=0)
