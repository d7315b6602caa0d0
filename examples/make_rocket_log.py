"""Write a sounding rocket's flight-computer log: what a rocketry team brings to aeroid.

The coast of ``studies/scenarios/rocket_coast.toml`` (a 100 mm, 10 kg rocket with canted
passive fins, Mach 0.9 at burnout down to Mach 0.2 in 15 s) logged by an off-the-shelf
flight computer (:class:`aeroid.flights.SensorSuite`):

* a 100 Hz IMU on a board whose long axis is the sensor's -y (``[groups.imu.mounting]
  axes = "x=-y, y=x, z=z"``), two accelerometer triads (16 g) and three gyros (2000 deg/s),
  each axis with a bias, a scale factor and white noise;
* a 20 Hz barometer logging static pressure and its own (the board's) temperature, a
  constant 305 K: ``[groups.baro] temperature = "board"`` in the log says so, and the
  reconstruction takes the ISA density of the pressure altitude, not ``p / (R T)``;
* a 10 Hz GNSS logging NED position only (no velocity);
* the flight computer's own attitude solution at 10 Hz (``ins``; 0.01 rad), which the
  reconstruction needs to start from;
* no fin channel (the fins are passive).

One CSV per group and ``rocket.toml`` describing them; its airframe
``rocket-airframe.toml`` is the rocket's with ``fin = "passive"`` and the design tool's
prediction as ``[prior]`` (the scenario's; the starting point of every fit). Run from the repository
root::

    python examples/make_rocket_log.py [FOLDER] [--seed N] [--wrong-mounting]
        [--scenario TOML] [--mounting AXES] [--axial-only]

Then, start to finish (the files to the coefficients)::

    aeroid reconstruct rocket-log/rocket.toml -o rocket-log/states.csv \
        --flight rocket-log/raw.csv --raw-imu
    aeroid estimate rocket-log/raw.csv --method output-error \
        --option imu_errors=bias+scale --option estimate_initial_velocity=true \
        --option initial_velocity_prior=flight

``--axial-only`` writes the same flight as a cheap board logs it (one accelerometer axis
along the rocket, GNSS positions, the barometer: ``examples/make_axial_log.py``), which
needs no reconstruction: ``aeroid estimate`` fits the log's own files by the axial-drag
method (the Cx table against Mach; ``--mass-sd`` the coast mass's sd, ``--report`` the
tables and, with ``--reference-curve``, a design tool's drag curve beside them)::

    python examples/make_rocket_log.py axial-log --axial-only
    aeroid estimate axial-log/rocket.toml --method axial-drag \
        --option "cx_knots=[0.2, 0.4, 0.6, 0.9]" --mass-sd 0.3 --seed 1 --report axial-report

``--wrong-mounting`` writes the same log (the same readings) with a mounting that is
wrong but a proper rotation, two signs flipped (``x=y, y=-x, z=z``: 180 deg about z).
``--mounting AXES`` writes the same readings with any other axis map (one sign flipped,
``x=-y, y=x, z=-z``, is a reflection: the reader refuses it). ``--scenario`` flies another
scenario (``studies/scenarios/rocket_measure.toml``: the coast mass 2 % above the file's,
the file giving a 3 % sd, Cx as a Mach table: issue 25's measure flight).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from aeroid.flights import SensorSuite, load_scenario, simulate_suite, write_suite_log

ROOT = Path(__file__).resolve().parent.parent
SCENARIO = ROOT / "studies" / "scenarios" / "rocket_coast.toml"
#: Seed of the sensor errors and noise.
SEED = 2026
#: The flight computer (module docstring). 16 g = 156.9 m/s^2, 2000 deg/s = 34.9 rad/s.
FLIGHT_COMPUTER = dict(
    imu_rate_hz=100.0, gnss_rate_hz=10.0, baro_rate_hz=20.0, ins_rate_hz=10.0,
    fin_rate_hz=0.0, imu_mounting="x=-y, y=x, z=z", accel_range_mps2=156.9,
    gyro_range_radps=34.9, baro_channels=("pressure", "temperature"),
    baro_board_temperature_k=305.0, gnss_channels=("pn", "pe", "pd"),
    ins_attitude_sd_rad=0.01)
#: A proper rotation that is not the board's: two signs flipped (180 deg about z).
WRONG_MOUNTING = "x=y, y=-x, z=z"


def make_log(folder: Path, seed: int = SEED, wrong_mounting: bool = False,
             verbose: bool = True, *, scenario_path: Path = SCENARIO,
             mounting: str | None = None) -> Path:
    """Simulate the coast, log it with the flight computer, write it; return the TOML.

    ``mounting``: an axis map written instead of the board's (the readings unchanged);
    ``wrong_mounting`` is ``mounting=WRONG_MOUNTING``.
    """
    scenario = load_scenario(scenario_path)
    suite = SensorSuite(**FLIGHT_COMPUTER)
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         suite, rng=seed)
    log = sim.log  # its airframe is the scenario's, with the design tool's [prior]
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "rocket.toml"
    written = write_suite_log(log, path)
    mounting = WRONG_MOUNTING if wrong_mounting else mounting
    if mounting is not None:
        text = path.read_text()
        right = 'axes = "x=-y, y=x, z=z"'
        if right not in text:
            raise SystemExit(f"{path}: no {right!r} to replace")
        path.write_text(text.replace(right, f'axes = "{mounting}"'))
    for file in written if verbose else ():
        print(f"wrote {file}")
    return path


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", type=Path, default=Path("rocket-log"))
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--wrong-mounting", action="store_true")
    parser.add_argument("--scenario", type=Path, default=SCENARIO)
    parser.add_argument("--mounting", help='another axis map, e.g. "x=-y, y=x, z=-z"')
    parser.add_argument("--axial-only", action="store_true",
                        help="the axial accelerometer alone, GNSS and barometer "
                             "(examples/make_axial_log.py; the rocket coast only)")
    args = parser.parse_args()
    if args.axial_only:
        if args.wrong_mounting or args.mounting or args.scenario != SCENARIO:
            parser.error("--axial-only writes the rocket coast's log as make_axial_log.py "
                         "does: not with --wrong-mounting, --mounting or --scenario")
        import sys

        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from make_axial_log import make_axial_log

        path = make_axial_log(args.folder, args.seed)
        print(f"next: aeroid estimate {path} --method axial-drag --mass-sd 0.3 --report "
              f"{args.folder / 'report'}")
    else:
        path = make_log(args.folder, args.seed, args.wrong_mounting,
                        scenario_path=args.scenario, mounting=args.mounting)
        print(f"next: aeroid reconstruct {path} -o {args.folder / 'states.csv'} --flight "
              f"{args.folder / 'raw.csv'} --raw-imu")
