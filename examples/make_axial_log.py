"""Write the rocket coast's log as a cheap flight computer logs it: one accelerometer axis.

The flight of ``examples/make_rocket_log.py`` (the coast of
``studies/scenarios/rocket_coast.toml``, the same seed gives the same readings) logged by a
board with an axial accelerometer alone: the sensor axis along the rocket's long axis
(the board's -y, ``axes = "x=-y, ..."``), its bias, scale factor and noise, no lateral
axes, no gyros, no attitude solution; GNSS positions at 10 Hz and the barometer as in the
full log. ``baselines.axial_drag`` fits it. Run from the repository root::

    python examples/make_axial_log.py [FOLDER] [--seed N] [--mass-scale S]

``--mass-scale`` flies the coast with the mass times S while the airframe file keeps the
nominal mass (a residual propellant the file does not know).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

from aeroid.flights import (
    Mounting,
    SensorSuite,
    SuiteLog,
    load_scenario,
    mounted_group,
    simulate_suite,
    write_suite_log,
)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_rocket_log import FLIGHT_COMPUTER, SCENARIO, SEED  # noqa: E402

#: The body channel an axial-only board logs.
AXIAL = "ax1"


def axial_only(log: SuiteLog, mounting: Mounting | None = None) -> SuiteLog:
    """Return ``log`` with its IMU reduced to the sensor axis that reads body x, no INS.

    ``mounting`` replaces the log's in the result (the same readings: a wrong mounting).
    """
    imu = log["imu"]
    rotation = imu.mounting.rotation if imu.mounting is not None else np.eye(3)
    axis = int(np.flatnonzero(np.abs(rotation[0]) > 0.5)[0])  # body x from sensor `axis`
    sensor = f"a{'xyz'[axis]}1"
    readings = imu.sensor_channels or imu.channels
    group = mounted_group("imu", imu.t, {sensor: readings[sensor]},
                          {sensor: imu.noise_sd[AXIAL]}, imu.offset_s, imu.source,
                          mounting or imu.mounting, {k: v for k, v in imu.ranges.items()
                                         if k == "accel_range"})
    groups = {"imu": group, **{n: g for n, g in log.groups.items() if n in ("gnss", "baro")}}
    return dataclasses.replace(log, groups=groups)


def make_axial_log(folder: Path, seed: int = SEED, mass_scale: float = 1.0,
                   verbose: bool = True) -> Path:
    """Simulate the coast, log it with an axial accelerometer alone, write it; return the TOML."""
    scenario = load_scenario(SCENARIO)
    airframe = scenario.airframe
    truth = airframe.replace(mass_kg=airframe.mass_kg * mass_scale)
    sim = simulate_suite(truth, scenario.coefficient_vector, scenario.manoeuvre,
                         SensorSuite(**FLIGHT_COMPUTER), rng=seed)
    log = dataclasses.replace(axial_only(sim.log), airframe=sim.log.airframe.replace(
        mass_kg=airframe.mass_kg))
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "rocket.toml"
    for file in write_suite_log(log, path) if verbose else write_suite_log(log, path)[:0]:
        print(f"wrote {file}")
    return path


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", type=Path, default=Path("axial-log"))
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--mass-scale", type=float, default=1.0)
    args = parser.parse_args()
    make_axial_log(args.folder, args.seed, args.mass_scale)
