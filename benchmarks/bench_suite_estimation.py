"""Benchmark output-error on a sensor-suite log against the ideal log of the same flight.

Run by hand from the repository root (one process: ``--jobs 1`` in spirit)::

    python benchmarks/bench_suite_estimation.py --seeds 10

For each seed: the reference flight's window (``aeroid/data/reference-scenario.toml``,
5-6 s) logged twice, by the default :class:`~aeroid.flights.SensorSuite` (1000 Hz IMU with
biases of 0.02-0.2 m/s^2 and 0.001-0.005 rad/s and scale factors of 0.1-0.5 %, GNSS 10 Hz,
barometer 50 Hz, wrapped INS 100 Hz, no air data) and as the ideal 500 Hz log (the same
truth, the same IMU noise sd, no instrument errors, the true states). Fits:

- ``ideal``: output-error with its defaults on the ideal log;
- ``suite``: :func:`aeroid.reconstruction.reconstruct` of the suite log, its
  ``to_flight(imu="raw")``, output-error with ``imu_errors = "bias+scale"``,
  ``estimate_initial_velocity = true`` and ``initial_velocity_prior = "flight"`` (the
  reconstruction's u v w, good to 0.04-0.16 m/s, as a Gaussian prior with its sd);
- ``suite, velocity free``: the same without the prior;
- ``suite, velocity as reconstructed``: the same with the initial velocity held at the
  reconstruction's;
- ``suite, option off``: the raw readings taken as unbiased (a known-wrong input: how often
  the fit check refuses it);
- with ``--filters``, ``ekf suite`` and ``ukf suite``: the EKF and the UKF on the same
  raw flight with ``imu_errors = "bias+scale"`` and ``initial_velocity_sd_mps`` the
  largest of the reconstruction's sd of u, v, w at the first sample (their ratio to
  ``suite``: target <= 1.2).

Figures: mean |relative error| of the nine coefficients per fit and the ratio suite /
ideal (target <= 1.5), the largest |error| / standard error over the coefficients and
over the 9 biases and 9 scale factors (target <= 3), how often each fit succeeded.
Printed and written to ``benchmarks/results/suite_estimation.md``.
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from aeroid.flights import (  # noqa: E402
    GaussianNoise,
    SensorSuite,
    reference_scenario,
    simulate_scenario,
    simulate_suite,
)
from aeroid.model import NAMES, OUTPUT_CHANNELS  # noqa: E402
from aeroid.reconstruction import reconstruct  # noqa: E402
from baselines.output_error import OutputErrorEstimator  # noqa: E402

FITS = {
    "suite": {"imu_errors": "bias+scale", "estimate_initial_velocity": True,
              "initial_velocity_prior": "flight"},
    "suite, velocity free": {"imu_errors": "bias+scale", "estimate_initial_velocity": True},
    "suite, velocity as reconstructed": {"imu_errors": "bias+scale"},
    "suite, option off": {},
}


def _errors_truth(errors: dict[str, np.ndarray]) -> dict[str, float]:
    values = np.concatenate([errors["accel_bias"].ravel(), errors["gyro_bias"],
                             errors["accel_scale"].ravel(), errors["gyro_scale"]])
    names = [f"{p}{c}" for p in ("b", "s") for c in OUTPUT_CHANNELS]
    return dict(zip(names, values.tolist(), strict=True))


def one_seed(seed: int, filters: bool = False) -> dict[str, dict[str, float]]:
    """All fits of one seed: their figures by fit label."""
    from aeroid.estimation import make_estimator

    scenario = reference_scenario()
    truth = scenario.coefficient_vector
    suite = SensorSuite()
    sim = simulate_suite(scenario.airframe, truth, scenario.manoeuvre, suite, rng=seed)
    noise = GaussianNoise(accel_sd_mps2=suite.accel_noise_mps2,
                          rate_sd_radps=suite.gyro_noise_radps, position_sd_m=0.0)
    ideal = simulate_scenario(scenario, noise, rng=seed)
    start = time.perf_counter()
    raw = reconstruct(sim.log).to_flight(imu="raw")
    rec_s = time.perf_counter() - start
    out = {}
    flights = {"ideal": (ideal, {}), **{k: (raw, v) for k, v in FITS.items()}}
    if filters:
        sd = raw.metadata["initial_state_sd"]
        for name in ("ekf", "ukf"):
            flights[f"{name} suite"] = (raw, {"imu_errors": "bias+scale",
                                              "initial_velocity_sd_mps":
                                              max(sd["u"], sd["v"], sd["w"])})
    errors = _errors_truth(sim.errors)
    for label, (flight, options) in flights.items():
        start = time.perf_counter()
        if label[1:].startswith("kf"):
            res = make_estimator(label.split()[0], options).fit(flight, rng=seed)
        else:
            res = OutputErrorEstimator(**options).fit(flight, rng=seed)
        row = {"success": float(res.success), "wall_s": time.perf_counter() - start,
               "mean_rel": float(np.mean(np.abs(res.theta / truth - 1.0))),
               "max_z": float(np.max(np.abs(res.theta - truth) / res.stderr)),
               "rel": res.theta / truth - 1.0, "rel_sd": res.stderr / np.abs(truth)}
        if "imu_errors" in res.info:
            z = {n: abs(v - errors[n]) / res.info["imu_error_stderr"][n]
                 for n, v in res.info["imu_errors"].items()}
            row["bias_z"] = max(v for n, v in z.items() if n[0] == "b")
            row["scale_z"] = max(v for n, v in z.items() if n[0] == "s")
        if "suite" in label:
            row["wall_s"] += rec_s
        out[label] = row
    return out


def main() -> None:
    """Run the seeds, print and write the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="seeds 0..N-1")
    parser.add_argument("--filters", action="store_true",
                        help="also the EKF and the UKF with IMU-error states")
    args = parser.parse_args()
    runs = []
    for seed in range(args.seeds):
        runs.append(one_seed(seed, args.filters))
        r = runs[-1]
        fixed = r["suite, velocity as reconstructed"]
        print(f"seed {seed}: ideal {100 * r['ideal']['mean_rel']:.3f} %, suite "
              f"{100 * r['suite']['mean_rel']:.3f} % (ratio "
              f"{r['suite']['mean_rel'] / r['ideal']['mean_rel']:.2f}, max |z| "
              f"{r['suite']['max_z']:.2f}, biases {r['suite']['bias_z']:.2f}, scale "
              f"{r['suite']['scale_z']:.2f}, success {bool(r['suite']['success'])}); "
              f"velocity as reconstructed {100 * fixed['mean_rel']:.3f} % max |z| "
              f"{fixed['max_z']:.2f}; option off "
              f"success {bool(r['suite, option off']['success'])}", flush=True)
    labels = list(runs[0])
    lines = ["# Output-error on a sensor-suite log against the ideal log of the same flight", "",
             f"`python benchmarks/bench_suite_estimation.py --seeds {args.seeds}"
             f"{' --filters' if args.filters else ''}` on "
             f"{platform.processor() or platform.machine()}, Python "
             f"{platform.python_version()}, numpy {np.__version__}; reference window 5-6 s, "
             f"seeds 0-{args.seeds - 1}.", "",
             "| fit | succeeded | mean rel. error (mean over seeds) | worst seed | "
             "max coefficient |z| (worst seed) | seeds with a coefficient beyond 3 sd | "
             "max bias |z| | max scale-factor |z| | wall time per fit [s] (median) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for label in labels:
        rows = [r[label] for r in runs]

        def worst(key: str, rows: list = rows) -> str:
            values = [row[key] for row in rows if key in row]
            return f"{max(values):.2f}" if values else "-"

        lines.append(
            f"| {label} | {int(sum(r['success'] for r in rows))} of {len(rows)} | "
            f"{100 * np.mean([r['mean_rel'] for r in rows]):.3f} % | "
            f"{100 * max(r['mean_rel'] for r in rows):.3f} % | {worst('max_z')} | "
            f"{sum(r['max_z'] > 3 for r in rows)} | {worst('bias_z')} | {worst('scale_z')} | "
            f"{np.median([r['wall_s'] for r in rows]):.1f} |")
    names = NAMES
    lines += ["", "Per coefficient, RMS over the seeds of the relative error and the median "
              "relative standard error [%]:", "",
              "| fit | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for label in labels:
        rel = np.array([r[label]["rel"] for r in runs])
        sd = np.array([r[label]["rel_sd"] for r in runs])
        lines.append(f"| {label} | " + " | ".join(
            f"{100 * np.sqrt(np.mean(rel[:, j] ** 2)):.3g} ({100 * np.median(sd[:, j]):.3g})"
            for j in range(len(names))) + " |")
    ratios = [r["suite"]["mean_rel"] / r["ideal"]["mean_rel"] for r in runs]
    overall = (np.mean([r["suite"]["mean_rel"] for r in runs])
               / np.mean([r["ideal"]["mean_rel"] for r in runs]))
    lines += ["", f"Ratio suite / ideal of the mean relative error: {overall:.2f} over the "
              f"seeds (target <= 1.5); per seed median {np.median(ratios):.2f}, worst "
              f"{max(ratios):.2f}.", ""]
    for name in ("ekf", "ukf") if args.filters else ():
        ratio = (np.mean([r[f"{name} suite"]["mean_rel"] for r in runs])
                 / np.mean([r["suite"]["mean_rel"] for r in runs]))
        per_seed = [r[f"{name} suite"]["mean_rel"] / r["suite"]["mean_rel"] for r in runs]
        lines += [f"Ratio {name.upper()} / output-error on the suite: {ratio:.2f} over the "
                  f"seeds (target <= 1.2); per seed median {np.median(per_seed):.2f}, worst "
                  f"{max(per_seed):.2f}.", ""]
    lines.append("The suite fits' wall time includes the reconstruction.")
    print("\n".join(lines))
    out = ROOT / "benchmarks" / "results" / "suite_estimation.md"
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
