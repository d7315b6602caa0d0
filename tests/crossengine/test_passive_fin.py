"""A JSBSim passive-fin flight (issue 25, cross-engine): no fin motion, fin cant.

The cross-engine airframe with its fin fixed (``FlightConfig(fin="passive")``: JSBSim's
``fcs/fin-rad`` is 0), coasting (no thrust) from the climb's 560 m/s at 2.5 km with an
initial pitch and yaw rate (1.5 and -1.0 rad/s: the weathercock oscillation that
carries Cza, Czq, Cma, Cmq) and the climb's 30 rad/s roll rate, which the fin cant's
roll moment Cl0 drives up against the roll damping Clp (35 -> 52 rad/s over the
0.1-1.1 s window: the roll-up that separates Cl0 from Clp). Gaussian IMU noise. The log
goes through the files as a rocket team's would: a CSV **without a fin column** and an
airframe file with ``fin = "passive"`` (and the engine's per-sample density as a
``rho`` channel, ``[atmosphere] per_sample = "rho"``), read back by ``read_flight``.

Measured (``python -m tests.crossengine.wind_measure``, seeds 1-5; the test flies seed
1): output-error and the EKF hold Czd = Cmd = 0 (passive fin), succeed 5/5 each and
recover the seven others within 0.80-1.51 of their standard errors (EKF 0.78-1.55);
Cl0 and Clp within 0.06-1.31 se (EKF 0.18-1.27; seed 1: 0.25, EKF 0.33), their
standard errors 0.014 and 0.016 % of the truth; mean |error| of the seven 0.03-0.16 %.
The same log read with a relay airframe (a fin column of zeros) and fitted with all nine
free: not a success, Czd and Cmd named ("no fin motion").
"""

from __future__ import annotations

import numpy as np
import pytest

import aeroid
from aeroid.estimation import FIN_TERMS
from aeroid.flights import GaussianNoise, read_flight
from aeroid.model import save_airframe

from .jsbsim_flight import FlightConfig, make_flight

jsbsim = pytest.importorskip("jsbsim", reason="the cross-engine tests need JSBSim")

PASSIVE = FlightConfig(name="xe_passive", fin="passive", thrust_n=0.0, q_radps=1.5,
                       r_radps=-1.0, window_s=(0.1, 1.1))
NOISE_SEED = 1
#: Issue 25's verdict: Cl0, Clp (and here every free coefficient) within 3 se.
SE_BOUND = 3.0
ROLL = ("Cl0", "Clp")


@pytest.fixture(scope="module")
def passive_log(tmp_path_factory):
    """The JSBSim passive-fin log as files (no fin column) read back, and the truth."""
    flight, truth = make_flight(PASSIVE, noise=GaussianNoise(), rng=NOISE_SEED)
    assert np.all(truth.data["delta_frame"] == 0.0)  # the engine's fin never moved
    folder = tmp_path_factory.mktemp("xe_passive")
    data = flight.data.drop(columns="delta").assign(rho=truth.data["rho"].to_numpy())
    csv, toml = folder / "log.csv", folder / "log-airframe.toml"
    data.to_csv(csv, index=False, float_format="%.17g")
    save_airframe(flight.airframe.replace(altitude_m=None, given_density_kgm3=None,
                                          atmosphere_channel="rho"), toml)
    assert 'fin = "passive"' in toml.read_text()
    return read_flight(csv, airframe=toml), truth


def test_the_log_reads_without_a_fin_column(passive_log):
    flight, _ = passive_log
    assert np.all(flight["delta"] == 0.0)
    assert any("fin is passive" in note for note in flight.notes)


@pytest.mark.parametrize("method", ["output-error", "ekf"])
def test_passive_fin_fit_holds_the_fin_terms(passive_log, method):
    flight, truth = passive_log
    result = aeroid.make_estimator(method).fit(flight, rng=1)
    assert result.success, result.message
    assert result.held == dict.fromkeys(FIN_TERMS, 0.0)
    free = [i for i, name in enumerate(result.names) if name not in FIN_TERMS]
    z = np.abs(result.theta[free] - truth.coefficients[free]) / result.stderr[free]
    assert np.all(z <= SE_BOUND), dict(zip(np.array(result.names)[free], z, strict=True))
    roll = [result.names.index(n) for n in ROLL]
    assert np.all(result.stderr[roll] > 0)  # determined by the roll-up, not held


def test_a_relay_airframe_on_the_still_fin_names_the_fin_terms(passive_log):
    """The same record told its fin is a relay (a column of zeros): the fin terms cannot
    be determined, and a fit with all nine free is not a success for them."""
    flight, _ = passive_log
    relay = flight.airframe.replace(fin="relay", delta_max_deg=PASSIVE.delta_max_deg)
    flight = aeroid.make_flight({c: flight[c] for c in flight.channels}, relay,
                                dict(flight.metadata))
    result = aeroid.make_estimator("output-error").fit(flight, rng=1)
    assert not result.success
    assert set(result.info["not_identifiable"]) == set(FIN_TERMS)
    assert all(name in result.message for name in FIN_TERMS)
