"""GNSS position and barometric altitude in output-error's likelihood (``aiding``).

References: the simulator's own position (its truth ``pn pe pd``, integrated by its RK4
with the states, :func:`aeroid.flights.simulate_suite`) against the model's NED velocity
integrated by the trapezoidal rule; the position outputs' sensitivities against central
differences; a fit on a log with GNSS positions only, and one with the barometer too,
against the simulated truth (the barometer's altitude: the simulator's ``altitude``).
"""

from __future__ import annotations

import typing

import numpy as np
import pytest
from suite_flights import suite_flight

from aeroid.flights import Flight, make_flight, reference_scenario
from aeroid.model import N_COEFFICIENTS, OUTPUT_CHANNELS, P, Q, R
from baselines._oe_aiding import OE_AIDING
from baselines._oe_position import ORIGIN_NAMES
from baselines.output_error import OutputErrorEstimator

BASE = {"imu_errors": "bias+scale", "estimate_initial_velocity": True}
POSITION = ("pn", "pe", "pd")
#: The model's integrated NED velocity at the true parameters and initial state against
#: the simulator's position over the 1-s window [m]: measured 4.6e-7 (velocity 1.0e-6 m/s);
#: the GNSS's sd is 1.5 m.
TRUTH_ATOL_M = 1e-5
#: Central differences (scaled parameters: coefficients over their prior, m/s, rad, m)
#: against the exact sensitivities, relative to each column's largest entry.
FD_STEP, FD_STEP_SKEW = 1e-4, 1e-3  # the skew in samples (1 ms): cubic between them
FD_RTOL = 1e-5
WITHIN_SE = 3.0


def with_positions(sim, flight: Flight, sd: float | None = None, velocity: bool = False,
                   baro: bool = False) -> Flight:
    """``flight`` with the suite log's GNSS positions in ``metadata["aiding"]``
    (``gnss_position``: t, pn, pe, pd, sd), with ``velocity`` its velocities too, with
    ``baro`` the barometric altitudes (``baro``: t, altitude, sd)."""
    gnss = sim.log["gnss"]
    aiding = {"gnss_position": {"t": gnss.t, "sd": {c: float(sd or gnss.noise_sd[c])
                                                    for c in POSITION},
                                **{c: gnss.channels[c] for c in POSITION}}}
    if velocity:
        aiding["gnss"] = {"t": gnss.t, "sd": {c: float(gnss.noise_sd.get(c) or 1e-3) for c in
                                              ("vn", "ve", "vd")},
                          **{c: gnss.channels[c] for c in ("vn", "ve", "vd")}}
    if baro:
        log = sim.log["baro"]
        aiding["baro"] = {"t": log.t, "altitude": log.channels["altitude"],
                          "sd": {"altitude": float(sd or log.noise_sd["altitude"])}}
    return make_flight({c: flight[c] for c in flight.channels} | {"t": flight.t},
                       flight.airframe, {**flight.metadata, "aiding": aiding})


@pytest.fixture(scope="module")
def clean():
    """Noise-free default suite (seed 3): raw IMU, true states, noise-free GNSS."""
    sim, flight = suite_flight(seed=3, accel_noise_mps2=0.0, gyro_noise_radps=0.0,
                               gnss_velocity_sd_mps=0.0, gnss_position_sd_m=0.0,
                               baro_altitude_sd_m=0.0)
    return sim, with_positions(sim, flight, sd=1e-2, velocity=True, baro=True)


def _true_point(est, model):
    p = np.zeros(model.scale.size)
    p[:N_COEFFICIENTS] = (reference_scenario().coefficient_vector
                          / model.scale[:N_COEFFICIENTS])
    return p, est.parameter_names(model.position_free)


def test_integrated_velocity_is_the_simulators_position(clean):
    sim, flight = clean
    est = OutputErrorEstimator(**BASE, aiding="gnss-velocity+gnss-position+baro-altitude")
    prob = est.problem(flight)
    model = prob.model
    p, names = _true_point(est, model)
    # the true initial rates (the fit starts from the raw, biased gyros'), so the model's
    # states are the simulator's to its integration error
    model.base.x0[[P, Q, R]] = [sim.truth[c][0] for c in ("p", "q", "r")]
    m = len(OUTPUT_CHANNELS)
    y = model.outputs(p)[:, m + 3:m + 6]
    s = model.samples[1]
    assert s.source == "gnss_position" and s.index.size == 11
    # the origin started at the first sample: the rest follow from the integral alone
    truth = np.column_stack([sim.truth[c] for c in POSITION])[s.index]
    assert np.max(np.abs(y[s.index] - truth)) < TRUTH_ATOL_M
    assert names[-4:] == (*ORIGIN_NAMES, "baro_h0_m")
    # the barometer: h0 - pd, h0 from its first sample (50 Hz: 51 samples)
    b = model.samples[2]
    assert b.source == "baro" and b.index.size == 51
    altitude = model.outputs(p)[b.index, m + 6]
    assert np.max(np.abs(altitude - sim.truth["altitude"][b.index])) < TRUTH_ATOL_M


def test_position_jacobian_equals_central_differences(clean):
    _, flight = clean
    est = OutputErrorEstimator(**BASE, aiding="gnss-velocity+gnss-position+baro-altitude",
                               estimate_skew="gnss")  # the GNSS's skew moves both sources
    model = est.problem(flight).model
    p, names = _true_point(est, model)
    for name, value in (("u0", 0.3), ("theta0", -1e-3), ("psi0", 2e-3), ("pe0_m", 4.0),
                        ("gnss_skew_s", 3.3), ("baro_h0_m", -2.0)):
        p[names.index(name)] = value
    _, J = model.outputs_jacobian(p)
    m = len(OUTPUT_CHANNELS)
    rows = np.union1d(model.samples[1].index, model.samples[2].index)
    cols = slice(m + 3, m + 7)  # the position's, the barometer's
    for i, name in enumerate(names):
        h = FD_STEP_SKEW if name == "gnss_skew_s" else FD_STEP
        step = np.zeros_like(p)
        step[i] = h
        fd = (model.outputs(p + step) - model.outputs(p - step))[:, cols] / (2 * h)
        exact = J[cols, :, i].T
        peak = max(np.max(np.abs(fd)), 1e-300)
        np.testing.assert_allclose(exact[rows], fd[rows], rtol=0, atol=FD_RTOL * peak,
                                   err_msg=name)
        rows_p = model.samples[1].index
        if name in ORIGIN_NAMES:
            np.testing.assert_array_equal(exact[rows_p, :3], np.eye(3)[ORIGIN_NAMES.index(name)]
                                          * np.ones((rows_p.size, 1)))


def test_fit_on_a_gnss_position_only_log():
    sim, flight = suite_flight(seed=1)
    fit = OutputErrorEstimator(**BASE, aiding="gnss-position").fit(
        with_positions(sim, flight), rng=0)
    assert fit.success, fit.message
    truth = reference_scenario().coefficient_vector
    assert np.max(np.abs(fit.theta - truth) / fit.stderr) < WITHIN_SE
    names = list(fit.info["parameter_names"])
    for c, name in zip(POSITION, ORIGIN_NAMES, strict=True):
        i = names.index(name)
        error = fit.info["parameters"][i] - sim.truth[c][0]
        assert abs(error) < WITHIN_SE * fit.info["parameter_stderr"][i], name
    assert set(fit.info["aiding"]["sources"]) == {"gnss_position"}
    assert "theta0" not in names  # position alone frees no initial angle
    assert set(POSITION) <= set(fit.info["fit_check"]["residual_rms"])


def test_fit_with_gnss_position_and_barometric_altitude():
    sim, flight = suite_flight(seed=1)
    fit = OutputErrorEstimator(**BASE, aiding="gnss-position+baro-altitude").fit(
        with_positions(sim, flight, baro=True), rng=0)
    assert fit.success, fit.message
    truth = reference_scenario().coefficient_vector
    assert np.max(np.abs(fit.theta - truth) / fit.stderr) < WITHIN_SE
    names = list(fit.info["parameter_names"])
    # h0 = altitude + pd (the GNSS origin's altitude); the simulator's barometer: no bias
    i = names.index("baro_h0_m")
    error = fit.info["parameters"][i] - (sim.truth["altitude"][0] + sim.truth["pd"][0])
    assert abs(error) < WITHIN_SE * fit.info["parameter_stderr"][i]
    assert "baro_altitude" in fit.info["fit_check"]["residual_rms"]


def test_position_refusals_are_one_line(clean):
    sim, flight = suite_flight(seed=1)
    with pytest.raises(Exception, match="gnss_position") as exc:
        OutputErrorEstimator(**BASE, aiding="gnss-position").problem(flight)
    assert "\n" not in str(exc.value)
    with pytest.raises(ValueError, match="needs the INS attitude"):
        OutputErrorEstimator(aiding="gnss-position", estimate_skew="ins")
    OutputErrorEstimator(aiding="gnss-position", estimate_skew="gnss")  # the GNSS's clock


def test_the_option_lists_what_the_check_accepts():
    hints = typing.get_type_hints(OutputErrorEstimator)
    assert typing.get_args(hints["aiding"]) == OE_AIDING
    for value in OE_AIDING:
        OutputErrorEstimator(aiding=value)  # each accepted
    with pytest.raises(ValueError, match="aiding must be one of"):
        OutputErrorEstimator(aiding="baro-altitude+gnss-position")  # not in the list's order
