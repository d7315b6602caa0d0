"""Output-error's steady wind over several windows: one wind per window (issue 26).

References: two noise-free flights flown by the simulator in different steady winds (the
truth of each window's wind), and the single flight's fit (one window given as Windows is
the same problem).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import aeroid
from aeroid.errors import EstimatorError
from aeroid.flights import NoNoise, Wind, Windows, make_noise, simulate

#: Two windows, two winds [m/s] (north, east, down): along and across the path.
WINDS = ((3.0, 4.0, 0.0), (-2.0, 1.5, 0.5))
#: Noise-free recovery: the Gauss-Newton tolerance (tests/unit/test_windows.py
#: RECOVERY_RTOL for the coefficients); the winds to 1e-3 m/s.
RECOVERY_RTOL = 1e-4
WIND_ATOL_MPS = 1e-3
#: One window as Windows is the single flight's problem, but the along-path wind trades
#: with every coefficient (correlations 0.99+): the two fits stop at the Gauss-Newton
#: tolerance at different points along that ridge (measured: 1e-6 relative, 1e-4 of a
#: standard error). Compared in standard errors, and the standard errors relatively.
SAME_SE = 1e-3
SAME_RTOL = 1e-3


def _windy(scenario, wind, noise, rng):
    manoeuvre = dataclasses.replace(scenario.manoeuvre, wind=Wind(steady_ned_mps=wind))
    return simulate(scenario.airframe, scenario.coefficient_vector, manoeuvre, noise, rng=rng)


@pytest.fixture(scope="module")
def two_winds(reference_scenario):
    return Windows.of([_windy(reference_scenario, w, NoNoise(), 0) for w in WINDS])


def test_each_window_gets_its_own_wind(two_winds, reference_scenario):
    est = aeroid.make_estimator("output-error", {"estimate_wind": True})
    result = est.fit(two_winds, rng=0)
    assert result.success, result.message
    np.testing.assert_allclose(result.theta, reference_scenario.coefficient_vector,
                               rtol=RECOVERY_RTOL)
    for name, wind in zip(two_winds.names, WINDS, strict=True):
        got = result.info["window_wind"][name]["wind_ned_mps"]
        np.testing.assert_allclose(got, wind, atol=WIND_ATOL_MPS, err_msg=name)
        assert result.info["window_parameters"][name]["wind_n"] == got[0]
    notices = [w for w in result.warnings if "estimate_wind:" in w]
    assert [n.split(":")[0] for n in notices] == ["window w1", "window w2"]


def test_one_window_with_the_wind_is_the_single_flight_fit(reference_scenario):
    flight = _windy(reference_scenario, WINDS[0], make_noise("gaussian"), 3)
    est = aeroid.make_estimator("output-error", {"estimate_wind": True})
    one = est.fit(flight, rng=0)
    win = est.fit(Windows.of([flight]), rng=0)
    assert np.all(np.abs(win.theta - one.theta) < SAME_SE * one.stderr)
    np.testing.assert_allclose(win.stderr, one.stderr, rtol=SAME_RTOL)
    wind = win.info["window_wind"]["w1"]
    assert np.all(np.abs(np.subtract(wind["wind_ned_mps"], one.info["wind_ned_mps"]))
                  < SAME_SE * np.array(one.info["wind_stderr_mps"]))


def test_still_air_windows_fit_of_two_winds_is_refused(two_winds):
    """The verdict on a known-wrong model over windows: the winds fitted as still air (the
    default, auto, estimates them: the windows' metadata declare their winds)."""
    still = aeroid.make_estimator("output-error", {"estimate_wind": False})
    assert not still.fit(two_winds, rng=0).success


def test_wind_with_tables_over_windows_is_refused_in_one_line(two_winds):
    from aeroid.model import TableSpec

    tabled = Windows(tuple(dataclasses.replace(f, airframe=f.airframe.replace(
        tables=TableSpec((("Cx", 3),)))) for f in two_winds), two_winds.names)
    with pytest.raises(EstimatorError, match="estimate_wind with coefficient tables"):
        aeroid.make_estimator("output-error", {"estimate_wind": True}).fit(tabled, rng=0)
