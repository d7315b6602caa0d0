"""The per-sample input checks against a second simulator's own channels (issue 21).

JSBSim logs the altitude (``position/h-sl-ft``), the density, the dynamic pressure and
the mass properties of its climb, each computed by its own code (WGS84 geodesy, its
atmosphere, its mass balance). aeroid's validator must accept them as they are (no
finding: pytest turns warnings into errors) and name the unit when they are scaled:
the altitude's rate, the independent reference of the kinematic check, agrees with
aeroid's vertical speed ``u sin theta - (v sin phi + w cos phi) cos theta`` to the
tolerance below.
"""

from __future__ import annotations

import numpy as np
import pytest

from aeroid.errors import FlightError
from aeroid.flights import make_flight

from ._aircraft import FT

jsbsim = pytest.importorskip("jsbsim", reason="the cross-engine tests need JSBSim "
                             "(pip install jsbsim)")

#: JSBSim's altitude rate against aeroid's vertical speed, median relative to the RMS
#: vertical speed: both are the same body velocity turned to the vertical; they differ by
#: the centred difference of the sampled altitude (O(dt^2) of a smooth climb) and the
#: Earth's curvature over the window (measured: median 1e-6, largest 2e-4 at the
#: window's one-sided ends; least-squares scale 0.99999991).
CLIMB_RTOL = 1e-5


def _with(flight, per_sample, **channels):
    data = {c: flight[c] for c in flight.channels}
    data.update(channels)
    airframe = flight.airframe.replace(altitude_m=None, atmosphere_channel=per_sample)
    return make_flight(data, airframe, {"source": "jsbsim.csv"})


def test_jsbsim_altitude_rate_is_aeroid_vertical_speed(climb):
    flight, truth = climb
    altitude = truth.data["altitude"].to_numpy()
    u, v, w = flight["u"], flight["v"], flight["w"]
    phi, theta = flight["phi"], flight["theta"]
    climb_rate = u * np.sin(theta) - (v * np.sin(phi) + w * np.cos(phi)) * np.cos(theta)
    rate = np.gradient(altitude, flight.t)
    rms = float(np.sqrt(np.mean(climb_rate**2)))
    assert rms > 1.0  # a climb: the check has something to compare
    assert float(np.median(np.abs(rate - climb_rate))) < CLIMB_RTOL * rms


def test_jsbsim_channels_pass_and_scaled_ones_are_named(climb):
    flight, truth = climb
    altitude = truth.data["altitude"].to_numpy()
    assert _with(flight, "altitude", altitude=altitude).check() == ([], [])
    assert _with(flight, "rho", rho=truth.data["rho"].to_numpy()).check() == ([], [])
    assert _with(flight, "qbar", qbar=truth.data["qbar"].to_numpy()).check() == ([], [])
    masses = {c: truth.data[c].to_numpy() for c in ("mass", "ix", "iy", "iz")}
    same = make_flight({**{c: flight[c] for c in flight.channels}, **masses},
                       flight.airframe, {"source": "jsbsim.csv"})
    assert same.check() == ([], [])
    with pytest.raises(FlightError, match=r"altitude in feet\?"):
        _with(flight, "altitude", altitude=altitude / FT).validate()
    with pytest.raises(FlightError, match=r"mass in grams\?"):
        make_flight({**{c: flight[c] for c in flight.channels}, "mass": masses["mass"] * 1e3},
                    flight.airframe, {"source": "jsbsim.csv"}).validate()
