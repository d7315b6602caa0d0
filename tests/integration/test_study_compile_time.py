"""A study's per-fit runtime leaves out numba's one-time compilation.

The first fit in a process that needs a kernel compiled it inside its timed run (a UKF
fit at 30 s beside a median of 0.84 s). :func:`aeroid.study._fits.fit_task` records the
compilation seen during the fit (numba's ``numba:compile`` events) in
``compile_time_s`` and subtracts it from ``wall_time_s``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import ClassVar

import pytest

from aeroid import EstimationResult, Estimator
from aeroid.model import HAVE_NUMBA
from aeroid.study import loads_study
from aeroid.study._fits import fit_task

pytestmark = pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")

#: Seconds of the stand-in compilation and of the stand-in work: the compilation is
#: ten times the work (and the fit check's own time, well under a second), so a runtime
#: that kept it could not pass for one that did not.
COMPILE_S = 2.0
WORK_S = 0.2

STUDY = """
[study]
name = "compile"
runs = 2
seed = 3

[[noise]]
label = "paper"
model = "paper"

[[estimators]]
label = "C"
method = "compiles"
"""


@dataclass(frozen=True, kw_only=True)
class Compiles(Estimator):
    """A compilation of COMPILE_S (announced as numba does, or as a C build does with
    :func:`aeroid.model.compiling`), then WORK_S of work."""

    name: ClassVar[str] = "compiles"
    kind: str = "numba"

    def run(self, flight, rng):
        from numba.core import event

        from aeroid.model import compiling

        announce = (event.trigger_event("numba:compile", data={"dispatcher": None,
                                                              "args": ()})
                    if self.kind == "numba" else compiling("the C model"))
        with announce:
            time.sleep(COMPILE_S)
        time.sleep(WORK_S)
        prior = flight.airframe.prior_vector()
        return EstimationResult(estimator=self.name, theta=prior, stderr=None, cost=0.0,
                                n_evaluations=1, n_iterations=1)


#: The first call's wall time of :class:`CompilesForReal`'s new function, per fit.
FIRST_CALL_S: list[float] = []


@dataclass(frozen=True, kw_only=True)
class CompilesForReal(Estimator):
    """Compiles a new numba function in every fit (a real compilation)."""

    name: ClassVar[str] = "compiles"

    def run(self, flight, rng):
        import numba

        start = time.perf_counter()
        numba.njit(lambda x: 2.0 * x + 1.0)(1.0)  # a new function: compiled here
        FIRST_CALL_S.append(time.perf_counter() - start)
        prior = flight.airframe.prior_vector()
        return EstimationResult(estimator=self.name, theta=prior, stderr=None, cost=0.0,
                                n_evaluations=1, n_iterations=1)


@dataclass(frozen=True, kw_only=True)
class Echo(Estimator):
    """Compiles nothing."""

    name: ClassVar[str] = "compiles"

    def run(self, flight, rng):
        prior = flight.airframe.prior_vector()
        return EstimationResult(estimator=self.name, theta=prior, stderr=None, cost=0.0,
                                n_evaluations=1, n_iterations=1)


@pytest.mark.parametrize("kind", ["numba", "c"])
def test_the_recorded_runtime_leaves_out_a_known_compilation(kind):
    study = loads_study(STUDY + f'options = {{ kind = "{kind}" }}\n',
                        registry={"compiles": Compiles})
    record, _ = fit_task(study, (1, 0, 0))
    assert record["success"], record["message"]
    assert COMPILE_S <= record["compile_time_s"] < COMPILE_S + 0.5
    # the work is in the runtime, the compilation is not
    assert WORK_S <= record["wall_time_s"] < COMPILE_S


def test_a_real_compilation_is_counted():
    study = loads_study(STUDY, registry={"compiles": CompilesForReal})
    FIRST_CALL_S.clear()
    record, _ = fit_task(study, (1, 0, 0))
    (first_call,) = FIRST_CALL_S
    # numba's event covers the compilation, most of the first call
    assert 0.5 * first_call < record["compile_time_s"] <= first_call
    assert record["wall_time_s"] >= 0.0


def test_a_fit_that_compiles_nothing_records_zero():
    study = loads_study(STUDY, registry={"compiles": Echo})
    record, _ = fit_task(study, (1, 0, 0))
    assert record["compile_time_s"] == 0.0
    assert record["wall_time_s"] > 0.0
