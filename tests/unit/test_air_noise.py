"""The noise models' air-data channels: vane noise on alpha, beta and a noisy airspeed.

References: the air-relative angles and speed written here from the simulator's clean
``u, v, w`` and attitude and the scenario's steady wind (a 3-2-1 rotation written in this
file, eqs. 14-16 as ``atan2``/``arcsin``), against which the logged channels' noise is
measured and its sd compared with the stated one (a chi-square bound); the IMU channels
of the same seed without air noise (identity: the air noise is drawn last).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import stats

from aeroid.errors import AirframeError
from aeroid.flights import GaussianNoise, Wind, make_noise, noise_from_dict, simulate

VANE_SD_RAD = np.radians(0.1)
BETA_SD_RAD = np.radians(0.2)
AIRSPEED_SD_MPS = 0.5
WIND_NED = (3.0, 4.0, -0.5)
#: Two-sided probability of a correct sd falling outside the chi-square band (per check).
BAND_P = 1e-6


def _sd_band(n: int, sd: float) -> tuple[float, float]:
    """The chi-square band of the sample sd (known mean 0) of ``n`` Gaussian draws."""
    lo, hi = stats.chi2.ppf([BAND_P / 2, 1 - BAND_P / 2], n)
    return sd * np.sqrt(lo / n), sd * np.sqrt(hi / n)


def _body(phi, theta, psi, ned):
    """NED vector(s) in body axes, 3-2-1 Euler rotation written out (not the model's)."""
    cf, sf, ct, st, cp, sp = (np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta),
                              np.cos(psi), np.sin(psi))
    n, e, d = ned
    x = ct * cp * n + ct * sp * e - st * d
    y = (sf * st * cp - cf * sp) * n + (sf * st * sp + cf * cp) * e + sf * ct * d
    z = (cf * st * cp + sf * sp) * n + (cf * st * sp - sf * cp) * e + cf * ct * d
    return x, y, z


@pytest.fixture(scope="module")
def noisy_pair(reference_scenario):
    s = reference_scenario
    windy = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND_NED))
    air = GaussianNoise(alpha_sd_rad=VANE_SD_RAD, beta_sd_rad=BETA_SD_RAD,
                        airspeed_sd_mps=AIRSPEED_SD_MPS)
    return (simulate(s.airframe, s.coefficient_vector, windy, air, rng=5),
            simulate(s.airframe, s.coefficient_vector, windy, GaussianNoise(), rng=5))


def test_air_channels_carry_the_stated_noise(noisy_pair) -> None:
    f, _ = noisy_pair
    wx, wy, wz = _body(f["phi"], f["theta"], f["psi"], WIND_NED)
    u, v, w = f["u"] - wx, f["v"] - wy, f["w"] - wz  # the states are clean
    speed = np.sqrt(u * u + v * v + w * w)
    for error, sd in ((f["alpha"] - np.arctan2(w, u), VANE_SD_RAD),
                      (f["beta"] - np.arcsin(v / speed), BETA_SD_RAD),
                      (f["airspeed"] - speed, AIRSPEED_SD_MPS)):
        lo, hi = _sd_band(error.size, sd)
        measured = float(np.sqrt(np.mean(error**2)))
        assert lo < measured < hi
        assert abs(np.mean(error)) < 5 * sd / np.sqrt(error.size)
    # alpha's and beta's noise independent: |r| below 5 / sqrt(n)
    a = f["alpha"] - np.arctan2(w, u)
    b = f["beta"] - np.arcsin(v / speed)
    assert abs(np.corrcoef(a, b)[0, 1]) < 5 / np.sqrt(a.size)


def test_air_noise_is_drawn_last(noisy_pair) -> None:
    noisy, plain = noisy_pair
    assert "airspeed" in noisy.channels and "airspeed" not in plain.channels
    for c in plain.channels:
        if c not in ("alpha", "beta"):
            np.testing.assert_array_equal(noisy[c], plain[c], err_msg=c)
    np.testing.assert_array_equal(noisy.airframe.accel_positions, plain.airframe.accel_positions)


def test_corrupt_air_on_a_large_sample() -> None:
    n = 200_000
    rng = np.random.default_rng(1)
    u, v, w = 500 + rng.normal(0, 5, n), rng.normal(0, 5, n), rng.normal(0, 5, n)
    model = GaussianNoise(alpha_sd_rad=VANE_SD_RAD, beta_sd_rad=0.0, airspeed_sd_mps=0.0)
    out = model.corrupt_air({}, (u, v, w), np.random.default_rng(2))
    assert "airspeed" not in out  # sd 0: no airspeed channel
    np.testing.assert_allclose(out["beta"], np.arcsin(v / np.sqrt(u * u + v * v + w * w)),
                               rtol=0, atol=1e-15)
    lo, hi = _sd_band(n, VANE_SD_RAD)
    assert lo < np.std(out["alpha"] - np.arctan2(w, u)) < hi


def test_default_is_no_air_data(reference_scenario) -> None:
    s = reference_scenario
    f = simulate(s.airframe, s.coefficient_vector, s.manoeuvre, make_noise("gaussian"), rng=1)
    assert "airspeed" not in f.channels
    np.testing.assert_allclose(f["alpha"], np.arctan2(f["w"], f["u"]), rtol=0, atol=1e-15)
    assert set(f.metadata["noise"]) == {"model", "accel_sd_mps2", "rate_sd_radps",
                                        "position_sd_m"}
    assert not GaussianNoise().logs_air_data


def test_settings_round_trip_and_bad_values() -> None:
    model = make_noise("gaussian", alpha_sd_rad=0.001, airspeed_sd_mps=0.3)
    assert noise_from_dict(model.to_dict()) == model
    with pytest.raises(AirframeError, match="airspeed_sd_mps must be a finite number >= 0"):
        make_noise("gaussian", airspeed_sd_mps=-1.0)
    with pytest.raises(AirframeError, match="unknown option"):
        make_noise("paper", alpha_sd_rad=0.001)  # eq. 43 has no air data


def test_the_turbulence_air_study_draws_the_probe() -> None:
    from pathlib import Path

    from aeroid.study import _runner as study_runner
    from aeroid.study import load_study

    study = load_study(Path(__file__).resolve().parents[2] / "studies" / "turbulence_air.toml")
    probe, vanes = (c.model for c in study.noise)
    assert probe.airspeed_sd_mps == 0.5 and vanes.airspeed_sd_mps == 0.0
    assert probe.alpha_sd_rad == probe.beta_sd_rad == pytest.approx(np.radians(0.1))
    f = study_runner.simulate_run(study, 0, 0)
    assert "airspeed" in f.channels
    assert "airspeed" not in study_runner.simulate_run(study, 0, 1).channels
