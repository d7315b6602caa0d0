"""Re-fly the exported table model in JSBSim and compare it with the log (issue 23).

The log is JSBSim's own: a supersonic coast of the cross-engine airframe whose Cx and
Cmq are tables in ``velocities/mach`` (the true tables written as an aerodynamics
fragment by :func:`aeroid.report.jsbsim_fragment` and multiplied into the template's
X, PITCH and YAW functions). aeroid's output-error fits the tables from that log; the
fitted fragment (what ``aeroid estimate --report`` writes as ``tables_jsbsim.xml``)
replaces the true one in the same aircraft, which JSBSim flies from the log's initial
state (the same initial condition, fin law and world); the re-flown states are compared
with the log's. Measured: the fitted points within 2 of their standard errors; the
re-flown speed 0.0068 m/s off the log's at most (bound from the points' errors: 0.031
m/s), the rates and angles 1e-5 to 8e-4 of their range.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import aeroid
from aeroid.flights import GaussianNoise
from aeroid.model import TableSpec
from aeroid.report import FittedTable, fitted_tables, jsbsim_fragment

from . import _engine
from ._aircraft import FlightConfig, aircraft_xml
from .jsbsim_flight import make_flight
from .test_recovery import issue10_flight

jsbsim = pytest.importorskip("jsbsim", reason="the cross-engine tests need JSBSim")

#: Placeholders the template fills as Cx and Cmq, replaced by the tables' functions.
CX_MARK, CMQ_MARK = 777.0, -888.0
#: The true tables (the Mach sweep scenario's rows about Mach 2): knots and values.
KNOTS = (1.925, 2.2)
TRUE = {"Cx": (-0.90, -0.833), "Cmq": (-2060.0, -1893.0)}
#: A coast at 5 km from Mach 2.15 (about 690 m/s), level: 2 s cross Mach 2.15 -> 1.95.
CONFIG = FlightConfig(name="xe_mach", thrust_n=0.0, altitude_m=5000.0, speed_mps=690.0,
                      theta_deg=0.0, p_radps=40.0, q_radps=0.5, sample_rate_hz=250.0,
                      frame_rate_hz=8000.0, window_s=(0.2, 2.2),
                      coefficients={**dict(FlightConfig().coefficients), "Cx": CX_MARK,
                                    "Cmq": CMQ_MARK})
#: Tolerance of the re-flown speed against the log: a Cx error dCx changes the
#: deceleration by q S dCx / m, so the speed after t by at most q S t |dCx| / m (dCx at
#: most 3 of the fitted points' standard errors, the flight's largest q); 1e-6 of the
#: speed beside it for the engine's rounding.
SE_BOUND = 3.0
#: The re-flown rates and angles against the log's, relative to each channel's largest
#: value: about 4x the measured (p 1.0e-5, q 7.5e-4, r 6.8e-4, phi 7.4e-6, theta 3.7e-4;
#: the fitted constants' and points' errors of 1-2 standard errors on this noisy log make
#: them); not derived, a guard against a fragment that JSBSim reads differently (a wrong
#: Mach axis or sign moves q and r by tens of per cent).
MOTION_TOL = {"p": 5e-5, "q": 3e-3, "r": 3e-3, "phi": 5e-5, "theta": 2e-3}
#: The engine's rounding of the speed [m/s] (its state in ft/s, double precision).
SPEED_ROUNDING = 1e-6
#: The log's sensor noise (aeroid's default Gaussian IMU) seed.
NOISE_SEED = 1


def _fragment_xml(tables: list[FittedTable]) -> str:
    return jsbsim_fragment(tables, source="test")


def _with_tables(xml: str, fragment: str) -> str:
    out = xml.replace(f"<value> {CX_MARK!r} </value>",
                      "<property> aero/coefficient/Cx_mach </property>")
    out = out.replace(f"<value> {CMQ_MARK!r} </value>",
                      "<property> aero/coefficient/Cmq_mach </property>")
    assert out.count("aero/coefficient/Cx_mach") == 1
    assert out.count("aero/coefficient/Cmq_mach") == 2  # pitch and yaw damping
    return out.replace("<aerodynamics>", "<aerodynamics>\n" + fragment, 1)


def _fly(monkeypatch, fragment: str, noise=None):
    def write(config, root):
        path = Path(root) / "aircraft" / config.name / f"{config.name}.xml"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(_with_tables(aircraft_xml(config), fragment))
        return path

    monkeypatch.setattr(_engine, "write_aircraft", write)
    return make_flight(CONFIG, noise=noise, rng=NOISE_SEED)


def test_the_exported_tables_refly_the_log_in_jsbsim(monkeypatch):
    truth = [FittedTable(name, np.array(KNOTS), np.array(values), np.zeros(2))
             for name, values in TRUE.items()]
    log, log_truth = _fly(monkeypatch, _fragment_xml(truth), GaussianNoise())
    # aeroid's view of the engine's log as the cross-engine fits take it (per-sample
    # density, the relay's switch instants: tests/crossengine/test_recovery.py), the
    # speed of sound from the log's mean temperature (JSBSim's Mach uses the local one:
    # 0.2 K apart over the 35 m the coast sinks)
    log = issue10_flight(log, log_truth, events=True)
    prior = dict(zip(aeroid.NAMES, aeroid.nominal(), strict=True))
    prior.update({n: v for n, v in CONFIG.coefficients.items() if n not in ("Cx", "Cmq")})
    spec = TableSpec((("Cx", KNOTS), ("Cmq", KNOTS)), float(log_truth.data["temperature"].mean()))
    log = dataclasses.replace(log, airframe=log.airframe.replace(
        tables=spec, prior=tuple(prior[n] for n in aeroid.NAMES)))
    result = aeroid.make_estimator("output-error", {"substeps": 4, "input": "events"}).fit(
        log, rng=0)
    assert result.success, result.message
    fitted = fitted_tables(result.names, result.theta, result.stderr)
    for table in fitted:  # the fit itself: every point within 3 of its standard error
        np.testing.assert_array_less(np.abs(table.value - np.array(TRUE[table.name])),
                                     SE_BOUND * table.stderr)
    refly, refly_truth = _fly(monkeypatch, _fragment_xml(fitted))
    logged, reflown = log_truth.data, refly_truth.data
    assert np.array_equal(reflown["t"], logged["t"])
    # the speed: a Cx error dCx changes the deceleration by qbar S dCx / m, so the speed
    # after t by qbar S t |dCx| / m at most (dCx: the fitted points' largest error against
    # the truth, the largest qbar of the flight); the engine's rounding beside it
    t = logged["t"].to_numpy()
    dcx = max(float(np.max(np.abs(f.value - np.array(TRUE["Cx"])))) for f in fitted
              if f.name == "Cx")
    bound = logged["qbar"].max() * CONFIG.area_m2 * t * dcx / CONFIG.mass_kg + SPEED_ROUNDING
    np.testing.assert_array_less(np.abs(reflown["u"] - logged["u"]).to_numpy(), bound)
    for channel, tol in MOTION_TOL.items():  # the motion the moments make
        scale = float(np.max(np.abs(logged[channel])))
        diff = float(np.max(np.abs(reflown[channel] - logged[channel])))
        assert diff < tol * scale, (channel, diff, scale)
