"""A fitted drag beside a reference Cd curve: reading, the sign and area conversion, figure.

References: the conversion by hand (Cd = -Cx S_aeroid / S_ref with the two areas from
their diameters), the Mach number from the ISA temperature at 10 km (223.15 K) and the
simulated speed, and the figure's own plotted data.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from aeroid.errors import UsageError
from aeroid.flights import NoNoise, load_scenario, simulate_scenario
from aeroid.report import (
    cd_from_cx,
    conversion_note,
    flight_mach,
    read_reference_curve,
    reference_curve_figure,
)

D_AEROID, D_REF = 0.127, 0.13
S_AEROID, S_REF = math.pi * D_AEROID**2 / 4, math.pi * D_REF**2 / 4


def _curve(tmp_path, text="Mach,Cd\n0.2,0.45\n0.8,0.48\n1.2,0.62\n2.0,0.55\n"):
    path = tmp_path / "rasaero.csv"
    path.write_text(text)
    return path


def test_conversion_is_sign_and_area_by_hand():
    cd, lo, hi = cd_from_cx(np.array([-0.98]), np.array([-1.02]), np.array([-0.94]),
                            area_m2=S_AEROID, reference_area_m2=S_REF)
    ratio = (D_AEROID / D_REF) ** 2
    assert cd[0] == pytest.approx(0.98 * ratio, rel=1e-14)
    assert (lo[0], hi[0]) == pytest.approx((0.94 * ratio, 1.02 * ratio), rel=1e-14)
    note = conversion_note(S_AEROID, S_REF)
    assert "\n" not in note and note.startswith("Cd = -Cx x S_aeroid / S_ref = -Cx x 0.0126677")


def test_read_curve(tmp_path):
    curve = read_reference_curve(_curve(tmp_path, " mach , CD \n0.2,0.45\n1.0,0.5\n"),
                                 area_m2=S_REF)
    np.testing.assert_array_equal(curve.mach, [0.2, 1.0])
    np.testing.assert_array_equal(curve.cd, [0.45, 0.5])
    assert curve.area_m2 == S_REF and curve.source == "rasaero.csv"


@pytest.mark.parametrize(("text", "area", "message"), [
    ("Mach,Cd\n0.2,0.4\n", 0.0, "the reference area must be a positive number"),
    ("Mach,Cd\n0.2,0.4\n", True, "the reference area must be a positive number"),
    ("Mach,Drag\n0.2,0.4\n", S_REF, "missing: cd; not used: Drag"),
    ("Mach,Cd,Cl\n0.2,0.4,0\n", S_REF, "missing: none; not used: Cl"),
    ("Mach,Cd\n0.2,0.4\n0.5,abc\n", S_REF, "column Cd row 3 is not a finite number ('abc')"),
    ("Mach,Cd\n0.2,0.4\n0.2,0.5\n", S_REF, "not increasing"),
    ("Mach,Cd\n-0.1,0.4\n", S_REF, "Mach must increase strictly from >= 0"),
    ("Mach,Cd\n100,0.4\n200,0.4\n", S_REF, "at most 30"),
    ("Mach,Cd\n", S_REF, "no rows"),
])
def test_bad_curve_is_one_line(tmp_path, text, area, message):
    path = _curve(tmp_path, text)
    with pytest.raises(UsageError) as info:
        read_reference_curve(path, area_m2=area)
    assert "\n" not in str(info.value)
    assert str(info.value).startswith(str(path))
    assert message in str(info.value)


def test_flight_mach_against_isa_by_hand():
    flight = simulate_scenario(load_scenario(None), NoNoise(), rng=0)
    speed_of_sound = math.sqrt(1.4 * 287.05287 * 223.15)  # ISA at 10 km
    speed = np.sqrt(flight["u"] ** 2 + flight["v"] ** 2 + flight["w"] ** 2)
    np.testing.assert_allclose(flight_mach(flight), speed / speed_of_sound, rtol=1e-6)
    dense = dataclasses.replace(flight, airframe=flight.airframe.replace(
        altitude_m=None, given_density_kgm3=0.41))
    with pytest.raises(UsageError, match="gives no speed of sound"):
        flight_mach(dense)


def test_figure_draws_the_converted_fit_beside_the_curve(tmp_path):
    curve = read_reference_curve(_curve(tmp_path), area_m2=S_REF)
    ratio = S_AEROID / S_REF
    # a constant Cx over the flight's Mach range: a band
    fig = reference_curve_figure([1.68, 1.69], [-0.98] * 2, [-1.0] * 2, [-0.96] * 2, curve,
                                 area_m2=S_AEROID, label="output-error +- 2 se")
    ax = fig.axes[0]
    lines = {line.get_label(): line for line in ax.get_lines()}
    np.testing.assert_array_equal(lines["rasaero.csv (Cd)"].get_ydata(), curve.cd)
    np.testing.assert_allclose(lines["output-error +- 2 se"].get_ydata(), 0.98 * ratio,
                               rtol=1e-14)
    band = ax.collections[0].get_paths()[0].vertices[:, 1]
    assert band.min() == pytest.approx(0.96 * ratio) and band.max() == pytest.approx(
        1.0 * ratio)
    assert "Cd = -Cx x S_aeroid / S_ref" in ax.get_title()
    # a table: points with error bars, the converted interval
    fig = reference_curve_figure([0.5, 1.0, 1.5], [-0.4, -0.5, -0.6], [-0.42, -0.53, -0.61],
                                 [-0.38, -0.47, -0.59], curve, area_m2=S_AEROID)
    ax = fig.axes[0]
    (bars,) = ax.containers
    assert bars.get_label() == "fitted"
    np.testing.assert_allclose(bars.lines[0].get_ydata(), np.array([0.4, 0.5, 0.6]) * ratio,
                               rtol=1e-14)
    segments = bars.lines[2][0].get_segments()  # the vertical bars: [lo, hi] converted
    np.testing.assert_allclose([seg[:, 1] for seg in segments],
                               np.array([[0.38, 0.42], [0.47, 0.53], [0.59, 0.61]]) * ratio,
                               rtol=1e-12)
    with pytest.raises(UsageError, match="one length"):
        reference_curve_figure([0.5, 1.0], [-0.4], [-0.5], [-0.3], curve, area_m2=S_AEROID)


def test_overlap_is_said_only_when_the_ranges_are_apart(tmp_path):
    from aeroid.report import overlap_note

    curve = read_reference_curve(_curve(tmp_path), area_m2=S_REF)  # Mach 0.2 .. 2.0
    assert overlap_note((1.68, 1.69), curve) is None
    assert overlap_note((2.0, 2.3), curve) is None  # touching at one Mach: compared there
    assert overlap_note((0.0, 0.2), curve) is None
    note = overlap_note((2.01, 2.3), curve)
    assert note is not None and "\n" not in note
    assert "0.2 .. 2 and the flight's 2.01 .. 2.3 do not overlap" in note


def test_fitted_cx_of_a_table_a_held_table_and_no_cx():
    from aeroid.estimation import EstimationResult
    from aeroid.report import fitted_cx

    names = ("Cx@M1.8", "Cx@M1.2", "Cza")  # the knots out of order: drawn sorted
    theta, stderr = np.array([-0.8, -1.1, -11.8]), np.array([0.02, 0.01, 0.1])
    result = EstimationResult(estimator="m", names=names, theta=theta, stderr=stderr)
    mach, value, lo, hi, label = fitted_cx(result, (1.3, 1.7))
    np.testing.assert_array_equal(mach, [1.2, 1.8])
    np.testing.assert_array_equal(value, [-1.1, -0.8])
    np.testing.assert_allclose(lo, [-1.1 - 1.96 * 0.01, -0.8 - 1.96 * 0.02], rtol=1e-15)
    np.testing.assert_allclose(hi, [-1.1 + 1.96 * 0.01, -0.8 + 1.96 * 0.02], rtol=1e-15)
    assert label == "m, +- 1.96 se (95 %)"
    held = dataclasses.replace(result, stderr=np.array([np.nan, np.nan, 0.1]),
                               held={"Cx@M1.8": -0.8, "Cx@M1.2": -1.1})
    _, value, lo, hi, label = fitted_cx(held, (1.3, 1.7))
    assert np.array_equal(lo, value) and np.array_equal(hi, value) and "held" in label
    no_cx = EstimationResult(estimator="m", names=("Cza",), theta=np.array([-11.8]))
    with pytest.raises(UsageError, match="the m fit has no finite Cx to draw"):
        fitted_cx(no_cx, (1.3, 1.7))
