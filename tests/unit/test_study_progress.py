"""The study's remaining-time estimate stays put when fits of very different cost mix."""

import numpy as np
import pytest
from tqdm.std import EMA

from aeroid.study._progress import Progress, RemainingTime, format_seconds

#: A paper_table5-like run: one EAM-PSO fit of ~10 s and seven fits of ~0.1 s.
COSTS = {"EAM-PSO": 10.0, **{f"M{k}": 0.1 for k in range(7)}}
RUNS = 20
#: After the first run every estimator has been timed: the estimate must then be within
#: this factor of the truth (it is exact up to the jitter of the fit times).
AFTER_FIRST_RUN_TOL = 0.25


def _schedule(rng):
    """Serial, run-major fits with +-20 % jitter: (label, cost) in completion order."""
    return [(label, cost * rng.uniform(0.8, 1.2)) for _ in range(RUNS)
            for label, cost in COSTS.items()]


def test_estimate_is_stable_where_a_rate_average_swings():
    fits = _schedule(np.random.default_rng(1))
    ours = RemainingTime([label for label, _ in fits], start=0.0)
    ema_dn, ema_dt = EMA(0.3), EMA(0.3)  # tqdm's default: rate = EMA(items) / EMA(time)
    now, ratios, naive = 0.0, [], []
    for k, (label, cost) in enumerate(fits):
        now += cost
        ours.done(label, cost)
        truth = sum(c for _, c in fits[k + 1:])
        ema_dn(1)
        ema_dt(cost)
        if k >= len(COSTS) and truth > 0:  # after the first run
            ratios.append(ours.seconds(now) / truth)
            naive.append((len(fits) - k - 1) * ema_dt() / ema_dn() / truth)
    assert max(abs(np.array(ratios) - 1)) < AFTER_FIRST_RUN_TOL
    # what the old bar showed swung by more than an order of magnitude on this schedule
    assert max(naive) / min(naive) > 20


def test_estimate_uses_the_parallelism_achieved():
    # two workers: 4 fits of 10 s each done after 20 s of wall time; 4 left
    rt = RemainingTime(["A"] * 8, start=0.0)
    for _ in range(4):
        rt.done("A", 10.0)
    assert rt.seconds(20.0) == pytest.approx(20.0)


def test_unseen_estimators_count_at_the_mean_of_the_seen_ones():
    rt = RemainingTime(["A", "A", "B"], start=0.0)
    assert rt.seconds(1.0) is None  # nothing timed yet
    rt.done("A", 2.0)
    assert rt.seconds(2.0) == pytest.approx(4.0)  # one A (2 s) and one B (mean 2 s)
    rt.done("B", None)  # a fit without a time (a failure) counts as done, not as timed
    assert rt.seconds(2.0) == pytest.approx(2.0)


@pytest.mark.parametrize(("seconds", "text"), [(None, "?"), (0.4, "0:00"), (61, "1:01"),
                                               (3725, "1:02:05")])
def test_format_seconds(seconds, text):
    assert format_seconds(seconds) == text


def test_progress_bar_shows_the_estimate_and_failures(capsys):
    bar = Progress(3, 1, ["A", "A"], "demo", enabled=True)
    bar.update({"estimator": "A", "wall_time_s": 1.0, "success": False})
    text = str(bar.bar)
    bar.close()
    assert "2/3" in text and "left, 1 failed" in text
