"""Flight.validate plausibility: units through the kinematics, ranges, spikes, record length.

Every hostile input of issue 12 item 2 that the validator used to accept is refused
here with one line, and the reference flights (paper, Gaussian and no noise, several
seeds) pass with no problem and no warning (pytest turns warnings into errors).
"""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest

from aeroid.errors import AeroidWarning, FlightError
from aeroid.flights import (
    GaussianNoise,
    Manoeuvre,
    NoNoise,
    PaperNoise,
    make_flight,
    record_flight,
    simulate,
    simulate_truth,
)

#: Seeds of the reference flights that must validate silently.
SEEDS = range(5)
NOISES = [NoNoise(), PaperNoise(), PaperNoise(rates_xi=0.05, accelerations_xi=0.05),
          GaussianNoise(), GaussianNoise(accel_sd_mps2=0.5, rate_sd_radps=0.05),
          GaussianNoise(position_sd_m=0.001)]


def _changed(flight, **changes):
    """A copy of ``flight`` whose channels are replaced by ``changes`` (arrays)."""
    data = {c: flight[c] for c in flight.channels}
    data.update(changes)
    return make_flight(data, flight.airframe, {"source": "hostile.csv"})


def _error(flight) -> str:
    with pytest.raises(FlightError) as info:
        flight.validate()
    message = str(info.value)
    assert "\n" not in message and message.startswith("hostile.csv: ")
    return message


@pytest.fixture(scope="module")
def reference_truth(reference_scenario):
    """The reference truth, integrated once (each noisy flight only records it)."""
    s = reference_scenario
    return simulate_truth(s.airframe, s.coefficient_vector, s.manoeuvre)


@pytest.mark.parametrize("noise", NOISES, ids=lambda n: str(n.to_dict()))
def test_reference_flights_validate_without_problem_or_warning(reference_scenario,
                                                               reference_truth, noise):
    s = reference_scenario
    for seed in SEEDS:
        flight = record_flight(s.airframe, s.coefficient_vector, s.manoeuvre, reference_truth,
                               noise, rng=seed)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            assert flight.validate() is flight
        assert flight.check() == ([], [])


@pytest.mark.parametrize("window", [(0.0, 0.2), (0.5, 0.6), (2.0, 3.0), (0.0, 6.0)])
def test_other_windows_of_the_reference_validate_silently(reference_scenario, window):
    manoeuvre = Manoeuvre(window_s=window)
    for noise in (NoNoise(), PaperNoise()):
        flight = simulate(reference_scenario.airframe, reference_scenario.coefficient_vector,
                          manoeuvre, noise, rng=3)
        assert flight.check() == ([], [])


def test_rates_in_degrees_per_second(paper_flight):
    rates = {c: np.degrees(paper_flight[c]) for c in ("p", "q", "r")}
    message = _error(_changed(paper_flight, **rates))
    assert "the roll angle's derivative is 0.0175 x p + (q sin phi + r cos phi) tan theta " \
           "(eq. 8): rates in deg/s" in message
    assert "(eq. 9)" in message


def test_all_angles_in_degrees_with_alpha_below_one_degree(clean_flight):
    # a gentler flight: |alpha| < 1 deg, so even read as radians it stays under 60 deg
    v, w, u = 0.4 * clean_flight["v"], 0.4 * clean_flight["w"], clean_flight["u"]
    alpha, beta = np.arctan2(w, u), np.arcsin(v / np.sqrt(u * u + v * v + w * w))
    assert np.degrees(np.abs(alpha)).max() < 1.0
    angles = {c: np.degrees(clean_flight[c]) for c in ("phi", "theta", "psi", "delta")}
    only_air = _changed(clean_flight, v=v, w=w, alpha=np.degrees(alpha), beta=np.degrees(beta))
    message = _error(only_air)
    assert "alpha is 57.3 x atan(w/u) (eq. 15): alpha in degrees?" in message
    assert "beta is 57.3 x asin(v/V) (eq. 16)" in message
    every = _changed(clean_flight, v=v, w=w, alpha=np.degrees(alpha), beta=np.degrees(beta),
                     **angles)
    message = _error(every)
    assert "|theta| > 90 deg" in message and "delta in degrees?" in message


def test_roll_angle_in_degrees_sampled_fast(reference_scenario):
    # at 4 kHz phi in degrees steps 0.73 per sample and looks continuous (no wrap) and
    # theta and psi stay small: only eq. 8 can tell
    fast = Manoeuvre(sample_rate_hz=4000.0, window_s=(5.0, 5.1), truth_substeps=1)
    flight = simulate(reference_scenario.airframe, reference_scenario.coefficient_vector,
                      fast, PaperNoise(), rng=1)
    assert flight.check() == ([], [])
    message = _error(_changed(flight, phi=np.degrees(flight["phi"])))
    # 57.3 from the units, blurred by sin/cos of phi in degrees in the q, r terms
    assert re.search(r"derivative is 5[67]\.\d x p \+ \(q sin phi \+ r cos phi\) tan theta "
                     r"\(eq\. 8\): angles in degrees while rates are in rad/s\?", message)


def test_scale_error_is_a_warning_and_sign_flip_an_error(paper_flight):
    with pytest.warns(AeroidWarning, match=r"hostile.csv: the roll angle's derivative is "
                                           r"0.667 x .*check the gyro scale"):
        _changed(paper_flight, p=1.5 * paper_flight["p"]).validate()
    message = _error(_changed(paper_flight, p=-paper_flight["p"]))
    assert "is -1 x p" in message and "opposite signs" in message


def test_a_logged_alpha_off_the_inertial_one_names_moving_air_not_the_gyros(paper_flight):
    # a vane's alpha in turbulence came out 0.708 x atan(w/u) and was blamed on the gyro
    # scale; the gyros do not enter eq. 15
    with pytest.warns(AeroidWarning, match=r"hostile.csv: alpha is 0.7 x atan\(w/u\) "
                                           r"\(eq. 15\): a wind or turbulence") as seen:
        _changed(paper_flight, alpha=0.7 * paper_flight["alpha"]).validate()
    assert not any("gyro" in str(w.message) for w in seen)


def test_three_rows(paper_flight):
    short = make_flight({c: paper_flight[c][:3] for c in paper_flight.channels},
                        paper_flight.airframe, {"source": "hostile.csv"})
    assert "too few samples (3; need at least 40" in _error(short)


def test_spike(paper_flight):
    ax1 = paper_flight["ax1"]
    ax1[250] = 1e300
    assert "column 'ax1' has 1 spike(s), first at row 250 (1e+300" in _error(
        _changed(paper_flight, ax1=ax1))


@pytest.mark.parametrize(("factor", "fragment"), [
    (-1.0, "u <= 0 at row 0 (flying backwards?"),
    (6e5, "airspeed above 3000 m/s at row 0 (3.02e+08 m/s)"),
])
def test_negative_or_relativistic_speed(paper_flight, factor, fragment):
    # alpha and beta as logged: only the speed is wrong
    flight = _changed(paper_flight, **{c: factor * paper_flight[c] for c in ("u", "v", "w")})
    assert fragment in _error(flight)


@pytest.mark.parametrize("dt", [1e-12, 1e6])
def test_sample_interval_out_of_range(paper_flight, dt):
    t = 5.0 * (dt > 1) + dt * np.arange(paper_flight.n_samples)
    assert f"sample interval {dt:.3g} s is outside" in _error(_changed(paper_flight, t=t))


def test_wrapped_roll_angle(paper_flight):
    phi = (paper_flight["phi"] + math.pi) % (2 * math.pi) - math.pi
    assert "phi jumps by -6.18 rad at row 15 (wrapped to +-180 deg?" in _error(
        _changed(paper_flight, phi=phi))


def test_fin_deflection_in_degrees_or_overshooting(paper_flight):
    delta = paper_flight["delta"]
    assert "delta in degrees?" in _error(_changed(paper_flight, delta=np.degrees(delta)))
    with pytest.warns(AeroidWarning, match=r"\|delta\| reaches 0.1815 rad, 1.3x"):
        _changed(paper_flight, delta=1.3 * delta).validate()


@pytest.mark.parametrize(("channel", "value", "message"), [
    ("mass", -1.0, "channel 'mass' must be positive"),
    ("ix", 0.0, "channel 'ix' must be positive"),
    ("thrust", -5.0, "channel 'thrust' must be >= 0"),
    ("altitude", 30000.0, "channel 'altitude' outside the ISA model"),
])
def test_per_sample_inputs_are_range_checked(paper_flight, channel, value, message):
    flight = _changed(paper_flight, **{channel: np.full(paper_flight.n_samples, value)})
    if channel == "altitude":
        flight = make_flight({c: flight[c] for c in flight.channels},
                             flight.airframe.replace(altitude_m=None,
                                                     atmosphere_channel="altitude"),
                             {"source": "hostile.csv"})
    assert message in _error(flight)


def test_an_atmosphere_channel_is_used_or_refused(paper_flight):
    # per_sample names a channel the flight lacks: refused
    airframe = paper_flight.airframe.replace(altitude_m=None, atmosphere_channel="rho")
    flight = make_flight({c: paper_flight[c] for c in paper_flight.channels}, airframe,
                         {"source": "hostile.csv"})
    message = _error(flight)
    assert "[atmosphere] per_sample = 'rho' but the flight has no 'rho' channel" in message
    # a density channel while the airframe states one atmosphere: refused, not ignored
    flight = _changed(paper_flight, rho=np.full(paper_flight.n_samples, 0.41))
    assert "channel(s) rho given while the airframe states one atmosphere" in _error(flight)
