"""Output-error's initial attitude under the reconstruction's prior (``attitude_prior``,
baselines/_oe_attitude.py): the sensitivities against central differences, the prior's
weight, one-line refusals, and the default left exactly as it was."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import aeroid
from aeroid.flights import GaussianNoise, reference_scenario, simulate_scenario
from baselines.output_error import OutputErrorEstimator

#: Central differences (step 1e-6 of the scaled parameter) against the exact Jacobian, as
#: tests/unit/test_output_error_imu_errors.py's check of the other parameters.
FD_RTOL = 1e-5
#: The reconstruction's stated sd used on the test flights [m/s, rad].
STATE_SD = {"u": 0.1, "v": 0.1, "w": 0.2, "phi": 0.003, "theta": 0.001, "psi": 0.002}


def _with_sd(flight, sd=STATE_SD):
    return dataclasses.replace(flight, metadata={**flight.metadata, "initial_state_sd": sd})


@pytest.fixture(scope="module")
def reference_flight():
    noise = GaussianNoise(accel_sd_mps2=0.5, rate_sd_radps=0.02, position_sd_m=0.0)
    return _with_sd(simulate_scenario(reference_scenario(), noise, rng=4))


def test_jacobian_of_the_initial_attitude_equals_finite_differences(reference_flight):
    est = OutputErrorEstimator(attitude_prior="flight", imu_errors="bias",
                               estimate_initial_velocity=True, compile_model=False)
    prob = est.problem(reference_flight)
    names = est.parameter_names(prob.model.position_free)
    assert "phi0" in names and "theta0" in names and "psi0" not in names
    rng = np.random.default_rng(2)
    p = np.ones(prob.model.scale.size)
    n_c = aeroid.model.N_COEFFICIENTS
    p[:n_c] += 0.05 * rng.standard_normal(n_c)
    p[n_c:] = 0.5 * rng.standard_normal(p.size - n_c)
    p[[names.index("phi0"), names.index("theta0")]] = [0.01, -0.02]  # [rad]: scale 1
    _, J = prob.residuals_jacobian(p)
    assert J.shape[-1] == len(names)
    for name in ("phi0", "theta0", "Cx", "u0"):
        i = names.index(name)
        h = 1e-6
        dp = np.zeros_like(p)
        dp[i] = h
        fd = -(prob.residuals(p + dp) - prob.residuals(p - dp)).T / (2 * h)
        assert np.abs(fd).max() > 0, name  # the angle moves the outputs
        np.testing.assert_allclose(J[:, :, i], fd, rtol=0, atol=FD_RTOL * np.abs(fd).max(),
                                   err_msg=name)


def test_the_prior_weight_is_one_over_the_stated_variance(reference_flight):
    est = OutputErrorEstimator(attitude_prior="flight", estimate_initial_velocity=True,
                               initial_velocity_prior="flight", compile_model=False)
    prob = est.problem(reference_flight)
    names = est.parameter_names(prob.model.position_free)
    for j, name in enumerate(names):
        key = name[:-1]
        expected = (1.0 / STATE_SD[key] ** 2 if name in ("u0", "v0", "w0", "phi0", "theta0")
                    else 0.0)
        weight = prob.prior_weight[j] / prob.model.scale[j] ** 2
        assert weight == pytest.approx(expected, rel=1e-12), name


def test_a_flight_without_the_attitude_sd_is_refused_in_one_line(reference_flight):
    est = OutputErrorEstimator(attitude_prior="flight", compile_model=False)
    for sd in (None, {"u": 0.1, "v": 0.1, "w": 0.1}, {**STATE_SD, "theta": 0.0},
               {**STATE_SD, "phi": "x"}):
        flight = dataclasses.replace(reference_flight, metadata={
            k: v for k, v in reference_flight.metadata.items() if k != "initial_state_sd"})
        if sd is not None:
            flight = _with_sd(flight, sd)
        with pytest.raises(aeroid.FlightError, match="attitude_prior = flight needs metadata "
                           "initial_state_sd with positive phi, theta") as info:
            est.problem(flight)
        assert "\n" not in str(info.value)


def test_bad_options_are_refused(capsys):
    with pytest.raises(ValueError, match="attitude_prior must be one of none, flight"):
        OutputErrorEstimator(attitude_prior="ins")
    with pytest.raises(ValueError, match="attitude_prior = flight with estimate_wind is not"):
        OutputErrorEstimator(attitude_prior="flight", estimate_wind=True)
    with pytest.raises(aeroid.EstimatorError):
        aeroid.make_estimator("output-error", {"attitude_prior": "yes"})
    from aeroid.cli import main

    assert main(["methods", "--options", "output-error"]) == 0
    assert "attitude_prior" in capsys.readouterr().out


def test_off_by_default_and_the_default_is_the_fit_without_the_option(reference_flight):
    default, off = OutputErrorEstimator(), OutputErrorEstimator(attitude_prior="none")
    assert default.attitude_prior == "none" and default.x0_free() == (3, 4, 5)
    assert default.parameter_names() == off.parameter_names()
    assert not any(n in default.parameter_names() for n in ("phi0", "theta0", "psi0"))
    a, b = default.fit(reference_flight, rng=0), off.fit(reference_flight, rng=0)
    np.testing.assert_array_equal(a.theta, b.theta)
    np.testing.assert_array_equal(a.stderr, b.stderr)
    assert "attitude_offset_rad" not in a.info
    assert not any("attitude_prior" in w for w in a.warnings)


def test_the_ins_attitude_aiding_and_the_prior_free_each_angle_once():
    est = OutputErrorEstimator(attitude_prior="flight", aiding="gnss-velocity+ins-attitude")
    assert est.x0_free() == (3, 4, 5, 6, 7, 8)
    names = est.parameter_names()
    assert names.count("phi0") == 1 and names.count("theta0") == 1


#: The rocket coast's logged attitude off by a known constant (the whole record) [rad].
PHI_OFFSET, THETA_OFFSET = 0.02, 0.01
#: The prior's sd on that flight [rad]: wide, so that the data, not the prior, find the
#: offset (measured posterior sd: phi 3.2e-3, theta 1.5e-4).
WIDE_SD = 0.05


@pytest.fixture(scope="module")
def coast():
    """studies/scenarios/rocket_coast.toml (15 s, 100 Hz) with Gaussian IMU noise."""
    from pathlib import Path

    from aeroid.flights import load_scenario

    root = Path(__file__).resolve().parents[2]
    scenario = load_scenario(root / "studies" / "scenarios" / "rocket_coast.toml")
    noise = GaussianNoise(accel_sd_mps2=0.05, rate_sd_radps=0.003, position_sd_m=0.0)
    return scenario, simulate_scenario(scenario, noise, rng=3)


@pytest.fixture(scope="module")
def offset_coast(coast):
    """The coast, its logged phi and theta off by PHI_OFFSET and THETA_OFFSET over the
    whole record, the prior's sd WIDE_SD."""
    scenario, flight = coast
    data = flight.data.copy()
    data["phi"] += PHI_OFFSET
    data["theta"] += THETA_OFFSET
    sd = {**STATE_SD, "phi": WIDE_SD, "theta": WIDE_SD}
    return scenario, _with_sd(dataclasses.replace(flight, data=data), sd)


def test_a_known_attitude_offset_is_recovered_and_the_coefficients_with_it(offset_coast):
    """Measured: offsets -0.0158 +- 0.0032 (phi, 1.3 se) and -0.009985 +- 0.000155 (theta,
    0.1 se); every coefficient within 0.7 se."""
    scenario, flight = offset_coast
    res = OutputErrorEstimator(attitude_prior="flight").fit(flight, rng=0)
    assert res.success, res.message
    offset, se = res.info["attitude_offset_rad"], res.info["attitude_offset_stderr_rad"]
    assert abs(offset["phi"] + PHI_OFFSET) < 3 * se["phi"]
    assert abs(offset["theta"] + THETA_OFFSET) < 3 * se["theta"]
    assert se["theta"] < WIDE_SD / 10 and se["phi"] < WIDE_SD / 10  # the data found them
    assert res.info["attitude_prior_sd_rad"] == {"phi": WIDE_SD, "theta": WIDE_SD}
    free = res.stderr > 0  # the fin terms are held (passive fin)
    truth = np.asarray(scenario.coefficient_vector)
    z = np.abs(res.theta - truth)[free] / res.stderr[free]
    assert np.all(z < 3), dict(zip(np.asarray(res.names)[free], z, strict=True))
    assert any(w.startswith("attitude_prior = flight: the initial roll and pitch")
               for w in res.warnings)


def test_the_same_offset_taken_as_measured_is_not_a_success(offset_coast):
    """The known-wrong input: without the option the fit is refused (measured: the
    whiteness verdict, residual RMS 1.76x the noise) and Cx is 32 se off."""
    _, flight = offset_coast
    res = OutputErrorEstimator().fit(flight, rng=0)
    assert not res.success


def test_the_attitudes_share_reaches_the_coefficients_standard_errors(coast):
    """The right attitude with the stated sd (phi 3 mrad, theta 1 mrad): every standard
    error at least the one with the attitude taken as exact; Cx's 1.38x (measured 4.42e-5
    against 3.21e-5: the pitch angle's gravity component trades with the axial force)."""
    _, flight = coast
    flight = _with_sd(flight)
    off = OutputErrorEstimator().fit(flight, rng=0)
    on = OutputErrorEstimator(attitude_prior="flight").fit(flight, rng=0)
    assert off.success and on.success
    free = off.stderr > 0
    # 1e-3: the two fits' optima differ by a fraction of a standard error, so their
    # information does too
    assert np.all(on.stderr[free] >= off.stderr[free] * (1 - 1e-3))
    i = list(on.names).index("Cx")
    assert on.stderr[i] > 1.2 * off.stderr[i]
    assert on.info["attitude_offset_stderr_rad"]["theta"] < STATE_SD["theta"]
