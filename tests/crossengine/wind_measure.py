"""Measure aeroid's estimators on the JSBSim flights in wind, turbulence and with a passive fin.

Run by hand (not collected by pytest; one process, about 15 s per seed)::

    PYTHONPATH=. python -m tests.crossengine.wind_measure            # seeds 1-5
    PYTHONPATH=. python -m tests.crossengine.wind_measure 1 2        # those seeds

The flights are those of :mod:`.test_wind` and :mod:`.test_passive_fin` (the seed is
the IMU noise's and, for the turbulent flight, JSBSim's ``simulation/randomseed``; the
vane noise of 0.1 deg on alpha and beta is drawn from ``[seed, 26]``). Printed per
seed and flight: each fit's verdict, mean |relative error| of the coefficients [%] and
the largest |error| / standard error; for the turbulent flight also the gusts' sd over
the window per NED component and the RMS of the logged alpha minus ``atan(w/u)``.
"""

from __future__ import annotations

import dataclasses
import sys

import numpy as np

from aeroid.flights import GaussianNoise, make_flight

from . import jsbsim_flight
from .test_passive_fin import PASSIVE
from .test_recovery import issue10_flight
from .test_wind import TURBULENT, WIND_NED_MPS, WINDY, _fit, _with_vane_noise

STILL = dataclasses.replace(WINDY, name="xe_climb", wind_ned_mps=(0.0, 0.0, 0.0))


def _vane(flight, seed: int):
    """The test's vane noise (0.1 deg white), drawn from the seed's own stream."""
    return _with_vane_noise(flight, np.random.default_rng([seed, 26]))


def _row(label: str, result, truth, free=None) -> float:
    free = np.arange(len(result.names)) if free is None else np.asarray(free)
    err = np.abs(result.theta[free] / truth.coefficients[free] - 1.0) * 100.0
    z = (np.abs(result.theta[free] - truth.coefficients[free]) / result.stderr[free]
         if result.stderr is not None else np.array([np.nan]))
    extra = ""
    if "wind_ned_mps" in result.info:
        wind = np.asarray(result.info["wind_ned_mps"])
        se = np.asarray(result.info["wind_stderr_mps"])
        extra = (f" wind {np.round(wind, 2).tolist()} +- {np.round(se, 2).tolist()}, max |z| "
                 f"{np.max(np.abs(wind - np.array(WIND_NED_MPS)) / se):.2f}")
    print(f"| {label} | {result.success} | {np.mean(err):.3f} | {np.nanmax(z):.2f} | "
          f"{result.message[:90]}{extra} |")
    return float(np.mean(err))


def measure(seed: int) -> None:
    """Fit every flight of ``seed`` and print one markdown row per fit."""
    noise = GaussianNoise()
    print(f"\n### seed {seed}\n\n| flight / fit | success | mean abs err [%] | max abs err/se "
          "| message |\n|---|---|---|---|---|")
    flight, truth = jsbsim_flight.make_flight(WINDY, noise=noise, rng=seed)
    flight = issue10_flight(flight, truth, events=True)
    _row("wind / output-error estimate_wind", _fit(
        "output-error", flight, {"input": "events", "estimate_wind": True}), truth)
    _row("wind / output-error", _fit("output-error", flight, {"input": "events"}), truth)
    _row("wind / EKF estimate_wind", _fit(
        "ekf", flight, {"input": "events", "estimate_wind": True}), truth)
    still, still_truth = jsbsim_flight.make_flight(STILL, noise=noise, rng=seed)
    still = issue10_flight(still, still_truth, events=True)
    _row("still / output-error", _fit("output-error", still, {"input": "events"}), still_truth)
    base = _row("still / equation-error", _fit("equation-error", still, {}), still_truth)
    config = dataclasses.replace(TURBULENT, random_seed=seed)
    flight, truth = jsbsim_flight.make_flight(config, noise=noise, rng=seed)
    d = truth.data
    gust_sd = d[["wind_n", "wind_e", "wind_d"]].std().to_numpy()
    angle = np.degrees(np.sqrt(np.mean((d["alpha"] - np.arctan2(d["w"], d["u"])) ** 2)))
    flight = _vane(issue10_flight(flight, truth, events=True), seed)
    measured = _row("turbulence / equation-error measured angles", _fit(
        "equation-error", flight, {"air_data": "measured"}), truth)
    _row("turbulence / equation-error inertial angles", _fit(
        "equation-error", flight, {"air_data": "inertial"}), truth)
    _row("turbulence / output-error", _fit("output-error", flight, {"input": "events"}), truth)
    _row("turbulence / output-error estimate_wind", _fit(
        "output-error", flight, {"input": "events", "estimate_wind": True}), truth)
    print(f"\nturbulence: gust sd over the window (N, E, D) {np.round(gust_sd, 2).tolist()} "
          f"m/s, alpha - atan(w/u) {angle:.3f} deg RMS; equation-error measured / still air "
          f"{measured / base:.1f}x\n")
    passive, passive_truth = jsbsim_flight.make_flight(PASSIVE, noise=noise, rng=seed)
    channels = {c: passive[c] for c in passive.channels}
    channels["rho"] = passive_truth.data["rho"].to_numpy()
    passive = make_flight(channels, passive.airframe.replace(
        altitude_m=None, given_density_kgm3=None, atmosphere_channel="rho"),
        dict(passive.metadata))
    for name in ("output-error", "ekf"):
        result = _fit(name, passive, {})
        free = [i for i, n in enumerate(result.names) if n not in result.held]
        _row(f"passive fin / {name} (held {', '.join(result.held)})", result, passive_truth,
             free)


def main(argv: list[str]) -> None:
    """Measure the seeds in ``argv`` (default 1-5)."""
    for seed in [int(a) for a in argv] or [1, 2, 3, 4, 5]:
        measure(seed)


if __name__ == "__main__":
    main(sys.argv[1:])
