"""Filter-error's measurement noise from the innovations on the README's example log.

The example log (still air, a tactical IMU's Gaussian noise 0.05 m/s^2 and 0.005 rad/s,
examples/make_flight_log.py; no noise metadata) was refused as not white: the relaxation
``R_c = mean(nu_c^2 - (H P^- H^T)_cc)`` set the tail triad's ay2, az2 variances to the
floor at the first iteration from the prior (raising the likelihood's cost), and the fit
stopped in a poorer optimum with 3.4 m/s of gusts in still air. References: the generator's
noise sd; the truth's coefficients; the optimum reached from the truth (the airframe
without a prior starts there); the likelihood itself (each noise step lowers it); wrong
models on the same log still refused.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aeroid.flights import read_column_map, read_flight
from aeroid.model import ACCEL_CHANNELS, NAMES, OUTPUT_CHANNELS, load_airframe, nominal
from baselines import _fem_fit
from baselines.filter_error import FilterErrorEstimator

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
#: examples/make_flight_log.py's GaussianNoise(): accelerations, rates.
ACCEL_SD, RATE_SD = 0.05, 0.005
#: 501 samples: the sd of an estimated sd is ~3 %; 15 % is 5 of those.
NOISE_RTOL = 0.15
#: The fit's coefficients lie within 2.5 of their standard errors of the truth (measured,
#: largest over the nine: Cmq); 3 is the usual bound.
WITHIN_SE = 3.0
#: The fit from the prior and the fit from the truth end at the same optimum: their costs
#: agree to 0.1 (measured 0.02; the noise variances converge to 1 %).
SAME_OPTIMUM = 0.1


@pytest.fixture(scope="module")
def example_log():
    return read_flight(EXAMPLES / "flight-log.csv",
                       airframe=load_airframe(EXAMPLES / "airframe.toml"),
                       columns=read_column_map(EXAMPLES / "columns.toml"), degrees=True)


@pytest.fixture(scope="module")
def example_fit(example_log):
    return FilterErrorEstimator().fit(example_log, rng=0)


def test_the_example_log_passes(example_log, example_fit) -> None:
    fe = example_fit
    assert fe.success, fe.message
    assert fe.info["measurement_noise"] == "innovations"
    assert fe.info["gust_sd_at_bound"]  # still air
    assert fe.info["fit_check"]["not_white"] == []
    want = np.array([ACCEL_SD if c in ACCEL_CHANNELS else RATE_SD for c in OUTPUT_CHANNELS])
    np.testing.assert_allclose(np.sqrt(fe.info["measurement_noise_var"]), want,
                               rtol=NOISE_RTOL)
    err = (fe.theta - nominal()) / fe.stderr
    assert np.all(np.abs(err) < WITHIN_SE), err
    # the same optimum as the fit started from the truth (no [prior]: nominal)
    from_truth = FilterErrorEstimator().fit(
        type(example_log)(example_log.data, example_log.airframe.replace(prior=None),
                          example_log.metadata), rng=0)
    assert from_truth.success, from_truth.message
    assert abs(fe.cost - from_truth.cost) < SAME_OPTIMUM


def test_the_noise_step_lowers_the_likelihood(example_log) -> None:
    """The cause, then the guard: at the first iteration from the prior the relaxation
    taken in full raises the cost (measured by 435); the step taken lowers it."""
    start = FilterErrorEstimator().start(example_log)
    problem, R0 = start.problem, start.noise.R
    one = _fem_fit.fisher_scoring(problem, start.p0, R0, update_noise=True,
                                  r_floor=start.noise.floor, max_iterations=1, tol=0.01)

    def cost(R: np.ndarray) -> float:
        return float(_fem_fit.nll(problem.run(one.p[None], R))[0])

    relaxed = _fem_fit._innovation_noise(problem.run(one.p[None], R0), R0, start.noise.floor)
    assert cost(relaxed) > cost(R0) + 100.0  # the relaxation in full: the cause
    assert np.min(relaxed / R0) < 1e-3  # a tail channel's variance thrown to the floor
    assert cost(one.R) < cost(R0)  # the guarded step: downhill
    assert np.min(one.R / R0) > 0.1
    assert len(one.noise_fractions) == 1 and 0.0 <= one.noise_fractions[0] <= 1.0


def test_the_converged_noise_is_the_relaxation_fixed_point(example_log, example_fit) -> None:
    """At the end the relaxation no longer moves the variances (its fixed point: the
    guard did not stop it short), and it was taken in full on the way."""
    fe = example_fit
    assert 1.0 in fe.info["measurement_noise_fractions"]
    start = FilterErrorEstimator().start(example_log)
    problem = start.problem
    nf = problem.free.size
    p = fe.info["parameters"][:nf + 1].copy()
    p[:nf] /= problem.scale
    p[nf] = np.log(p[nf])
    R = fe.info["measurement_noise_var"]
    relaxed = _fem_fit._innovation_noise(problem.run(p[None], R), R, start.noise.floor)
    np.testing.assert_allclose(relaxed, R, rtol=0.02)  # the 1 % convergence test, twice


@pytest.mark.parametrize(("case", "expect"), [
    ("Cma held 30 % off", "the data refuse the user's Cma (hold)"),
    ("input midpoint", "leaves structure in the residuals"),
    ("tail triad on the axis", "does not fit the data"),
])
def test_wrong_models_on_the_example_log_are_refused(example_log, case, expect) -> None:
    flight, options, holds = example_log, {}, None
    if case == "Cma held 30 % off":
        holds = {"hold": {"Cma": 0.7 * float(nominal()[NAMES.index("Cma")])}}
    elif case == "input midpoint":  # the log's deflection holds between samples (hold passes)
        options = {"input": "midpoint"}
    else:  # the tail triad's 0.01 m offsets taken as zero
        x_tail = example_log.airframe.accel2_position_m[0]
        flight = type(example_log)(example_log.data, example_log.airframe.replace(
            accel2_position_m=(x_tail, 0.0, 0.0)), example_log.metadata)
    wrong = FilterErrorEstimator(**options).fit(flight, rng=0, holds=holds)
    assert not wrong.success and expect in wrong.message, wrong.message
