"""What the air-data benchmarks share: one BLAS thread, the winds, the probe, the flights.

Imported first (before numpy) by ``benchmarks/bench_air_data*.py``, ``bench_pitot.py`` and
``bench_pso_air_data.py``, which run from the repository root as scripts (this folder is
then on ``sys.path``). The flights: the reference scenario in a wind of :data:`AIRS`,
simulated and recorded from one generator ``default_rng(seed)`` (the gusts, then the
sensor noise, as :func:`aeroid.simulate`), so every benchmark flies the same flights for
the same seed.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # shared 2-core machine
os.environ.setdefault("OMP_NUM_THREADS", "1")

import dataclasses  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from aeroid.flights import (  # noqa: E402
    MIL_SCALE_LENGTH_M,
    Flight,
    NoiseModel,
    Wind,
    make_noise,
    record_flight,
    reference_scenario,
    simulate_truth,
)
from aeroid.model import NAMES  # noqa: E402

#: The steady wind [m/s], north-east-down: 3 along the northward path, 4 across.
WIND = (3.0, 4.0, 0.0)
#: The probe: vanes of 0.1 deg on alpha and beta, an airspeed channel of 0.5 m/s.
VANE_SD_DEG = 0.1
VANE_RAD = float(np.radians(VANE_SD_DEG))
AIRSPEED_SD_MPS = 0.5
#: Dryden's scale length [m] (MIL-F-8785C).
SCALE_LENGTH_M = MIL_SCALE_LENGTH_M


def dryden(sd_mps: float) -> Wind:
    """The steady :data:`WIND` with Dryden gusts of sd ``sd_mps``."""
    return Wind(steady_ned_mps=WIND, turbulence_sd_mps=sd_mps, scale_length_m=SCALE_LENGTH_M)


#: The airs the benchmarks fly (None: still air).
AIRS: dict[str, Wind | None] = {
    "still": None, "crosswind 5 m/s": Wind(steady_ned_mps=(0.0, 5.0, 0.0)),
    "wind 5 m/s": Wind(steady_ned_mps=WIND), "wind + Dryden sd 1": dryden(1.0),
    "wind + Dryden sd 3": dryden(3.0)}


def probe_noise(vane_rad: float = VANE_RAD, **probe: Any) -> NoiseModel:
    """The tactical Gaussian IMU with vanes of ``vane_rad`` on alpha and beta and the
    ``probe``'s other channels (``airspeed_sd_mps``, the pressures' sd)."""
    return make_noise("gaussian", alpha_sd_rad=vane_rad, beta_sd_rad=vane_rad, **probe)


def windy_flight(wind: Wind | None, noise: NoiseModel, seed: int) -> tuple[Flight, np.ndarray]:
    """The reference flight in ``wind`` recorded with ``noise`` (``rng = seed``: the gusts,
    then the sensor noise), and the simulator's wind over its samples, shape (n, 3) [m/s]
    (zeros in still air)."""
    s = reference_scenario()
    m = s.manoeuvre if wind is None else dataclasses.replace(s.manoeuvre, wind=wind)
    rng = np.random.default_rng(seed)
    truth = simulate_truth(s.airframe, s.coefficient_vector, m, rng=rng)
    flight = record_flight(s.airframe, s.coefficient_vector, m, truth, noise, rng=rng)
    k0 = int(round(m.window_s[0] / m.dt))
    true_wind = (np.zeros((flight.n_samples, 3)) if truth.wind is None
                 else np.asarray(truth.wind[k0:], dtype=float))
    return flight, true_wind


def coefficient_table(errors: dict[str, list[np.ndarray]], head: str = "air / fit"
                      ) -> list[str]:
    """The lines of the mean |relative error| per coefficient [%]: ``errors`` maps a row's
    label to its runs' errors, each (n_coefficients,) [%]."""
    out = ["", "Mean |relative error| per coefficient [%]:", "",
           f"| {head} | " + " | ".join(NAMES) + " |", "|---|" + "---|" * len(NAMES)]
    for label, runs in errors.items():
        out.append(f"| {label} | " + " | ".join(f"{v:.2f}" for v in np.mean(runs, axis=0))
                   + " |")
    return out
