"""Measure axial-drag across a burn: the verdict with the motor's curve and without it.

Run by hand from the repository root (one process; about 10 s per seed)::

    python benchmarks/bench_axial_burn.py --seeds 20 [--first 0]

Per seed the end of the boost of ``studies/scenarios/rocket_burnout.toml`` (the last 1.6 s
of the burn, then 3.4 s of coast) is flown by the sensor-suite simulator, whose IMU sees
the thrust, and logged by the axial-only board of ``examples/make_axial_log.py`` (one
accelerometer axis along the rocket, GNSS positions, the barometer). Fitted by axial-drag
(a constant Cx) with the airframe's thrust curve (a right fit: how often is it refused,
and is Cx within 3 se?) and without it (the model's thrust 0 across the burn: how often is
it refused?). Printed as a Markdown table.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
from pathlib import Path

import numpy as np

from aeroid.estimation import make_estimator
from aeroid.flights import SensorSuite, load_scenario, simulate_suite
from aeroid.model import NAMES

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "studies" / "scenarios" / "rocket_burnout.toml"


def _example():
    spec = importlib.util.spec_from_file_location(
        "make_axial_log", ROOT / "examples" / "make_axial_log.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main() -> None:
    """Run the seeds and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--first", type=int, default=0)
    args = parser.parse_args()
    example = _example()
    scenario = load_scenario(SCENARIO)
    truth = float(scenario.coefficient_vector[NAMES.index("Cx")])
    right, within, ratios, refused, worst = 0, 0, [], 0, []
    seeds = range(args.first, args.first + args.seeds)
    for seed in seeds:
        sim = simulate_suite(scenario.airframe, scenario.coefficient_vector,
                             scenario.manoeuvre, SensorSuite(**example.FLIGHT_COMPUTER),
                             rng=seed)
        log = example.axial_only(sim.log)
        fit = make_estimator("axial-drag", {}).fit(log, rng=1)
        right += bool(fit.success)
        error = abs(fit.theta[0] - truth) / fit.stderr[0]
        within += bool(error < 3.0)
        ratios.append(error)
        without = dataclasses.replace(log, airframe=log.airframe.replace(thrust_curve=None))
        bad = make_estimator("axial-drag", {}).fit(without, rng=1)
        refused += not bad.success
        worst.append(bad.info["fit_check"]["ratio"]["accel"])
        print(f"seed {seed}: with curve {'ok' if fit.success else 'FAILED'} Cx "
              f"{fit.theta[0]:.5f} +- {fit.stderr[0]:.5f} ({error:.2f} se); without "
              f"{'ok' if bad.success else 'FAILED'} (accel residual {worst[-1]:.3g} x noise)",
              flush=True)
    n = len(seeds)
    print(f"\n| {n} seeds ({args.first}-{args.first + n - 1}) | result |\n|---|---|")
    print(f"| with the curve: success | {right} of {n} |")
    print(f"| with the curve: Cx within 3 se | {within} of {n} (largest |error|/se "
          f"{max(ratios):.2f}, mean {np.mean(ratios):.2f}) |")
    print(f"| without the curve: refused | {refused} of {n} (accelerometer residual "
          f"{min(worst):.3g}-{max(worst):.3g} x noise) |")


if __name__ == "__main__":
    main()
