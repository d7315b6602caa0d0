"""Benchmark the flight-path reconstruction: cost per second of flight, and its calibration.

Run by hand from the repository root::

    python benchmarks/bench_reconstruction.py                 # cost, then 10 seeds
    python benchmarks/bench_reconstruction.py --seeds 0       # cost only
    python benchmarks/bench_reconstruction.py --seeds 20 --equation-error

Cost: the reference flight (``aeroid/data/reference-scenario.toml``) logged by the
default :class:`~aeroid.flights.SensorSuite` (1000 Hz IMU, 10 Hz GNSS, 50 Hz barometer,
100 Hz INS), windows of 1 s (5-6 s) and 4 s (2-6 s); the wall time of
:func:`aeroid.reconstruction.reconstruct` (filter and smoother; the log already in
memory), best and median of three, per second of flight and per IMU sample. Calibration:
over seeds 0..N-1 of the 1-s window, the fraction of samples whose error lies within
3 sd per state, the largest |error| / sd of the 18 instrument errors, and the mean NIS
per dof per aiding source (1 when the stated noise sd fit) and how often the residual
check (chi-square, two-sided level 0.002) refuses these correct runs. With
``--equation-error``, today's equation-error fitted on the reconstruction's Flight for
three suites (default; no scale-factor errors; no instrument errors). Results are printed and
written to ``benchmarks/results/reconstruction.md``.
"""

from __future__ import annotations

import argparse
import dataclasses
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from aeroid.flights import reference_scenario, simulate_suite, wrap_angle  # noqa: E402
from aeroid.reconstruction import STATES, reconstruct  # noqa: E402

WINDOWS = ((5.0, 6.0), (2.0, 6.0))
REPEATS = 3
CHECKED = ("u", "v", "w", "phi", "theta", "psi", "pn", "pe", "pd")


def cost(lines: list[str]) -> None:
    """Time the reconstruction of each window."""
    scenario = reference_scenario()
    lines += ["| window [s] | IMU samples | best [s] | median [s] | s per s of flight | "
              "ms per IMU sample |", "|---|---|---|---|---|---|"]
    for window in WINDOWS:
        manoeuvre = dataclasses.replace(scenario.manoeuvre, window_s=window)
        log = simulate_suite(scenario.airframe, scenario.coefficient_vector, manoeuvre,
                             rng=1).log
        times = []
        for _ in range(REPEATS):
            start = time.perf_counter()
            reconstruct(log)
            times.append(time.perf_counter() - start)
        n = len(log["imu"].t)
        span = window[1] - window[0]
        best, median = min(times), float(np.median(times))
        lines.append(f"| {window[0]:g}-{window[1]:g} | {n} | {best:.2f} | {median:.2f} | "
                     f"{best / span:.2f} | {1e3 * best / n:.2f} |")
        print(lines[-1], flush=True)


def calibration(lines: list[str], seeds: int) -> None:
    """Coverage of the 3-sd bands and the NIS over ``seeds`` noise draws."""
    scenario = reference_scenario()
    within = {name: [] for name in CHECKED}
    worst_bias, nis = [], {"gnss": [], "baro": [], "ins": []}
    refused = {source: 0 for source in nis}
    for seed in range(seeds):
        sim = simulate_suite(scenario.airframe, scenario.coefficient_vector,
                             scenario.manoeuvre, rng=seed)
        rec = reconstruct(sim.log)
        for name in CHECKED:
            err = rec.table[name].to_numpy() - sim.truth[name]
            if name in ("phi", "psi"):
                err = wrap_angle(err)
            within[name].append(np.mean(np.abs(err) < 3 * rec.table[f"sd_{name}"].to_numpy()))
        e = sim.errors
        truth = np.concatenate([e["accel_bias"].ravel(), e["gyro_bias"],
                                e["accel_scale"].ravel(), e["gyro_scale"]])
        first = rec.table.iloc[0]
        z = [(first[n] - v) / first[f"sd_{n}"] for n, v in zip(STATES[10:], truth, strict=True)]
        worst_bias.append(float(np.max(np.abs(z))))
        for source in nis:
            nis[source].append(rec.nis[source]["mean_nis_per_dof"])
            refused[source] += not rec.nis[source]["consistent"]
        print(f"seed {seed}: worst instrument |z| {worst_bias[-1]:.2f}, NIS "
              + ", ".join(f"{s} {v[-1]:.2f}" for s, v in nis.items()), flush=True)
    lines += ["", f"Calibration over seeds 0-{seeds - 1} (window 5-6 s):", "",
              "| state | min fraction within 3 sd | mean fraction |", "|---|---|---|"]
    lines += [f"| {n} | {min(v):.3f} | {np.mean(v):.3f} |" for n, v in within.items()]
    lines += ["", f"Instrument errors: worst |error| / sd over the 18 and the seeds "
              f"{max(worst_bias):.2f}; runs with one beyond 3: "
              f"{sum(b > 3 for b in worst_bias)} of {seeds}.", "",
              "| source | mean NIS per dof: min | median | max | runs refused by the "
              "residual check |", "|---|---|---|---|---|"]
    lines += [f"| {s} | {min(v):.2f} | {np.median(v):.2f} | {max(v):.2f} | "
              f"{refused[s]} of {seeds} |" for s, v in nis.items()]


def equation_error(lines: list[str]) -> None:
    """Today's equation-error on the reconstruction's Flight, three suites of one seed."""
    from aeroid.estimation import make_estimator
    from aeroid.flights import SensorSuite

    scenario = reference_scenario()
    suites = {"default (biases and scale factors)": SensorSuite(),
              "no scale-factor errors": SensorSuite(scale_factor=(0.0, 0.0)),
              "no scale-factor errors, no biases": SensorSuite(
                  scale_factor=(0.0, 0.0), accel_bias_mps2=(0.0, 0.0),
                  gyro_bias_radps=(0.0, 0.0))}
    lines += ["", "Equation-error on `Reconstruction.to_flight()` (window 5-6 s, seed 2026):",
              "", "| suite | success | mean relative error | message |", "|---|---|---|---|"]
    for label, suite in suites.items():
        sim = simulate_suite(scenario.airframe, scenario.coefficient_vector,
                             scenario.manoeuvre, suite, rng=2026)
        result = make_estimator("equation-error").fit(reconstruct(sim.log).to_flight(), rng=0)
        error = np.mean(np.abs(result.theta / scenario.coefficient_vector - 1.0))
        lines.append(f"| {label} | {result.success} | {error:.4f} | "
                     f"{result.message.split(';')[0]} |")
        print(lines[-1], flush=True)


def main() -> None:
    """Run the benchmark, print and write the results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="calibration seeds (0: none)")
    parser.add_argument("--equation-error", action="store_true",
                        help="also fit equation-error on three reconstructions")
    args = parser.parse_args()
    lines = ["# Flight-path reconstruction: cost and calibration", "",
             f"`python benchmarks/bench_reconstruction.py --seeds {args.seeds}"
             f"{' --equation-error' if args.equation_error else ''}` on "
             f"{platform.processor() or platform.machine()}, Python "
             f"{platform.python_version()}, numpy {np.__version__}.", ""]
    cost(lines)
    if args.seeds:
        calibration(lines, args.seeds)
    if args.equation_error:
        equation_error(lines)
    out = ROOT / "benchmarks" / "results" / "reconstruction.md"
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
