"""Per-sample input channels checked before a fit (issue 21): ranges, airframe, kinematics.

Each hostile case of the issue (a mass in grams; 35 kg where the airframe says 70 kg; a
thrust of 0 where it says 740 N; 1e12 N; an altitude in feet on a 5 km flight) gives one
line naming the channel, and the same line stops output-error, equation-error and the
EKF before they run (the check is in ``Estimator.fit``'s ``Flight.validate``). Channels
that agree with the airframe and the kinematics give nothing (pytest turns warnings into
errors).
"""

from __future__ import annotations

import numpy as np
import pytest
from test_flight_checks import _error  # one line, naming the log

from aeroid.errors import AeroidWarning, FlightError
from aeroid.estimation import make_estimator
from aeroid.flights import make_flight

#: One foot [m] (international foot, exact).
FOOT_M = 0.3048
#: The estimators the issue names; the check runs before any of them.
ESTIMATORS = ("output-error", "equation-error", "ekf")


def _with(flight, airframe=None, **channels):
    data = {c: flight[c] for c in flight.channels}
    data.update({k: np.broadcast_to(np.asarray(v, dtype=float), (flight.n_samples,)).copy()
                 for k, v in channels.items()})
    return make_flight(data, airframe or flight.airframe, {"source": "hostile.csv"})


def _climb(flight) -> np.ndarray:
    """The altitude [m] integrated (trapezoids) from the vertical speed, 5000 m at the start.

    The vertical speed is the body velocity turned to the vertical by the attitude, written
    independently of the checker: the third row of the body-to-NED rotation, negated.
    """
    u, v, w = flight["u"], flight["v"], flight["w"]
    phi, theta = flight["phi"], flight["theta"]
    down = (-np.sin(theta) * u + np.cos(theta) * np.sin(phi) * v
            + np.cos(theta) * np.cos(phi) * w)
    steps = 0.5 * (down[1:] + down[:-1]) * np.diff(flight.t)
    return 5000.0 - np.concatenate([[0.0], np.cumsum(steps)])


def _altitude_airframe(flight):
    return flight.airframe.replace(altitude_m=None, atmosphere_channel="altitude")


def test_the_airframe_values_as_channels_and_a_true_altitude_give_nothing(paper_flight,
                                                                         clean_flight):
    a = paper_flight.airframe
    same = _with(paper_flight, mass=a.mass_kg, thrust=a.thrust_n, ix=a.ix_kgm2,
                 iy=a.iy_kgm2, iz=a.iz_kgm2)
    assert same.check() == ([], [])
    burning = _with(paper_flight, mass=np.linspace(a.mass_kg, 0.95 * a.mass_kg,
                                                   paper_flight.n_samples))
    assert burning.check() == ([], [])  # a 5 % burn over the window is no news
    for flight in (clean_flight, paper_flight):
        climbing = _with(flight, _altitude_airframe(flight), altitude=_climb(flight))
        assert climbing.check() == ([], [])
    rho = paper_flight.airframe.replace(altitude_m=None, atmosphere_channel="rho")
    assert _with(paper_flight, rho, rho=0.4127).check() == ([], [])
    qbar = paper_flight.airframe.replace(altitude_m=None, atmosphere_channel="qbar")
    speed2 = paper_flight["u"] ** 2 + paper_flight["v"] ** 2 + paper_flight["w"] ** 2
    assert _with(paper_flight, qbar, qbar=0.5 * 0.4127 * speed2).check() == ([], [])


def test_mass_in_grams_is_an_error_naming_grams(paper_flight):
    message = _error(_with(paper_flight, mass=70_000.0))
    assert ("channel 'mass' (median 7e+04 kg) against the airframe's mass_kg = 70 kg: "
            "1e+03x (mass in grams?)") in message


def test_half_the_airframe_mass_is_a_warning_naming_both(paper_flight):
    with pytest.warns(AeroidWarning, match=r"hostile.csv: channel 'mass' \(median 35 kg\) "
                      r"against the airframe's mass_kg = 70 kg: 0.5x, more than 10% off"):
        _with(paper_flight, mass=35.0).validate()
    with pytest.warns(AeroidWarning, match=r"median 154.3 kg.*2.2x.*\(mass in pounds\?\)"):
        _with(paper_flight, mass=70.0 / 0.45359237).validate()


def test_zero_thrust_against_740_newtons_is_a_warning(paper_flight):
    with pytest.warns(AeroidWarning, match=r"channel 'thrust' \(median 0 N\) against the "
                      r"airframe's thrust_N = 740 N: the channel says there is no thrust"):
        _with(paper_flight, thrust=0.0).validate()


@pytest.mark.parametrize(("value", "fragment"), [
    (1e12, "channel 'thrust' reaches 1e+12, outside the plausible 0 to 1e+08 N"),
    (0.74, "0.001x (thrust in kN?)"),
])
def test_implausible_thrust_is_an_error(paper_flight, value, fragment):
    assert fragment in _error(_with(paper_flight, thrust=value))


def test_inertia_in_grams_square_metre(paper_flight):
    assert "'ix' (median 180 kg m^2) against the airframe's Ix_kgm2 = 0.18 kg m^2: 1e+03x " \
           "(ix in g m^2?)" in _error(_with(paper_flight, ix=180.0))


def test_altitude_in_feet_on_a_5_km_flight(paper_flight):
    feet = _climb(paper_flight) / FOOT_M
    assert 16_000 < feet.min() < 20_000 / FOOT_M  # inside the ISA range: only kinematics tell
    message = _error(_with(paper_flight, _altitude_airframe(paper_flight), altitude=feet))
    assert "the altitude's change is 3.28 x the integrated vertical speed" in message
    assert "altitude in feet?" in message
    # depth (z down) instead of height: the sign says it
    depth = _with(paper_flight, _altitude_airframe(paper_flight),
                  altitude=10_000.0 - _climb(paper_flight))
    assert "opposite signs: the altitude channel must be height up" in _error(depth)


def test_altitude_in_feet_outside_the_isa_range_names_feet(paper_flight):
    feet = (_climb(paper_flight) + 5000.0) / FOOT_M
    message = _error(_with(paper_flight, _altitude_airframe(paper_flight), altitude=feet))
    assert "channel 'altitude' outside the ISA model's -500 to 20000 m (altitude in feet?)" \
        in message


def test_density_in_grams_and_an_impossible_dynamic_pressure(paper_flight):
    rho = paper_flight.airframe.replace(altitude_m=None, atmosphere_channel="rho")
    assert "(rho in g/m^3?)" in _error(_with(paper_flight, rho, rho=412.7))
    qbar = paper_flight.airframe.replace(altitude_m=None, atmosphere_channel="qbar")
    speed2 = paper_flight["u"] ** 2 + paper_flight["v"] ** 2 + paper_flight["w"] ** 2
    # 0.4127 kg/m^3 written in psi: 7000 times too small a pressure, below any density
    message = _error(_with(paper_flight, qbar, qbar=0.5 * 0.4127 * speed2 / 6894.7573))
    assert "channel 'qbar' with the airspeed implies a density of 5.99e-05 kg/m^3" in message
    assert "(qbar in kPa or psf or psi?)" in message  # each puts it inside


@pytest.mark.parametrize("name", ESTIMATORS)
def test_every_estimator_is_stopped_before_it_runs(paper_flight, name):
    estimator = make_estimator(name)
    with pytest.raises(FlightError, match=r"mass in grams\?"):
        estimator.fit(_with(paper_flight, mass=70_000.0), rng=0)
    with pytest.raises(FlightError, match=r"altitude in feet\?"):
        estimator.fit(_with(paper_flight, _altitude_airframe(paper_flight),
                            altitude=_climb(paper_flight) / FOOT_M), rng=0)
    # warnings come before the method runs too (pytest makes them errors here)
    for changes in ({"mass": 35.0}, {"thrust": 0.0}):
        with pytest.raises(AeroidWarning, match="the channel is used|no thrust"):
            estimator.fit(_with(paper_flight, **changes), rng=0)


#: A barometric altimeter's noise [m] (white, per sample), for the refusal rate below.
ALTIMETER_SD_M = 0.5


def test_a_noisy_altimeter_is_neither_refused_nor_missed(clean_flight):
    # 20 seeds of a 0.5 m altimeter at 500 Hz on the 1 s reference window (climbing 18 m):
    # in metres never a finding (measured: 0 of 20), in feet always named (20 of 20)
    airframe = _altitude_airframe(clean_flight)
    refused, named = 0, 0
    for seed in range(20):
        noise = np.random.default_rng(seed).normal(0.0, ALTIMETER_SD_M, clean_flight.n_samples)
        metres = _climb(clean_flight) + noise
        refused += _with(clean_flight, airframe, altitude=metres).check() != ([], [])
        errors, _ = _with(clean_flight, airframe, altitude=metres / FOOT_M).check()
        named += any("altitude in feet?" in e for e in errors)
    assert (refused, named) == (0, 20)
