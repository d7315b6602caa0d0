"""The one curve-CSV reader behind the thrust curve and the reference drag curve.

The two callers' own messages are tested in ``test_thrust_curve.py`` and
``test_reference_curve.py`` (unchanged by the shared reader); here the reader itself:
the values read back equal those written, the header matched without case or blanks,
an optional column present or not, and each refusal one line of the caller's error kind
in the caller's words.
"""

from __future__ import annotations

import numpy as np
import pytest

from aeroid.errors import AirframeError, UsageError
from aeroid.model import read_curve_csv


def _read(path, **kwargs):
    return read_curve_csv(path, required=("time_s", "thrust_n"), optional=("mass_kg",),
                          kind="thrust curve", columns_text="the columns A", **kwargs)


def test_values_read_back_with_and_without_the_optional_column(tmp_path) -> None:
    times, thrust, mass = [0.0, 0.5, 2.25], [0.0, 612.5, 1e-3], [10.0, 9.75, 9.5]
    path = tmp_path / "c.csv"
    path.write_text(" Time_S ,THRUST_N,mass_kg\n" + "".join(
        f"{a!r},{b!r},{c!r}\n" for a, b, c in zip(times, thrust, mass, strict=True)))
    values = _read(path)
    assert list(values) == ["time_s", "thrust_n", "mass_kg"]
    for key, expected in zip(values, (times, thrust, mass), strict=True):
        np.testing.assert_array_equal(values[key], expected)  # exactly: repr round-trips
    path.write_text("time_s,thrust_N\n0,1\n1,2\n")
    assert list(_read(path)) == ["time_s", "thrust_n"]


@pytest.mark.parametrize(("text", "error", "row_word", "match"), [
    ("time_s,thrust_N,extra\n0,1,2\n", AirframeError, "line",
     r"a thrust curve has the columns A \(missing: none; not used: extra\)"),
    ("thrust_N\n1\n", UsageError, "row", r"\(missing: time_s; not used: none\)"),
    ("time_s,thrust_N\n0,1\n1,x\n", AirframeError, "line",
     r"column thrust_N line 3 is not a finite number \('x'\)"),
    ("time_s,thrust_N\n0,1\n1,inf\n", UsageError, "row", r"column thrust_N row 3 is not a"),
])
def test_refusals_are_one_line_of_the_callers_kind(tmp_path, text, error, row_word,
                                                   match) -> None:
    path = tmp_path / "c.csv"
    path.write_text(text)
    with pytest.raises(error, match=match) as info:
        _read(path, row_word=row_word, error=error)
    assert str(info.value).startswith(f"{path}: ") and "\n" not in str(info.value)


def test_a_missing_file_is_one_line(tmp_path) -> None:
    with pytest.raises(UsageError, match="cannot read the thrust curve") as info:
        _read(tmp_path / "none.csv", error=UsageError)
    assert "\n" not in str(info.value)
