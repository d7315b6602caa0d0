"""Study metrics on synthetic fit records whose answers are worked out by hand."""

import math

import numpy as np
import pandas as pd
import pytest

from aeroid.model import NAMES
from aeroid.study import _metrics as metrics

# Sums and means of a few O(1) decimals: float64 rounding only.
EXACT_TOL = 1e-12

TRUTH = np.arange(1.0, 10.0) * np.array([1, -1, 1, -1, 1, -1, 1, -1, 1])  # 1, -2, 3, ...


def _record(run, offsets, stderr, success=True, estimator="A", noise="n1"):
    """A fit whose estimate is truth + offset * |truth| (offset in units of |truth|)."""
    theta = None if offsets is None else TRUTH + np.asarray(offsets) * np.abs(TRUTH)
    return {"run": run, "noise": noise, "estimator": estimator, "method": "m",
            "truth": TRUTH.tolist(), "theta": None if theta is None else theta.tolist(),
            "stderr": None if stderr is None else (np.asarray(stderr) * np.abs(TRUTH)).tolist(),
            "success": success, "message": "" if success else "diverged", "cost": 1.0,
            "n_evaluations": 10 * (run + 1), "n_iterations": 1, "wall_time_s": float(run + 1)}


@pytest.fixture(scope="module")
def records():
    # relative offsets -0.1, +0.1, +0.3 (in units of |truth|); stderr 0.05, 0.2, 0.1
    ones = np.ones(len(NAMES))
    return [
        _record(0, -0.1 * ones, 0.05 * ones),   # |e| = 0.1 > 1.96*0.05 = 0.098: not covered
        _record(1, 0.1 * ones, 0.2 * ones),     # 0.1 <= 0.392: covered
        _record(2, 0.3 * ones, 0.1 * ones),     # 0.3 > 0.196: not covered
        _record(3, None, None, success=False),  # failed: out of accuracy and coverage
        _record(4, 0.0 * ones, None),           # no stderr: in accuracy, out of coverage
    ]


def test_tidy_has_one_row_per_fit_and_coefficient(records):
    frame = metrics.tidy(records)
    assert list(frame.columns) == metrics.TIDY_COLUMNS
    assert len(frame) == 5 * len(NAMES)
    run2 = frame[frame["run"] == 2]
    assert list(run2["coefficient"]) == list(NAMES)
    np.testing.assert_allclose(run2["error"], 0.3 * np.abs(TRUTH), rtol=0, atol=EXACT_TOL)
    np.testing.assert_allclose(run2["rel_error_pct"], 30.0, rtol=0, atol=1e-9)
    covered = frame.groupby("run")["covered"].first()
    assert [bool(covered[k]) for k in (0, 1, 2)] == [False, True, False]
    assert pd.isna(covered[3]) and pd.isna(covered[4])



def test_a_held_coefficient_is_not_counted_as_covered():
    """A held coefficient has sd 0 (error 0 at the truth): no interval, no coverage
    (it counted 0 <= 0 as covered)."""
    stderr = 0.2 * np.ones(len(NAMES))
    stderr[3] = 0.0
    offsets = 0.1 * np.ones(len(NAMES))
    offsets[3] = 0.0
    frame = metrics.tidy([_record(0, offsets, stderr)])
    assert pd.isna(frame["covered"].iloc[3]) and frame["covered"].drop(index=3).all()
    summary = metrics.summarize(frame)
    held = summary[summary["coefficient"] == NAMES[3]].iloc[0]
    assert held["n_stderr"] == 0 and np.isnan(held["coverage"])


def test_summary_matches_hand_computation(records):
    summary = metrics.summarize(metrics.tidy(records))
    assert len(summary) == len(NAMES)
    # successful offsets (in |truth| units): -0.1, 0.1, 0.3, 0.0
    offsets = np.array([-0.1, 0.1, 0.3, 0.0])
    for _, row in summary.iterrows():
        scale = abs(row["truth"])
        assert row["n_runs"] == 5 and row["n_success"] == 4
        assert row["success_rate"] == pytest.approx(0.8, abs=EXACT_TOL)
        assert row["bias"] == pytest.approx(0.075 * scale, abs=EXACT_TOL * scale)
        assert row["bias_pct"] == pytest.approx(7.5, abs=1e-9)
        sd = math.sqrt(sum((o - 0.075) ** 2 for o in offsets) / 3) * scale
        assert row["sd"] == pytest.approx(sd, abs=EXACT_TOL * scale)
        assert row["sd_pct"] == pytest.approx(sd / scale * 100, abs=1e-9)
        assert row["mean_abs_error_pct"] == pytest.approx(12.5, abs=1e-9)   # (10+10+30+0)/4
        assert row["rmse"] == pytest.approx(math.sqrt(0.11 / 4) * scale, abs=EXACT_TOL * scale)
        assert row["n_stderr"] == 3
        assert row["coverage"] == pytest.approx(1 / 3, abs=EXACT_TOL)
        assert row["median_wall_time_s"] == pytest.approx(3.0)   # median of 1..5 (all fits)
        assert row["median_evaluations"] == pytest.approx(30.0)
        assert math.isnan(row["cr_sd"])


def test_cramer_rao_columns(records):
    floor = 0.01 * np.abs(TRUTH)  # 1 % of the truth
    summary = metrics.summarize(metrics.tidy(records), {"n1": floor})
    np.testing.assert_allclose(summary["cr_sd_pct"], 1.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(summary["sd_over_cr"], summary["sd"] / floor, rtol=0, atol=0)


def test_groups_are_kept_apart_and_overall_averages_coefficients():
    ones = np.ones(len(NAMES))
    recs = [_record(0, 0.1 * ones, None, estimator="A"),
            _record(0, -0.2 * ones, None, estimator="B"),
            _record(0, 0.4 * ones, None, estimator="A", noise="n2")]
    summary = metrics.summarize(metrics.tidy(recs))
    assert list(dict.fromkeys(zip(summary["noise"], summary["estimator"], strict=True))) == [
        ("n1", "A"), ("n1", "B"), ("n2", "A")]
    over = metrics.overall(summary)
    np.testing.assert_allclose(over["mean_abs_error_pct"], [10.0, 20.0, 40.0], atol=1e-9)
    assert over["coverage"].isna().all()  # no standard errors anywhere
    assert summary["sd"].isna().all()     # one fit per group: no spread


def test_all_failed_group_gives_nan_accuracy():
    summary = metrics.summarize(metrics.tidy([_record(0, None, None, success=False)]))
    assert (summary["success_rate"] == 0).all()
    assert summary[["bias", "mean_abs_error_pct", "rmse", "coverage"]].isna().all().all()


def test_a_zero_truth_has_no_relative_measures():
    # a passive fin's Czd, Cmd are 0 in the truth and held at 0 (issue 25): the absolute
    # figures stand, the relative ones are NaN (not a ZeroDivisionError in the report)
    truth = TRUTH.copy()
    truth[NAMES.index("Czd")] = 0.0
    recs = []
    for run, offset in enumerate((0.1, -0.3)):
        rec = _record(run, offset * np.ones(len(NAMES)), 0.1 * np.ones(len(NAMES)))
        theta = np.array(rec["theta"])
        theta[NAMES.index("Czd")] = offset  # an error of `offset` on a zero truth
        recs.append({**rec, "truth": truth.tolist(), "theta": theta.tolist()})
    summary = metrics.summarize(metrics.tidy(recs)).set_index("coefficient")
    czd = summary.loc["Czd"]
    assert czd["bias"] == pytest.approx(-0.1, abs=EXACT_TOL)
    assert czd["rmse"] == pytest.approx(math.sqrt((0.1**2 + 0.3**2) / 2), abs=EXACT_TOL)
    for column in ("bias_pct", "sd_pct", "rmse_pct"):
        assert math.isnan(czd[column]), column
    assert summary.loc["Cx", "rmse_pct"] == pytest.approx(math.sqrt(0.05) * 100, rel=1e-9)
