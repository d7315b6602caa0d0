"""Noise-free sensor-suite flights for the tests of the IMU errors (shared helpers).

:func:`clean_suite_flight`: the reference window logged by the default suite without
white noise; the flight holds the raw IMU readings (each axis ``(1 + s) truth + b`` with the
drawn biases and scale factors) and the true states, so a fit with ``imu_errors`` must
return the drawn errors, which :func:`truth_errors` names as the fits do.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from aeroid.flights import (
    DECLARED_WIND_KEY,
    Flight,
    SensorSuite,
    make_flight,
    reference_scenario,
    simulate_suite,
)
from aeroid.model import OUTPUT_CHANNELS

#: The state channels a suite flight takes from the truth.
TRUE_STATES = ("u", "v", "w", "phi", "theta", "psi")


def clean_suite_flight(seed: int = 3) -> tuple[Any, Flight]:
    """Return the noise-free suite simulation and its flight (raw IMU, true states)."""
    scenario = reference_scenario()
    suite = SensorSuite(accel_noise_mps2=0.0, gyro_noise_radps=0.0)
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         suite, rng=seed)
    imu = sim.log["imu"]
    channels = {"t": imu.t, **{c: imu.channels[c] for c in OUTPUT_CHANNELS},
                **{c: sim.truth[c] for c in TRUE_STATES}, "delta": sim.truth["delta"]}
    return sim, make_flight(channels, scenario.airframe, declared_air(sim))


def declared_air(sim: Any) -> dict[str, Any]:
    """The air the suite simulator flew (its log's ``metadata["wind"]``: still air), as
    the flight's metadata: estimate_wind = auto then assumes still air, as these tests
    mean (:func:`aeroid.flights.declared_wind`)."""
    return {DECLARED_WIND_KEY: sim.log.metadata[DECLARED_WIND_KEY]}


def truth_errors(sim: Any) -> dict[str, float]:
    """The simulation's drawn IMU errors by the fits' names (``bax1`` ... ``sr``)."""
    e = sim.errors
    names = [f"b{c}" for c in OUTPUT_CHANNELS] + [f"s{c}" for c in OUTPUT_CHANNELS]
    values = np.concatenate([e["accel_bias"].ravel(), e["gyro_bias"],
                             e["accel_scale"].ravel(), e["gyro_scale"]])
    return dict(zip(names, values.tolist(), strict=True))


def gnss_aiding(sim: Any, flight: Flight, shift_s: float = 0.0, sd: float | None = None
                ) -> Flight:
    """``flight`` with the suite log's GNSS velocity as ``metadata["aiding"]`` (what
    ``Reconstruction.to_flight(aiding=True)`` passes), its times moved by ``shift_s``
    (an undeclared skew: the values stay those of the true times) and its stated sd
    replaced by ``sd`` when given; samples outside the flight's times left out."""
    gnss = sim.log["gnss"]
    t = gnss.t + shift_s
    inside = (t >= flight.t[0] - 1e-9) & (t <= flight.t[-1] + 1e-9)
    stated = {c: float(sd if sd is not None else gnss.noise_sd[c]) for c in ("vn", "ve", "vd")}
    aiding = {"gnss": {"t": t[inside], "sd": stated,
                       **{c: gnss.channels[c][inside] for c in ("vn", "ve", "vd")}}}
    return make_flight({c: flight[c] for c in flight.channels} | {"t": flight.t},
                       flight.airframe, {**flight.metadata, "aiding": aiding})


def suite_flight(seed: int = 1, **suite: Any) -> tuple[Any, Flight]:
    """Return a default-suite simulation (noise on) and its flight (raw IMU, true states)."""
    scenario = reference_scenario()
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         SensorSuite(**suite), rng=seed)
    imu = sim.log["imu"]
    channels = {"t": imu.t, **{c: imu.channels[c] for c in OUTPUT_CHANNELS},
                **{c: sim.truth[c] for c in TRUE_STATES}, "delta": sim.truth["delta"]}
    return sim, make_flight(channels, scenario.airframe, declared_air(sim))


def ins_aiding(sim: Any, flight: Flight, shift_s: float = 0.0, sd: float | None = None
               ) -> Flight:
    """``flight`` with the suite log's INS attitude (wrapped, as logged) added to
    ``metadata["aiding"]`` as ``"ins"``, as :func:`gnss_aiding` does the GNSS's."""
    ins = sim.log["ins"]
    t = ins.t + shift_s
    inside = (t >= flight.t[0] - 1e-9) & (t <= flight.t[-1] + 1e-9)
    angles = ("phi", "theta", "psi")
    stated = {c: float(sd if sd is not None else ins.noise_sd[c]) for c in angles}
    aiding = {**flight.metadata.get("aiding", {}),
              "ins": {"t": t[inside], "sd": stated, **{c: ins.channels[c][inside]
                                                       for c in angles}}}
    return make_flight({c: flight[c] for c in flight.channels} | {"t": flight.t},
                       flight.airframe, {**flight.metadata, "aiding": aiding})
