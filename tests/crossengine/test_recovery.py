"""What aeroid's estimators recover from the JSBSim flights, today and with issue 10's inputs.

Measured numbers (``python -m tests.crossengine.measure``) on the default flight
``climb`` (noise-free unless the test says otherwise):

* equation-error today: mean |error| 0.66 %, worst Clp 1.55 %, because the density
  changes by 2.8 % over the window while aeroid holds one; with the density of each
  sample (the regressors of :func:`.prototype.equation_error_per_sample_density`) it
  reaches 0.0004 % on the force coefficients and Cma, Cmd, Cmq, and 0.08 / 0.12 % on
  Cl0 / Clp: what is left there is the 101-sample Savitzky-Golay window of the roll-rate
  derivative (aeroid.estimation._reconstruct), tuned for the reference flight's slow
  roll-up (time constant ~3 s, here ~0.45 s).
* output-error today: Czq 106 %, Cmq 35 %, ``success: True``.

The tests marked ``xfail(strict=True, reason="needs issue 10 inputs")`` are written
against the API this package proposes for issue 10 (the names are in
:func:`issue10_flight`); they flip to passing when the inputs land.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import aeroid

from . import prototype as pt

jsbsim = pytest.importorskip("jsbsim", reason="the cross-engine tests need JSBSim "
                                                  "(the dev or crossengine extra)")

#: aeroid's equation-error on ``climb`` today (measured: 0.013 0.459 0.011 1.44 1.49 1.55
#: 0.804 0.017 0.144 %): the tolerance is the largest measured error plus 5 % of it.
EE_TODAY_MAX_PCT = 1.55 * 1.05
EE_TODAY_MEAN_PCT = 0.66 * 1.05
#: With per-sample density (measured: 1.4e-6 4.7e-5 1.0e-5 3.7e-4 0.082 0.124 1.8e-3
#: 1.0e-4 2.0e-3 %): the roll-derivative window's bias on Cl0 / Clp, 5 % margin...
EE_DENSITY_ROLL_MAX_PCT = 0.124 * 1.05
#: ...and the others, limited by the step-1 reconstruction and smoothing (2.5x margin).
EE_DENSITY_OTHERS_MAX_PCT = 0.005
#: Issue 10's target for the noise-free window.
TARGET_NOISE_FREE_PCT = 0.1
#: Issue 10's targets with Gaussian noise: every coefficient within 3 Cramér-Rao sd,
#: mean |error| <= 1 %.
TARGET_CRAMER_RAO_SD = 3.0
TARGET_NOISY_MEAN_PCT = 1.0
ROLL = [aeroid.NAMES.index("Cl0"), aeroid.NAMES.index("Clp")]


def _error_pct(theta, truth) -> np.ndarray:
    return np.abs(np.asarray(theta) / truth.coefficients - 1.0) * 100.0


def test_equation_error_today(climb):
    flight, truth = climb
    result = aeroid.make_estimator("equation-error").fit(flight, rng=1)
    error = _error_pct(result.theta, truth)
    # one density for a climb: the regression misses the forces by tens of times the
    # noise-free data's resolution, and the fit check says so
    assert not result.success and "does not fit the data" in result.message
    assert np.max(error) < EE_TODAY_MAX_PCT
    assert np.mean(error) < EE_TODAY_MEAN_PCT


def test_equation_error_with_per_sample_density(climb):
    """The density trend is what limits equation-error today (prototype regressors)."""
    flight, truth = climb
    rho = truth.data["rho"].to_numpy()
    error = _error_pct(pt.equation_error_per_sample_density(flight, rho), truth)
    assert np.max(error[ROLL]) < EE_DENSITY_ROLL_MAX_PCT
    assert np.max(np.delete(error, ROLL)) < EE_DENSITY_OTHERS_MAX_PCT
    same = pt.equation_error_per_sample_density(flight)  # one density: aeroid's answer
    # the prototype smooths targets and regressors
    today = aeroid.make_estimator("equation-error", {"smoothing": "both"}).fit(flight, rng=1)
    np.testing.assert_allclose(same, today.theta, rtol=1e-12)


# ----------------------------------------------------------------------------------
# Issue 10: the API these tests propose
# ----------------------------------------------------------------------------------
def issue10_flight(flight, truth, *, events: bool = False, delay: bool = False):
    """aeroid's view of a JSBSim flight with the inputs of issue 10.

    * the per-sample density: a ``rho`` channel and ``[atmosphere] per_sample = "rho"``;
    * with ``events``: the switch instants as the deflection's knots,
      ``metadata["delta_knots"]`` (what the ``events`` input reads);
    * the fin law in the airframe (``Airframe.fin_law``).
    """
    channels = {c: flight[c] for c in flight.channels}
    channels["rho"] = truth.data["rho"].to_numpy()
    airframe = flight.airframe.replace(altitude_m=None, given_density_kgm3=None,
                                       atmosphere_channel="rho")
    metadata = dict(flight.metadata)
    if events:
        knots = aeroid.model.Schedule.events(truth.initial_delta, truth.switch_times,
                                             truth.switch_values)
        metadata["delta_knots"] = {"t": knots.times.tolist(), "delta": knots.values.tolist()}
    config = truth.config  # the fin law of the airframe file
    law = aeroid.model.FinLaw(delta_max_rad=airframe.delta_max_rad,
                              command_amplitude=config.command_amplitude,
                              command_phase_deg=config.command_phase_deg,
                              delay_s=config.fin_delay_s if delay else 0.0)
    airframe = airframe.replace(fin_law=law)
    return aeroid.make_flight(channels, airframe, metadata)


@pytest.mark.parametrize("delta_input", ["law", "events"])
def test_output_error_recovers_the_noise_free_flight(climb, delta_input):
    """Measured with the prototype: every coefficient within 0.0011 % (both inputs)."""
    flight, truth = climb
    flight = issue10_flight(flight, truth, events=delta_input == "events")
    result = aeroid.make_estimator("output-error", {"input": delta_input}).fit(flight, rng=1)
    assert result.success
    assert np.max(_error_pct(result.theta, truth)) <= TARGET_NOISE_FREE_PCT


def test_output_error_estimates_the_actuator_delay(climb_delayed):
    """Measured with the prototype: 1000.03 us +- 0.001 us, coefficients within 0.004 %."""
    flight, truth = climb_delayed
    flight = issue10_flight(flight, truth)
    result = aeroid.make_estimator("output-error",
                                   {"input": "law", "estimate_delay": True}).fit(flight, rng=1)
    delay, delay_sd = result.info["delay_s"], result.info["delay_stderr_s"]
    assert abs(delay - truth.config.fin_delay_s) <= max(3 * delay_sd, 1e-6)
    assert np.max(_error_pct(result.theta, truth)) <= TARGET_NOISE_FREE_PCT


def test_output_error_with_gaussian_noise_is_within_its_cramer_rao_bounds(climb_noisy):
    """Measured with the prototype on 5 seeds x 2 flights: worst 2.24 sd, mean <= 0.05 %."""
    flight, truth = climb_noisy
    flight = issue10_flight(flight, truth, events=True)
    result = aeroid.make_estimator("output-error", {"input": "events"}).fit(flight, rng=1)
    z = np.abs(result.theta - truth.coefficients) / result.stderr
    assert np.all(z <= TARGET_CRAMER_RAO_SD)
    assert np.mean(_error_pct(result.theta, truth)) <= TARGET_NOISY_MEAN_PCT


def test_equation_error_uses_the_density_channel(climb):
    flight, truth = climb
    result = aeroid.make_estimator("equation-error").fit(issue10_flight(flight, truth), rng=1)
    error = _error_pct(result.theta, truth)
    assert np.max(error[ROLL]) < EE_DENSITY_ROLL_MAX_PCT
    assert np.max(np.delete(error, ROLL)) < EE_DENSITY_OTHERS_MAX_PCT


def test_fit_check_fails_todays_held_input_fit(climb_noisy):
    """Held deflection on a continuous relay: Czq 106 % off while the accelerometer
    residuals are many times the noise; the fit check must say so (issue 10, item 4)."""
    flight, _ = climb_noisy
    result = aeroid.make_estimator("output-error").fit(flight, rng=1)
    assert not result.success
    assert any(name in result.message for name in ("ax1", "ay1", "az1", "ax2", "ay2", "az2"))
    ratio = result.info["fit_check"]["ratio"]
    assert max(ratio.values()) > 3.0
    assert math.isfinite(max(ratio.values()))


@pytest.mark.parametrize("name", ["ekf", "ukf"])
def test_filter_passes_on_the_jsbsim_flight_are_within_their_intervals(climb_noisy, name):
    """The EKF/UKF passes (issue 11) on a flight our simulator did not make: the JSBSim
    climb with Gaussian noise, events input, per-sample density (as output-error above).
    Measured: EKF 1.7 sd at worst after 3 passes, UKF 1.7. This test found the EKF's
    passes 6.6 sd off on Cza: its model's deflection at sample 0 was overwritten by the
    last sample's after the first pass (``Buffered`` aliased its input)."""
    flight, truth = climb_noisy
    flight = issue10_flight(flight, truth, events=True)
    result = aeroid.make_estimator(name, {"input": "events"}).fit(flight, rng=1)
    assert result.success, result.message
    assert result.info["passes"] > 1
    z = np.abs(result.theta - truth.coefficients) / result.stderr
    assert np.all(z <= TARGET_CRAMER_RAO_SD), z
    assert np.mean(_error_pct(result.theta, truth)) <= TARGET_NOISY_MEAN_PCT
