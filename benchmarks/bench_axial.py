"""Measure the axial-drag method on the rocket coast's axial-only log against the full suite.

Run by hand from the repository root (one process; about 2 min per seed)::

    python benchmarks/bench_axial.py --seeds 5
    python benchmarks/bench_axial.py --axial-only --seeds 30   # ~15 s per seed

Per seed (0..N-1) the coast of ``studies/scenarios/rocket_coast.toml`` is logged by the
flight computer of ``examples/make_rocket_log.py`` twice: flown at the file's mass, and at
1.02 x it (the file saying 10 kg). From the same readings, the axial-only log
(``examples/make_axial_log.py``: the one sensor axis along the rocket, GNSS positions, the
barometer) and the full log (two triads, gyros, INS). Fits, the Cx table at Mach
:data:`KNOTS`:

* ``axial``: axial-drag (defaults: the trim's normal force in the model) on the
  axial-only log, mass exact (flown at the file's mass);
* ``axial+sd``: the same on the 1.02 x flight with ``mass_sd_kg = 0.3`` (3 %), the
  consider path's two re-fits in its standard errors;
* ``full``: output-error on the full log's raw-IMU flight (reconstructed;
  ``imu_errors = "bias+scale"``, initial velocity with the reconstruction's prior), the
  same table, mass exact; its se with the 3 % mass sd is ``sqrt(se^2 + (theta sd / m)^2)``
  (the closed form the consider path reproduces for a force coefficient, S = theta / m:
  README "Mass known roughly"; output-error's three fits would take 2 min a seed);
* ``flipped``: the axial-only log with the axial sign flipped in its mounting
  (``x=y, y=-x, z=z``), and ``wrong bias``: the right log fitted with a bias calibration
  of the wrong sign (``accel_bias_mps2`` = minus the seed's drawn body-x bias, sd 0.01;
  the right sign is fitted too);
* ``calibrated``: axial-drag with the drawn scale factor given as a calibration with sd
  0.001 (what a scale-factor calibration buys), mass exact.

Printed: per Cx point |error| / se and the se ratio axial / full, as Markdown tables.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
for path in (ROOT, ROOT / "examples"):
    if str(path) not in sys.path:
        sys.path.insert(0, str(path))

from make_axial_log import axial_only  # noqa: E402
from make_rocket_log import FLIGHT_COMPUTER, SCENARIO  # noqa: E402

from aeroid.flights import SensorSuite, axis_map, load_scenario, simulate_suite  # noqa: E402
from aeroid.model import NAMES, TableSpec  # noqa: E402
from aeroid.reconstruction import reconstruct  # noqa: E402
from baselines.axial_drag import AxialDragEstimator  # noqa: E402
from baselines.output_error import OutputErrorEstimator  # noqa: E402

#: The Cx table's knots [Mach] over the coast's Mach 0.9 -> 0.2.
KNOTS = (0.2, 0.4, 0.6, 0.9)
#: The mass the coast is flown at, as a multiple of the file's; the file's sd.
MASS_SCALE, MASS_SD_FRACTION = 1.02, 0.03
FULL = OutputErrorEstimator(imu_errors="bias+scale", estimate_initial_velocity=True,
                            initial_velocity_prior="flight")
WRONG_MOUNTING = "x=y, y=-x, z=z"
#: The sd of a scale-factor calibration (the drawn scale factor as its mean).
CALIBRATED_SCALE_SD = 0.001


def logs(seed: int, mass_scale: float) -> tuple[Any, Any, float, float]:
    """Return the full log, the axial-only log and the drawn body-x bias and scale factor."""
    scenario = load_scenario(SCENARIO)
    nominal = scenario.airframe.replace(tables=TableSpec((("Cx", KNOTS),)))
    truth = scenario.airframe.replace(mass_kg=nominal.mass_kg * mass_scale)
    sim = simulate_suite(truth, scenario.coefficient_vector, scenario.manoeuvre,
                         SensorSuite(**FLIGHT_COMPUTER), rng=seed)
    # the full log's airframe without [tables]: the reconstruction's density probe refuses
    # them (a limit of aeroid.reconstruction); the table goes on the flight it makes
    full = dataclasses.replace(sim.log, airframe=scenario.airframe)
    rotation = full["imu"].mounting.rotation
    truth_of = full.metadata["truth"]
    bias = float(rotation[0] @ np.asarray(truth_of["accel_bias"])[0])
    scale = float(np.abs(rotation[0]) @ np.asarray(truth_of["accel_scale"])[0])
    return full, dataclasses.replace(axial_only(full), airframe=nominal), bias, scale


def z_scores(result: Any, truth: float) -> np.ndarray:
    """|estimate - truth| / se of the Cx points."""
    j = [i for i, n in enumerate(result.names) if n.startswith("Cx")]
    return np.abs(result.theta[j] - truth) / result.stderr[j]


def cx_se(result: Any) -> np.ndarray:
    """The se of the Cx points."""
    return np.array([s for n, s in zip(result.names, result.stderr, strict=True)
                     if n.startswith("Cx")])


def one(seed: int) -> dict[str, Any]:
    """Run one seed (module docstring)."""
    cx = float(load_scenario(SCENARIO).coefficient_vector[NAMES.index("Cx")])
    full, axial, bias, scale = logs(seed, 1.0)
    method = AxialDragEstimator()
    plain = method.fit(axial, rng=seed)
    flight = reconstruct(full).to_flight(imu="raw")
    flight = dataclasses.replace(flight, airframe=flight.airframe.replace(
        tables=TableSpec((("Cx", KNOTS),))))
    reference = FULL.fit(flight, rng=seed)
    _, heavy_axial, _, _ = logs(seed, MASS_SCALE)
    sd = MASS_SD_FRACTION * heavy_axial.airframe.mass_kg
    heavy = method.fit(dataclasses.replace(
        heavy_axial, airframe=heavy_axial.airframe.replace(mass_sd_kg=sd)), rng=seed)
    full_se = cx_se(reference)
    j = [i for i, n in enumerate(reference.names) if n.startswith("Cx")]
    full_widened = np.sqrt(full_se**2 + (reference.theta[j] * MASS_SD_FRACTION) ** 2)
    flipped_log = dataclasses.replace(axial_only(full, axis_map(WRONG_MOUNTING)),
                                      airframe=axial.airframe)
    flipped = method.fit(flipped_log, rng=seed)
    wrong_bias = AxialDragEstimator(accel_bias_mps2=-bias, accel_bias_sd_mps2=0.01).fit(
        axial, rng=seed)
    right_bias = AxialDragEstimator(accel_bias_mps2=bias, accel_bias_sd_mps2=0.01).fit(
        axial, rng=seed)
    calibrated = AxialDragEstimator(accel_scale=scale, scale_sd=CALIBRATED_SCALE_SD).fit(
        axial, rng=seed)
    return {"calibrated_success": calibrated.success, "calibrated_z": z_scores(calibrated, cx),
            "calibrated_se": cx_se(calibrated), "plain_success": plain.success,
            "plain_z": z_scores(plain, cx),
            "plain_se": cx_se(plain), "full_success": reference.success,
            "full_z": z_scores(reference, cx), "full_se": full_se,
            "heavy_success": heavy.success, "heavy_z": z_scores(heavy, cx),
            "heavy_se": cx_se(heavy), "full_widened": full_widened,
            "checks": {**plain.info["fit_check"]["ratio"],
                       **plain.info["fit_check"]["priors"]}, "flipped": flipped.success,
            "flipped_message": flipped.message, "wrong_bias": wrong_bias.success,
            "wrong_bias_message": wrong_bias.message, "right_bias": right_bias.success,
            "time": plain.wall_time_s}


def coverage(seeds: range) -> None:
    """``--axial-only``: axial-drag alone on many seeds (mass exact): how often the fit check
    refuses a right fit, and the coverage of the Cx points' 95 % intervals."""
    cx = float(load_scenario(SCENARIO).coefficient_vector[NAMES.index("Cx")])
    z, refused = [], []
    for seed in seeds:
        _, axial, _, _ = logs(seed, 1.0)
        result = AxialDragEstimator().fit(axial, rng=seed)
        refused.append(not result.success)
        z.append(z_scores(result, cx))
        print(f"seed {seed}: success {result.success} {result.message} z "
              f"{np.array2string(z[-1], precision=3)}", flush=True)
    zs = np.array(z)
    print(f"\n{len(z)} seeds ({seeds.start}..{seeds.stop - 1}), axial-drag, mass exact, Cx at "
          f"Mach {', '.join(map(str, KNOTS))}: refused {sum(refused)} of {len(z)}; within "
          f"1.96 se per point {', '.join(f'{v:.2f}' for v in (zs < 1.96).mean(axis=0))}; "
          f"within 3 se {int((zs < 3).sum())} of {zs.size}; largest |error|/se {zs.max():.2f}")


def main() -> None:
    """Run the seeds and print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--axial-only", action="store_true",
                        help="axial-drag alone: refusals of right fits and coverage")
    args = parser.parse_args()
    if args.axial_only:
        coverage(range(args.first, args.first + args.seeds))
        return
    rows = []
    for seed in range(args.first, args.first + args.seeds):
        rows.append(one(seed))
        row = rows[-1]
        print(f"seed {seed}: " + "; ".join(
            f"{k} {np.array2string(np.asarray(v), precision=4)}" if not isinstance(v, dict)
            else f"{k} " + ", ".join(f"{a} {b:.3f}" for a, b in v.items())
            for k, v in row.items()), flush=True)
    n = len(rows)

    def stack(key: str) -> np.ndarray:
        return np.array([r[key] for r in rows])

    print(f"\n{n} seeds ({args.first}..{args.first + n - 1}), Cx table at Mach "
          f"{', '.join(map(str, KNOTS))}\n")
    print("| fit | success | points within 3 se | largest \\|error\\|/se |\n|---|---|---|---|")
    for label, key in (("axial-drag, mass exact", "plain"),
                       ("axial-drag, flown 1.02 x, 3 % mass sd", "heavy"),
                       ("axial-drag, scale factor calibrated to 0.1 %", "calibrated"),
                       ("output-error full suite, mass exact", "full")):
        z = stack(f"{key}_z")
        print(f"| {label} | {int(stack(f'{key}_success').sum())} of {n} | "
              f"{int((z < 3).sum())} of {z.size} | {z.max():.2f} |")
    ratio = stack("plain_se") / stack("full_se")
    widened = stack("heavy_se") / stack("full_widened")
    calibrated = stack("calibrated_se") / stack("full_se")

    def cell(r: np.ndarray) -> str:
        return f"{np.median(r):.2f} ({r.min():.2f}-{r.max():.2f})"

    print("\n| Mach | se axial / full, mass exact: median (range) | with 3 % mass sd | "
          "mass exact, scale calibrated |\n|---|---|---|---|")
    for i, knot in enumerate(KNOTS):
        print(f"| {knot} | {cell(ratio[:, i])} | {cell(widened[:, i])} | "
              f"{cell(calibrated[:, i])} |")
    checks = {k: np.array([r["checks"][k] for r in rows]) for k in rows[0]["checks"]}
    print("\nfit check ratios of the right fits (min-max): " + ", ".join(
        f"{k} {v.min():.3f}-{v.max():.3f}" for k, v in checks.items()))
    print(f"flipped axial sign: success {int(stack('flipped').sum())} of {n}; wrong-sign "
          f"bias calibration: success {int(stack('wrong_bias').sum())} of {n} (the right "
          f"calibration: {int(stack('right_bias').sum())} of {n})")
    print(f"e.g. {rows[0]['flipped_message']}\ne.g. {rows[0]['wrong_bias_message']}")


if __name__ == "__main__":
    main()
