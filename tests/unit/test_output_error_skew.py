"""Output-error estimating an aiding group's time skew (``estimate_skew``).

References: the interpolant against closed forms (a line and a parabola are reproduced,
a rolling angle within its stated error); the skew's and the other parameters'
sensitivities against central differences of the outputs; undeclared 50 ms GNSS and
INS skews (known-wrong logs) against the skew the test put in.
"""

from __future__ import annotations

import numpy as np
import pytest
from suite_flights import gnss_aiding, ins_aiding, suite_flight

from aeroid.flights import reference_scenario
from aeroid.model import N_COEFFICIENTS, OUTPUT_CHANNELS
from baselines._oe_skew import SKEW_NAMES, hermite_weights
from baselines.output_error import OutputErrorEstimator

#: The skewed fits' options: the raw IMU's errors, the initial velocity free.
BASE = {"imu_errors": "bias+scale", "estimate_initial_velocity": True}
BOTH = "gnss-velocity+ins-attitude"
#: Record of the interpolant tests: 1 kHz over 1 s.
DT, N = 1e-3, 1001
#: A roll angle turning at 50 rad/s, its rate swinging by 5 rad/s at 10 Hz: interpolated
#: to 3.2e-7 rad inside the record, 2.3e-5 rad in its first and last intervals (one-sided
#: tangents) (measured); the INS's sd is 3e-3 rad.
ROLL_INSIDE_ATOL = 5e-7
ROLL_EDGE_ATOL = 5e-5
#: Rounding of a weighted sum of O(1) values.
EXACT = 1e-12
#: Central-difference steps in scaled parameters: coefficients over their prior, m/s, rad,
#: the skews in samples (1 ms); the skew's outputs are cubic in it between samples, so its
#: difference is exact to rounding.
FD_STEP, FD_STEP_SKEW = 1e-4, 1e-3
#: Exact sensitivities against the central differences, relative to each column's
#: largest entry: measured largest 3.5e-6 (Czq), 5.8e-9 and 7.3e-10 (the skews).
FD_RTOL = 1e-5
#: The undeclared skew put in [s] and the bound on |estimate - truth| in standard errors.
SKEW_S = 0.05
WITHIN_SE = 3.0


def _line(a, b):
    return lambda t: a + b * t


def test_interpolant_reproduces_a_line_everywhere_and_a_parabola_inside():
    t = DT * np.arange(N)
    rng = np.random.default_rng(0)
    inside = rng.uniform(t[1], t[-2], 500)
    everywhere = np.concatenate([inside, [t[0], t[-1], 0.3 * DT, t[-1] - 0.3 * DT],
                                 [t[0] - 7 * DT, t[-1] + 4.5 * DT]])  # beyond both ends
    for tq, f, df in ((everywhere, _line(2.0, -3.0), lambda t: -3.0 + 0 * t),
                      (inside, lambda t: 1.0 + 2 * t - 5 * t ** 2, lambda t: 2 - 10 * t)):
        index, w, dw = hermite_weights(tq, t[0], DT, N)
        np.testing.assert_allclose(np.sum(w, axis=1), 1.0, atol=EXACT)
        np.testing.assert_allclose(np.sum(dw, axis=1), 0.0, atol=EXACT / DT)
        np.testing.assert_allclose(np.sum(w * f(t)[index], axis=1), f(tq), atol=EXACT)
        np.testing.assert_allclose(np.sum(dw * f(t)[index], axis=1), df(tq), atol=1e-8)
    # on a sample: that sample alone
    index, w, _ = hermite_weights(t[[0, 17, N - 1]], t[0], DT, N)
    assert np.all(np.sum(w == 1.0, axis=1) == 1) and np.all(np.sum(w == 0.0, axis=1) == 3)
    np.testing.assert_array_equal(index[w == 1.0], [0, 17, N - 1])


def test_interpolant_of_a_rolling_angle_within_its_stated_error():
    t = DT * np.arange(N)

    def roll(t):
        return 50 * t - 5 / (20 * np.pi) * np.cos(20 * np.pi * t)
    rng = np.random.default_rng(1)
    for tq, atol in ((rng.uniform(t[1], t[-2], 2000), ROLL_INSIDE_ATOL),
                     (rng.uniform(t[0], t[1], 200), ROLL_EDGE_ATOL)):
        index, w, dw = hermite_weights(tq, t[0], DT, N)
        assert np.max(np.abs(np.sum(w * roll(t)[index], axis=1) - roll(tq))) < atol
        # the weights' derivative is the derivative of the weights (central differences)
        h = 1e-7
        _, wp, _ = hermite_weights(tq + h, t[0], DT, N)
        _, wm, _ = hermite_weights(tq - h, t[0], DT, N)
        np.testing.assert_allclose(dw, (wp - wm) / (2 * h), atol=1e-4)


@pytest.fixture(scope="module")
def clean():
    """Noise-free default suite (seed 3), GNSS and INS as logged (stated sd small)."""
    sim, flight = suite_flight(seed=3, accel_noise_mps2=0.0, gyro_noise_radps=0.0,
                               gnss_velocity_sd_mps=0.0)
    return ins_aiding(sim, gnss_aiding(sim, flight, sd=1e-3))


def test_skew_jacobian_equals_central_differences(clean):
    est = OutputErrorEstimator(**BASE, aiding=BOTH, estimate_skew="gnss+ins")
    model = est.problem(clean).model
    p = np.zeros(model.scale.size)
    p[:N_COEFFICIENTS] = (reference_scenario().coefficient_vector
                          / model.scale[:N_COEFFICIENTS])
    names = est.parameter_names(model.position_free)
    assert names[-2:] == (SKEW_NAMES["gnss"], SKEW_NAMES["ins"])
    # off the samples (3.3 and -7.6 ms), the other parameters away from their start
    for name, value in (("u0", 0.3), ("theta0", -1e-3), ("gnss_skew_s", 3.3),
                        ("ins_skew_s", -7.6), ("bax1", 0.5)):
        p[names.index(name)] = value
    _, J = model.outputs_jacobian(p)
    m = len(OUTPUT_CHANNELS)
    for i, name in enumerate(names):
        h = FD_STEP_SKEW if name.endswith("skew_s") else FD_STEP
        step = np.zeros_like(p)
        step[i] = h
        fd = (model.outputs(p + step) - model.outputs(p - step)) / (2 * h)
        exact = J[:, :, i].T
        if name.endswith("skew_s"):
            assert np.all(exact[:, :m] == 0.0)  # the IMU's outputs do not see a skew
            assert np.max(np.abs(fd[:, m:])) > 0.0
        peak = max(np.max(np.abs(fd[:, m:])), 1e-300)
        np.testing.assert_allclose(exact[:, m:], fd[:, m:], rtol=0, atol=FD_RTOL * peak,
                                   err_msg=name)


@pytest.fixture(scope="module")
def noisy():
    """The default suite with noise (seed 1): raw IMU, true states."""
    return suite_flight(seed=1)


@pytest.mark.parametrize(("source", "aiding"), [("gnss", "gnss-velocity"), ("ins", BOTH)])
def test_undeclared_50_ms_skew_is_recovered_within_3_se(noisy, source, aiding):
    sim, flight = noisy
    flight = gnss_aiding(sim, flight, shift_s=-SKEW_S if source == "gnss" else 0.0)
    if source == "ins":
        flight = ins_aiding(sim, flight, shift_s=-SKEW_S)  # logged 50 ms early
    fit = OutputErrorEstimator(**BASE, aiding=aiding, estimate_skew=source).fit(flight, rng=0)
    assert fit.success, fit.message
    skew, se = fit.info["aiding_skew_s"][source], fit.info["aiding_skew_stderr_s"][source]
    assert abs(skew - SKEW_S) < WITHIN_SE * se, (skew, se)
    truth = reference_scenario().coefficient_vector
    assert np.max(np.abs(fit.theta - truth) / fit.stderr) < WITHIN_SE
    # the GNSS skew is weakly determined (the free initial velocity and attitude absorb
    # most of it: se ~12 ms, theta0 its partner); the INS's sharply (roll at 50 rad/s)
    partner, corr = fit.info["aiding_skew_correlation"][source]
    assert (se > 1e-3 and partner == "theta0") if source == "gnss" else se < 1e-3
    assert abs(corr) < 1.0


def test_skew_option_refusals_are_one_line():
    for options, match in (({"aiding": "gnss-velocity", "estimate_skew": "ins"},
                            "needs the INS attitude in the likelihood"),
                           ({"estimate_skew": "gnss"}, "needs the GNSS velocity or position"),
                           ({"aiding": BOTH, "estimate_skew": "baro"},
                            "estimate_skew must be one of")):
        with pytest.raises(ValueError, match=match) as exc:
            OutputErrorEstimator(**options)
        assert "\n" not in str(exc.value)
