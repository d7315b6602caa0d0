"""JSBSim flights in a steady wind and in its Dryden turbulence (issue 26, cross-engine).

The cross-engine climb (``FlightConfig()``) flown by JSBSim with a steady wind of 5 m/s
(3 north, along the path's heading; 4 east, across it) and, for the turbulent flight,
JSBSim's MIL-F-8785C Dryden turbulence (``atmosphere/turb-type`` Milspec, severity 4
"moderate": 9.8-10 ft/s, about 3.0 m/s, at the flight's 8500-9400 ft; scale length
1750 ft). JSBSim's filters start at zero at t = 0, so over the 0.3-1.3 s window the
gusts have not reached their stationary level: their sd over the window is 1.0-1.9 m/s
per NED component on seed 1, 0.7-2.8 m/s over seeds 1-5. The damping terms see the body
rates (``FlightConfig.rotational_gusts``: JSBSim's rotational gusts for a 0.152 m span
at 16 kHz are 0.5 rad/s RMS white noise, a frame-rate artefact aeroid's model does not
have). The logged ``alpha``, ``beta`` are JSBSim's air-relative angles (a vane's).

Measured (``python -m tests.crossengine.wind_measure``, seeds 1-5; the tests fly seed
1; Gaussian IMU, the JSBSim per-sample density and relay switch instants as
:mod:`.test_recovery` gives them):

* output-error with ``estimate_wind`` in the steady wind: 5/5 successes, every
  coefficient within 1.22 of its standard error (0.07-1.22), the wind within 1.08 se
  (seed 1: (1.87 +- 1.20, 4.02 +- 0.02, 0.70 +- 0.73) m/s against (3, 4, 0)); mean
  |error| 0.29 % against the still-air fit's 0.012-0.035 % (mean 0.022 %) on the same
  climb, 13x: the along-path wind trades with every coefficient (their correlations
  0.98-0.9998), so the issue's <= 1.2x is not met here either. Without the wind:
  refused 5/5 (``az2`` 35-38x its noise).
* equation-error with the logged angles (0.1 deg vane noise) in the turbulence: mean
  |error| 1.19-2.33 % (mean 1.75 %) against its still-air 0.048-0.084 % on the same
  climb: 15-49x, **not** the issue's <= 2x; with the inertial angles 15.8-22.9 %
  (6.8-14x the measured angles' error). The fit check refuses all ten fits (the roll
  moment's residual 12-42x its noise: the along-path gusts change the dynamic pressure,
  which the angles do not see). Its still-air fit is refused too (6.1-6.5x, the
  roll-derivative smoothing window, :mod:`.test_recovery`), so the ratio's yardstick is
  itself a flagged fit.
* output-error in the turbulence: refused 5/5 (``q`` / ``r`` residual 11.7-17.8x); with
  ``estimate_wind`` it does not converge in 50 iterations on 4/5 and is refused by the
  fit check on the fifth, its along-path wind -73 to +45 m/s.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import aeroid
from aeroid.errors import AeroidWarning
from aeroid.flights import GaussianNoise

from .jsbsim_flight import FlightConfig, make_flight
from .test_recovery import issue10_flight

jsbsim = pytest.importorskip("jsbsim", reason="the cross-engine tests need JSBSim")

#: The steady wind, NED [m/s]: 3 along the initial heading (north), 4 across it.
WIND_NED_MPS = (3.0, 4.0, 0.0)
WINDY = dataclasses.replace(FlightConfig(), name="xe_wind", wind_ned_mps=WIND_NED_MPS)
#: JSBSim's Milspec severity 4 ("moderate", probability of exceedance 1e-3).
MODERATE = 4
TURBULENT = dataclasses.replace(WINDY, name="xe_turb", turbulence_severity=MODERATE,
                                random_seed=1)
#: A vane's white noise on the logged alpha and beta [rad] (issue 26: 0.1 deg).
VANE_SD_RAD = np.radians(0.1)
NOISE_SEED = 1
#: Issue 26's verdict: every coefficient and wind component within 3 of its own se.
SE_BOUND = 3.0
#: The measured angles must beat the inertial ones by this factor at least (measured on
#: seeds 1-5: 6.8-14x); the issue's 2x-of-still-air target is not met (docstring).
AIR_DATA_GAIN = 5.0
#: JSBSim's and aeroid's angles from the same velocities and wind: double rounding of a
#: state in ft/s (1e-12 relative) through atan2.
ANGLE_TOL_RAD = 1e-9


def _error_pct(theta, truth) -> np.ndarray:
    return np.abs(np.asarray(theta) / truth.coefficients - 1.0) * 100.0


def _with_vane_noise(flight, rng: np.random.Generator):
    n = flight.n_samples
    data = flight.data.assign(alpha=flight["alpha"] + VANE_SD_RAD * rng.standard_normal(n),
                              beta=flight["beta"] + VANE_SD_RAD * rng.standard_normal(n))
    return dataclasses.replace(flight, data=data)


def _fit(name: str, flight, options: dict):
    with warnings.catch_warnings():
        # the logged (air-relative) beta differs from asin(v/V): the flight's unit check
        # says so, as it should for a vane in wind; the fit is what these tests judge
        warnings.filterwarnings("ignore", message=r".*beta is .* x asin", category=AeroidWarning)
        return aeroid.make_estimator(name, options).fit(flight, rng=1)


@pytest.fixture(scope="module")
def windy():
    flight, truth = make_flight(WINDY, noise=GaussianNoise(), rng=NOISE_SEED)
    return issue10_flight(flight, truth, events=True), truth


@pytest.fixture(scope="module")
def turbulent():
    flight, truth = make_flight(TURBULENT, noise=GaussianNoise(), rng=NOISE_SEED)
    flight = issue10_flight(flight, truth, events=True)
    return _with_vane_noise(flight, np.random.default_rng([NOISE_SEED, 26])), truth


def _ned_to_body(phi, theta, psi, ned):
    """The 3-2-1 rotation of NED vectors into body axes, row by row (written here)."""
    cf, sf, ct, st, cp, sp = (np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta),
                              np.cos(psi), np.sin(psi))
    n, e, d = ned.T
    x = ct * cp * n + ct * sp * e - st * d
    y = (sf * st * cp - cf * sp) * n + (sf * st * sp + cf * cp) * e + sf * ct * d
    z = (cf * st * cp + sf * sp) * n + (cf * st * sp - sf * cp) * e + cf * ct * d
    return np.stack([x, y, z], axis=1)


@pytest.mark.parametrize("config", [WINDY, TURBULENT], ids=["wind", "turbulence"])
def test_the_logged_angles_are_the_air_relative_ones(config):
    """JSBSim's alpha, beta equal the body velocity minus its logged total wind, rotated
    by the logged attitude (aeroid's convention: the air's velocity over the ground)."""
    _, truth = make_flight(config)
    d = truth.data
    wind = _ned_to_body(d["phi"].to_numpy(), d["theta"].to_numpy(), d["psi"].to_numpy(),
                        d[["wind_n", "wind_e", "wind_d"]].to_numpy())
    air = d[["u", "v", "w"]].to_numpy() - wind
    alpha = np.arctan2(air[:, 2], air[:, 0])
    beta = np.arcsin(air[:, 1] / np.linalg.norm(air, axis=1))
    np.testing.assert_allclose(d["alpha"], alpha, rtol=0, atol=ANGLE_TOL_RAD)
    np.testing.assert_allclose(d["beta"], beta, rtol=0, atol=ANGLE_TOL_RAD)
    np.testing.assert_allclose(d["airspeed"], np.linalg.norm(air, axis=1), rtol=1e-9)
    inertial = np.arctan2(d["w"], d["u"])
    assert np.sqrt(np.mean((alpha - inertial) ** 2)) > 1e-3  # the wind moved them
    steady = d[["wind_n", "wind_e", "wind_d"]].to_numpy() - np.array(WIND_NED_MPS)
    if config.turbulence_severity:
        assert np.all(np.std(steady, axis=0) > 0.5)  # gusts of the order of m/s
    else:
        np.testing.assert_allclose(steady, 0.0, atol=1e-12)


def test_still_air_output_error_is_refused_in_the_wind(windy):
    flight, _ = windy
    result = _fit("output-error", flight, {"input": "events", "estimate_wind": False})
    assert not result.success
    assert "does not fit the data" in result.message


def test_auto_estimates_the_wind_of_a_log_that_does_not_say_still_air(windy):
    """The default (``estimate_wind = auto``) on a JSBSim log whose metadata says nothing
    of its air (vanes, no airspeed): the wind estimated, and said; every coefficient and
    wind component within 3 se (as ``estimate_wind = true``, measured)."""
    flight, truth = windy
    assert "wind" not in flight.metadata
    result = _fit("output-error", flight, {"input": "events"})
    assert result.success, result.message
    assert result.info["estimate_wind"]["used"] is True
    assert result.warnings[0].startswith("output-error: estimate_wind: on (auto): the log "
                                         "does not say the air was still (no metadata "
                                         "wind; its air data lack an airspeed")
    z = np.abs(result.theta - truth.coefficients) / result.stderr
    assert np.all(z <= SE_BOUND), z
    wind = np.asarray(result.info["wind_ned_mps"])
    wind_se = np.asarray(result.info["wind_stderr_mps"])
    assert np.all(np.abs(wind - np.array(WIND_NED_MPS)) <= SE_BOUND * wind_se), (wind, wind_se)


def test_output_error_estimates_the_steady_wind(windy):
    """Measured: every coefficient within 1.22 se, the wind within 0.95 se."""
    flight, truth = windy
    result = _fit("output-error", flight, {"input": "events", "estimate_wind": True})
    assert result.success, result.message
    z = np.abs(result.theta - truth.coefficients) / result.stderr
    assert np.all(z <= SE_BOUND), z
    wind = np.asarray(result.info["wind_ned_mps"])
    wind_se = np.asarray(result.info["wind_stderr_mps"])
    assert np.all(np.abs(wind - np.array(WIND_NED_MPS)) <= SE_BOUND * wind_se), (wind, wind_se)


def test_equation_error_with_air_data_in_turbulence(turbulent):
    """The logged angles mend most of what the inertial ones miss, but not the airspeed:
    the fit check refuses the measured-angle fit (docstring: 22x still air)."""
    flight, truth = turbulent
    measured = _fit("equation-error", flight, {"air_data": "measured"})
    inertial = _fit("equation-error", flight, {"air_data": "inertial"})
    assert measured.info["air_data"] == "measured"
    measured_err = np.mean(_error_pct(measured.theta, truth))
    inertial_err = np.mean(_error_pct(inertial.theta, truth))
    assert measured_err * AIR_DATA_GAIN < inertial_err, (measured_err, inertial_err)
    assert not inertial.success and "does not fit the data" in inertial.message
    # refused: by the fit check (the 0.1 s window's roll moment) or, with equation-error's
    # Kalman-smoothed wind (which the fit check passed here), as turbulence without an
    # airspeed channel (baselines/_ee_air.py: the along-path gusts unseen)
    assert not measured.success and ("does not fit the data" in measured.message
                                     or "no airspeed channel" in measured.message)


@pytest.mark.parametrize("estimate_wind", [False, True], ids=["still-air", "estimate_wind"])
def test_output_error_is_flagged_in_turbulence(turbulent, estimate_wind):
    """Measured: refused by the fit check without the wind (``r`` 16.8x its noise); with
    a steady wind estimated it does not converge (50 iterations; on 1 of 5 seeds the fit
    check refuses it instead): a steady wind cannot explain the gusts either way."""
    flight, _ = turbulent
    result = _fit("output-error", flight, {"input": "events", "estimate_wind": estimate_wind})
    assert not result.success
    verdicts = ("does not fit the data", "max_iterations") if estimate_wind else (
        "does not fit the data",)
    assert any(v in result.message for v in verdicts), result.message
