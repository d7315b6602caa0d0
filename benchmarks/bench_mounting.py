"""Measure the board-mounted IMU's verdicts: right mounting, wrong mounting, saturated gyros.

Run by hand from the repository root::

    python benchmarks/bench_mounting.py --seeds 10

Per seed (0..N-1): the reference flight's window (5-6 s) logged by the default
:class:`~aeroid.flights.SensorSuite` with the IMU on a board whose long axis is along the
sensor's -y (``imu_mounting = "x=-y, y=x, z=z"``) and a gyro range of 52 rad/s (the roll
peaks near 53 rad/s: a few hundred roll samples clip). Reconstructed (a) with the right
mounting: how often the residual check (chi-square, two-sided level 0.002 per source)
refuses this correct run, and the largest |phi error| / sd; (b) with a proper but wrong
mounting (``x=y, y=-x, z=z``: two signs flipped, 180 deg about z): how often the check
refuses it (it must, every time). Then the EKF (``imu_errors = "bias+scale"``) on (a)'s
raw-IMU flight with the saturated samples left out: successes and the largest |z| of the
nine coefficients; and on the same flight with the clipped values taken as readings
(``metadata['saturated']`` removed): how often the fit check refuses it. With
``--output-error`` the same two fits by output-error (``imu_errors = "bias+scale"``, the
initial velocity with the reconstruction's prior; ~30 s per fit). One process (``--jobs``
is not offered: the runs are short). Results are printed as a Markdown table::

    python benchmarks/bench_mounting.py --seeds 3 --output-error
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from aeroid.flights import (  # noqa: E402
    SensorSuite,
    axis_map,
    mounted_group,
    reference_scenario,
    simulate_suite,
    wrap_angle,
)
from aeroid.reconstruction import reconstruct  # noqa: E402
from baselines.ekf import ExtendedKalmanEstimator  # noqa: E402
from baselines.output_error import OutputErrorEstimator  # noqa: E402

BOARD = "x=-y, y=x, z=z"
WRONG = "x=y, y=-x, z=z"
GYRO_RANGE = 52.0


def one(seed: int, output_error: bool = False) -> dict[str, float]:
    """Run the checks of one seed (module docstring)."""
    scenario = reference_scenario()
    sim = simulate_suite(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                         SensorSuite(imu_mounting=BOARD, gyro_range_radps=GYRO_RANGE),
                         rng=seed)
    rec = reconstruct(sim.log)
    phi_z = np.max(np.abs(wrap_angle(rec.table["phi"].to_numpy() - sim.truth["phi"]))
                   / rec.table["sd_phi"].to_numpy())
    imu = sim.log["imu"]
    sd = {c: imu.noise_sd["ay1" if c[0] == "a" else "q"] for c in imu.sensor_channels}
    wrong = mounted_group("imu", imu.t, imu.sensor_channels, sd, 0.0, "wrong imu",
                          axis_map(WRONG), {})
    bad = reconstruct(dataclasses.replace(sim.log, groups={**sim.log.groups, "imu": wrong}))
    flight = rec.to_flight(imu="raw")
    unmarked = dataclasses.replace(flight, metadata={
        k: v for k, v in flight.metadata.items() if k != "saturated"})
    out = {"saturated": imu.n_saturated,
           "right_refused": float(not all(c["consistent"] for c in rec.nis.values())),
           "phi_z": float(phi_z),
           "wrong_refused": float(not all(c["consistent"] for c in bad.nis.values()))}
    methods = {"ekf": ExtendedKalmanEstimator(imu_errors="bias+scale")}
    if output_error:
        methods["oe"] = OutputErrorEstimator(imu_errors="bias+scale",
                                             estimate_initial_velocity=True,
                                             initial_velocity_prior="flight")
    for name, est in methods.items():
        res = est.fit(flight, rng=0)
        z = np.abs(res.theta - scenario.coefficient_vector) / res.stderr
        clipped = est.fit(unmarked, rng=0)
        zc = np.abs(clipped.theta - scenario.coefficient_vector) / clipped.stderr
        out.update({f"{name}_success": float(res.success), f"{name}_max_z": float(np.max(z)),
                    f"{name}_clipped_refused": float(not clipped.success),
                    f"{name}_clipped_max_z": float(np.max(zc))})
    return out


def main() -> None:
    """Run the seeds and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--output-error", action="store_true")
    args = parser.parse_args()
    rows = []
    for seed in range(args.seeds):
        rows.append(one(seed, args.output_error))
        print(f"seed {seed}: {rows[-1]}", flush=True)
    n = len(rows)

    def total(key: str) -> int:
        return int(sum(r[key] for r in rows))

    print(f"\n| {n} seeds | result |\n|---|---|")
    print(f"| saturated roll samples per log | {min(r['saturated'] for r in rows)}-"
          f"{max(r['saturated'] for r in rows)} |")
    print(f"| right mounting: residual check refuses | {total('right_refused')} of {n} |")
    print(f"| right mounting: largest phi error / sd | {max(r['phi_z'] for r in rows):.2f} |")
    print(f"| wrong mounting (x=y, y=-x): residual check refuses | {total('wrong_refused')} "
          f"of {n} |")
    for name in ("ekf", "oe") if args.output_error else ("ekf",):
        label = {"ekf": "EKF", "oe": "output-error"}[name]
        print(f"| {label}, saturated samples left out: success | {total(name + '_success')} "
              f"of {n} |")
        print(f"| {label}, saturated samples left out: largest coefficient error / se | "
              f"{max(r[name + '_max_z'] for r in rows):.2f} |")
        print(f"| {label}, clipped values taken as readings: fit check refuses | "
              f"{total(name + '_clipped_refused')} of {n} (largest error / se "
              f"{max(r[name + '_clipped_max_z'] for r in rows):.1f}) |")


if __name__ == "__main__":
    main()
