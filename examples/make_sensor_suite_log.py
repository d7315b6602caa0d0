"""Write an example sensor-suite log: what a flight-test logger's files look like.

The reference airframe's flight (``aeroid/data/reference-scenario.toml``, the recorded
window 5-6 s) logged by :class:`aeroid.flights.SensorSuite`'s default suite: a 1000 Hz
IMU (two accelerometer triads and three gyros, each axis with a constant bias, a
scale-factor error and white noise), GNSS NED velocity and position at 10 Hz, a
barometric altitude at 50 Hz, an INS attitude at 100 Hz with roll and yaw wrapped to
(-pi, pi], and the fin at 1000 Hz; one CSV per group with its own time column, described
by ``suite.toml``. The drawn sensor errors are in its ``[truth]`` table. Run from the
repository root::

    python examples/make_sensor_suite_log.py [FOLDER]      # default examples/suite-log
    aeroid reconstruct examples/suite-log/suite.toml -o states.csv --flight flight.csv

``--pressure`` logs the barometer's static pressure [Pa] and air temperature [K] (ISA of
the true altitude) instead of its pressure altitude::

    python examples/make_sensor_suite_log.py /tmp/suite-p --pressure
    aeroid reconstruct /tmp/suite-p/suite.toml -o states.csv --report report/

``--board`` logs the IMU as a flight computer's board mounts it: its long axis along the
sensor's -y (``[groups.imu.mounting] axes = "x=-y, y=x, z=z"`` in ``suite.toml``; the
CSV holds the board's axes, the errors and noise are the sensor axes') with a 52 rad/s
gyro range (the roll peaks near 53 rad/s: about 300 roll samples saturate, clipped at the
range and marked on reading)::

    python examples/make_sensor_suite_log.py /tmp/suite-b --board
    aeroid reconstruct /tmp/suite-b/suite.toml -o states.csv --flight flight.csv
"""

from __future__ import annotations

import sys
from pathlib import Path

from aeroid.flights import SensorSuite, reference_scenario, simulate_suite, write_suite_log

#: Seed of the sensor errors and noise.
SEED = 2026


#: The board's mounting and gyro range of ``--board``.
BOARD = {"imu_mounting": "x=-y, y=x, z=z", "gyro_range_radps": 52.0}


def main(folder: Path, pressure: bool = False, board: bool = False) -> None:
    """Simulate the reference flight with the default suite and write its log."""
    folder.mkdir(parents=True, exist_ok=True)
    scenario = reference_scenario()
    options: dict = {"baro_channels": ("pressure", "temperature")} if pressure else {}
    suite = SensorSuite(**options, **(BOARD if board else {}))
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         suite, rng=SEED)
    for path in write_suite_log(sim.log, folder / "suite.toml"):
        print(f"wrote {path}")


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a not in ("--pressure", "--board")]
    main(Path(args[0]) if args else Path(__file__).parent / "suite-log",
         pressure="--pressure" in sys.argv[1:], board="--board" in sys.argv[1:])
