"""Coefficient tables over several windows (issue 23): shared table points, each
window's own nuisances (output-error: initial rates; equation-error: its reconstruction).

References: the windows fit of one window is the single-flight table fit (the same
problem stacked once); a noise-free coast cut into windows with gaps between them is
recovered to the single-flight tolerances (tests/unit/test_tables_fits.py), each table
point informed by one window or another.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from table_truths import MACH_SWEEP, SWEEP_WINDOW_S, table_truth

import aeroid
from aeroid.errors import EstimatorError
from aeroid.flights import (
    NoNoise,
    Windows,
    cut_windows,
    record_flight,
)
from aeroid.model import TableSpec

#: The truth's knots within the sweep's first 6 s (Mach 2.19 -> 1.68).
KNOTS = (1.65, 1.925, 2.2)
#: One window stacked once is the same problem: equation-error's least squares to
#: rounding; output-error's Gauss-Newton from the same starts to rounding of its steps.
EE_IDENTITY_RTOL = 1e-10
OE_IDENTITY_RTOL = 1e-8
#: Noise-free recovery (tests/unit/test_tables_fits.py): equation-error's axial row is
#: exact to rounding; output-error with the truth's RK4 step to its solver's tolerance.
EE_AXIAL_TOL = 1e-9
OE_TOL = 1e-6
#: The windows of the coast, with a 2 s gap: 0.5-2.5 s spans Mach 2.19-2.0 and 4.5-6.5 s
#: Mach 1.85-1.68; no window holds the knot 1.925, both inform its point.
GAPPED = "0.5-2.5,4.5-6.5"


@pytest.fixture(scope="module")
def sweep():
    scenario, manoeuvre, _, truth = table_truth(MACH_SWEEP, SWEEP_WINDOW_S)
    flight = record_flight(scenario.airframe, scenario.coefficient_vector, manoeuvre, truth,
                           NoNoise(), rng=0, tables=scenario.tables)
    flight = dataclasses.replace(flight, airframe=flight.airframe.replace(
        tables=TableSpec((("Cx", KNOTS), ("Cmq", KNOTS)))))
    values = dict(zip(scenario.tables.parameter_names(), scenario.coefficients, strict=True))
    return flight, values


@pytest.mark.parametrize(("method", "options", "rtol"), [
    ("equation-error", {}, EE_IDENTITY_RTOL),
    ("output-error", {}, OE_IDENTITY_RTOL)])
def test_windows_fit_of_one_window_is_the_single_flight_fit(sweep, method, options, rtol):
    flight, _ = sweep
    est = aeroid.make_estimator(method, options)
    single = est.fit(flight, rng=0)
    stacked = est.fit(Windows.of([flight]), rng=0)
    assert stacked.names == single.names == flight.airframe.mach_tables(
        flight.states()).parameter_names()
    np.testing.assert_allclose(stacked.theta, single.theta, rtol=rtol)
    np.testing.assert_allclose(stacked.stderr, single.stderr, rtol=1e3 * rtol)
    assert stacked.info["tables"] == single.info["tables"]


@pytest.mark.parametrize("method", ["equation-error", "output-error"])
def test_a_coast_cut_into_windows_with_a_gap_recovers_every_table_point(sweep, method):
    flight, truth = sweep
    windows = cut_windows(flight, GAPPED)
    options = {"substeps": 8} if method == "output-error" else {}
    result = aeroid.make_estimator(method, options).fit(windows, rng=0)
    assert result.names == flight.airframe.mach_tables(flight.states()).parameter_names()
    for name, value in zip(result.names, result.theta, strict=True):
        if method == "output-error":
            assert value == pytest.approx(truth[name], rel=OE_TOL), name
        elif name.startswith("Cx"):
            assert value == pytest.approx(truth[name], rel=EE_AXIAL_TOL), name
    if method == "output-error":
        assert result.success, result.message
        own = result.info["window_parameters"]
        assert set(own) == set(windows.names) and all("p0" in v for v in own.values())


def test_counted_knots_span_the_windows_and_a_point_no_window_informs_is_refused(sweep):
    flight, _ = sweep
    windows = cut_windows(flight, GAPPED)
    counted = Windows(tuple(dataclasses.replace(f, airframe=f.airframe.replace(
        tables=TableSpec((("Cx", 3),)))) for f in windows), windows.names)
    result = aeroid.make_estimator("equation-error").fit(counted)
    knots = [float(n.split("@M")[1]) for n in result.names if n.startswith("Cx@")]
    mach = np.concatenate([f.airframe.mach_tables(f.states()).mach(f.states())
                           for f in windows])
    assert mach.min() - 0.01 < knots[0] <= mach.min() and mach.max() <= knots[-1] < \
        mach.max() + 0.01  # over both windows, rounded outward to 0.01
    narrow = Windows(tuple(dataclasses.replace(f, airframe=f.airframe.replace(
        tables=TableSpec((("Cx", (1.1, 1.65, 2.2)),)))) for f in windows), windows.names)
    with pytest.raises(EstimatorError, match=r"no sample of any window informs Cx@M1.1 \("):
        aeroid.make_estimator("output-error").fit(narrow)
    other = Windows((windows.flights[0], dataclasses.replace(
        windows.flights[1], airframe=narrow.flights[1].airframe)), windows.names)
    with pytest.raises(EstimatorError, match=r"window '4.5-6.5' has other \[tables\] than"):
        aeroid.make_estimator("equation-error").fit(other)
    # holds name the windows' shared points (tests/unit/test_tables_alpha_holds.py fits
    # them): a point of no shared knot is one line before any fit
    with pytest.raises(EstimatorError, match=r"Cx@M1.5: no such knot in Cx's table"):
        aeroid.make_estimator("output-error").fit(windows, holds={"hold": {"Cx@M1.5": -0.9}})
