"""Repeated warnings inside a filter pass become one (issue 21: 4006 lines of one warning)."""

from __future__ import annotations

import warnings

from baselines._kalman import collapsed_warnings


def test_a_warning_repeated_at_one_place_is_issued_once_with_its_count():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with collapsed_warnings():
            for k in range(100):
                warnings.warn(f"ill-conditioned, rcond = {k}e-300", RuntimeWarning,
                              stacklevel=1)
            warnings.warn("another place", UserWarning, stacklevel=1)
    messages = [str(w.message) for w in caught]
    assert messages == ["ill-conditioned, rcond = 0e-300 (and 99 more like it in this "
                        "filter pass)", "another place"]
    assert [w.category for w in caught] == [RuntimeWarning, UserWarning]


def test_no_warning_no_output():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with collapsed_warnings():
            pass
