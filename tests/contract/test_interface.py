"""The estimator interface itself: result, warnings, fit's failure handling, options, progress,
registry (the import layering is tests/contract/test_layers.py)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, Literal

import numpy as np
import pytest

from aeroid.errors import EstimatorError, FlightError
from aeroid.estimation import (
    EDGE_FRACTION,
    EstimationResult,
    Estimator,
    ProgressEvent,
    box_edge_warnings,
    failed_result,
    register,
    report_progress,
)
from aeroid.estimation._options import parse_value, type_name
from aeroid.model._coefficients import NAMES


def _result(**fields) -> EstimationResult:
    return EstimationResult(estimator="x", theta=np.arange(1.0, 10.0), **fields)


# ---------------------------------------------------------------- result and warnings


def test_warnings_are_a_tuple_of_single_lines() -> None:
    assert _result().warnings == ()
    assert _result(warnings="one\nwarning").warnings == ("one warning",)
    assert _result(warnings=["a", "b  c"]).warnings == ("a", "b c")


def test_summary_shows_warnings_and_no_nan_cost() -> None:
    text = _result(warnings=("Czq on the edge",), n_iterations=3).summary()
    lines = text.splitlines()
    assert lines[0] == "x: ok"
    assert lines[1] == "warning: Czq on the edge"
    assert "cost" not in lines[2] and lines[2].startswith("0 evaluations, 3 iterations")
    assert "nan" not in text
    assert _result(cost=2.5).summary().splitlines()[1].startswith("cost 2.5, ")


def test_summary_and_json_say_compiled_or_interpreted() -> None:
    assert "model evaluated compiled" in _result(info={"compiled": True}).summary()
    assert "model evaluated interpreted" in _result(info={"compiled": False}).summary()
    assert "compiled" not in _result().summary()
    assert _result(info={"compiled": False}).to_json_dict()["compiled"] is False
    assert "compiled" not in _result().to_json_dict()


def test_row_and_json_carry_the_warnings() -> None:
    result = _result(warnings=("a", "b"))
    row = result.to_row()
    assert row["warnings"] == "a; b"
    assert all(np.isscalar(v) for v in row.values())  # flat
    assert _result().to_row()["warnings"] == ""
    assert result.to_json_dict()["warnings"] == ["a", "b"]


def test_box_edge_warnings_hand_cases() -> None:
    bounds = np.array([[0.0, 10.0], [-4.0, -2.0], [1.0, 2.0], [0.0, 1.0]])
    names = ("a", "b", "c", "d")
    # a on its low wall; b within EDGE_FRACTION of its high wall; c just outside the margin
    # of its low wall; d NaN (a failed estimate is not "on the edge")
    theta = np.array([0.0, -2.0 - 0.5 * EDGE_FRACTION * 2.0, 1.0 + 2 * EDGE_FRACTION, np.nan])
    (warning,) = box_edge_warnings(theta, bounds, names)
    assert "a = 0 at low end of [0, 10]" in warning
    assert "b = -2.001 at high end of [-4, -2]" in warning
    assert "c = " not in warning and "d = " not in warning
    assert box_edge_warnings(np.array([5.0, -3.0, 1.5, 0.5]), bounds, names) == ()
    with pytest.raises(ValueError, match="3 estimates, 4 bounds"):
        box_edge_warnings(theta[:3], bounds, names)


# ---------------------------------------------------------------- fit


@dataclass(frozen=True, kw_only=True)
class _Scripted(Estimator):
    """An estimator whose run does what the test says.

    Options
    -------
    action : {"raise", "user-error", "report", "nan"}
        What run does: raise a RuntimeError, raise a FlightError, report progress and
        return, or return NaN estimates. Second sentence.
    level : float
        A number.
    sizes : list of int or None
        Some sizes.
    """

    name: ClassVar[str] = "scripted"
    action: Literal["raise", "user-error", "report", "nan"] = "report"
    level: float = 1.0
    sizes: tuple[int, ...] | None = None

    def run(self, flight, rng):
        if self.action == "raise":
            raise RuntimeError("boom\nsecond line")
        if self.action == "user-error":
            raise FlightError("flight.csv: channel 'q' is in deg/s")
        if self.action == "nan":
            return EstimationResult(estimator=self.name, theta=np.full(len(NAMES), np.nan))
        for k in range(3):
            report_progress(k, 2, "stage")
        return EstimationResult(estimator=self.name, theta=np.zeros(len(NAMES)), cost=0.0)


def test_fit_turns_a_crash_into_a_failed_result(paper_flight) -> None:
    result = _Scripted(action="raise").fit(paper_flight)
    assert not result.success
    assert result.message == "RuntimeError: boom"
    assert np.all(np.isnan(result.theta))


def test_fit_raises_user_errors_found_by_the_method(paper_flight) -> None:
    with pytest.raises(FlightError, match="deg/s"):
        _Scripted(action="user-error").fit(paper_flight)


def test_fit_flags_non_finite_estimates(paper_flight) -> None:
    result = _Scripted(action="nan").fit(paper_flight)
    assert not result.success and result.message == "non-finite estimate"


@pytest.mark.parametrize("seed", [-1, 1.5, "x"])
def test_fit_refuses_a_bad_seed_in_one_line(paper_flight, seed) -> None:
    with pytest.raises(EstimatorError, match="scripted: bad seed") as info:
        _Scripted().fit(paper_flight, rng=seed)
    assert "\n" not in str(info.value)


def test_progress_goes_to_the_listener_of_its_own_fit_only(paper_flight) -> None:
    outer: list[ProgressEvent] = []
    inner: list[ProgressEvent] = []
    report_progress(1, 2)  # nobody listens: nothing happens

    @dataclass(frozen=True, kw_only=True)
    class Nested(Estimator):
        name: ClassVar[str] = "nested"

        def run(self, flight, rng):
            report_progress(1, 2, "outer")
            _Scripted().fit(flight)  # no listener: silent, even inside this fit
            _Scripted().fit(flight, progress=inner.append)
            return EstimationResult(estimator=self.name, theta=np.zeros(len(NAMES)))

    Nested().fit(paper_flight, progress=outer.append)
    assert outer == [ProgressEvent(1, 2, "outer")]
    assert [(e.done, e.total, e.stage) for e in inner] == [(0, 2, "stage"), (1, 2, "stage"),
                                                          (2, 2, "stage")]
    assert all(math.isnan(e.cost) for e in inner)


# ---------------------------------------------------------------- options


def test_describe_options_reads_types_defaults_and_first_sentences() -> None:
    infos = {o.name: o for o in _Scripted.describe_options()}
    assert list(infos) == ["action", "level", "sizes"]
    assert infos["action"].type == "{raise, user-error, report, nan}"
    assert infos["action"].default == "report"
    assert infos["action"].description == (
        "What run does: raise a RuntimeError, raise a FlightError, report progress and "
        "return, or return NaN estimates.")
    assert (infos["level"].type, infos["level"].default) == ("float", 1.0)
    assert infos["sizes"].type == "list of int or none"


def test_every_built_in_option_is_documented() -> None:
    from aeroid.estimation import get_estimator

    for name in ("eam-pso", "ebm-pso", "sebm-pso"):
        for info in get_estimator(name).describe_options():
            assert info.description, f"{name}: option {info.name} has no description"
            assert "``" not in info.description and ":func:" not in info.description


def test_type_names_and_values() -> None:
    assert type_name(int) == "int"
    assert type_name(Literal["a", "b"] | None) == "{a, b} or none"
    assert parse_value("[1, 2]") == [1, 2]
    assert parse_value("noise") == "noise"


def test_from_options_checks_types_in_one_line() -> None:
    assert _Scripted.from_options({"level": "2", "sizes": "[1, 2]"}) == _Scripted(
        level=2.0, sizes=(1, 2))
    with pytest.raises(EstimatorError, match="scripted: option level expects a number"):
        _Scripted.from_options({"level": "high"})
    with pytest.raises(EstimatorError, match=r"unknown option\(s\) colour"):
        _Scripted.from_options({"colour": "red"})


# ---------------------------------------------------------------- registry


def test_register_refuses_a_second_class_under_one_name() -> None:
    from aeroid.estimation._sebm import SEBMPSO

    assert register(SEBMPSO) is SEBMPSO  # the same class again is fine
    with pytest.raises(EstimatorError, match="'sebm-pso' registered twice"):
        register(type("Twin", (SEBMPSO,), {}))
    with pytest.raises(EstimatorError, match="has no name"):
        register(type("Nameless", (_Scripted,), {"name": ""}))


def test_failed_result_has_nan_estimates() -> None:
    result = failed_result("m", "why")
    assert not result.success and result.message == "why" and result.names == NAMES
    assert np.all(np.isnan(result.theta))
