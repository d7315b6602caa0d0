"""Benchmark the consider covariance of an uncertain mass (aeroid.estimation._consider).

Run by hand from the repository root::

    python benchmarks/bench_consider.py            # writes benchmarks/results/consider.md
    python benchmarks/bench_consider.py --quick    # fewer seeds, prints only

1. Cost: on the reference flight (paper noise, seed 2026) each method's fit, then the two
   re-fits of ``S = d theta / d m`` (mass_sd_kg = 2.1, 3 %), cold (from the airframe's
   prior, as the fit: the default) and warm-started from the estimate.
2. A known-wrong mass: the coast (thrust 0) flown at 1.02 x the nominal mass, the
   airframe saying the nominal mass with a 3 % sd (the issue's residual propellant):
   over seeds, the share of flights whose every force coefficient (Cx, Cz*) lies within
   3 standard errors of its truth, with the widened se and with the method's own se;
   and the same with the mass right (scale 1, 3 % sd still given): how often the widened
   se are needlessly wide is the price (they cover; their ratio to the plain se is shown).
The machine is shared: wall times are indicative.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from aeroid.estimation import consider_covariance, make_estimator  # noqa: E402
from aeroid.flights import PaperNoise, load_scenario, simulate_scenario  # noqa: E402
from aeroid.model import NAMES  # noqa: E402

FORCES = [j for j, n in enumerate(NAMES) if n.startswith(("Cx", "Cz"))]
#: 3 % of the nominal mass, as the issue's study.
SD_FRACTION = 0.03
#: The coast mass above the nominal one (residual propellant), as the issue's study.
MASS_SCALE = 1.02


def cost_rows(methods: list[str]) -> list[str]:
    scenario = load_scenario(None)
    flight = simulate_scenario(scenario, PaperNoise(), rng=2026)
    flight = dataclasses.replace(flight, airframe=flight.airframe.replace(
        mass_sd_kg=SD_FRACTION * flight.airframe.mass_kg))
    rows = ["| method | fit [s] | S warm [s] | S cold [s] | re-fits | Cx se plain | "
            "Cx se with mass sd |", "|---|---|---|---|---|---|---|"]
    for name in methods:
        est = make_estimator(name, {})
        plain_flight = dataclasses.replace(flight, airframe=flight.airframe.replace(
            mass_sd_kg=0.0))
        est.fit(plain_flight, rng=0)  # warm-up (compilation)
        t0 = time.perf_counter()
        plain = est.fit(plain_flight, rng=0)
        fit_s = time.perf_counter() - t0
        warm = consider_covariance(est, flight, plain, rng=0, warm_start=True)
        cold = consider_covariance(est, flight, plain, rng=0)
        cx = NAMES.index("Cx")
        share = np.sqrt(plain.stderr[cx] ** 2 + cold.covariance[cx, cx])
        rows.append(f"| {name} | {fit_s:.3g} | {warm.wall_time_s:.3g} | "
                    f"{cold.wall_time_s:.3g} | {warm.n_refits} | {plain.stderr[cx]:.3g} | "
                    f"{share:.3g} |")
        print(rows[-1], flush=True)
    return rows


def coverage_rows(methods: list[str], seeds: int, scale: float = MASS_SCALE) -> list[str]:
    scenario = load_scenario(None)
    coast = scenario.airframe.replace(thrust_n=0.0)
    heavy = dataclasses.replace(scenario, airframe=coast.replace(
        mass_kg=coast.mass_kg * scale))
    told = coast.replace(mass_sd_kg=SD_FRACTION * coast.mass_kg)
    rows = ["| method | seeds | forces within 3 widened se | within 3 plain se | "
            "largest |z| widened | largest |z| plain | Cx se widened / plain |",
            "|---|---|---|---|---|---|---|"]
    for name in methods:
        est = make_estimator(name, {})
        wide, plain, zw, zp, ratio = 0, 0, 0.0, 0.0, []
        for seed in range(seeds):
            flight = simulate_scenario(heavy, PaperNoise(), rng=seed)
            flight = dataclasses.replace(flight, airframe=told)
            r = est.fit(flight, rng=seed)
            err = np.abs(r.theta - flight.true_coefficients)[FORCES]
            z_wide = err / r.stderr[FORCES]
            z_plain = err / r.consider.stderr_without[FORCES]
            wide += bool(np.all(z_wide <= 3.0))
            plain += bool(np.all(z_plain <= 3.0))
            zw, zp = max(zw, float(z_wide.max())), max(zp, float(z_plain.max()))
            cx = NAMES.index("Cx")
            ratio.append(r.stderr[cx] / r.consider.stderr_without[cx])
        rows.append(f"| {name} | {seeds} | {wide}/{seeds} | {plain}/{seeds} | {zw:.3g} | "
                    f"{zp:.3g} | {np.median(ratio):.3g} |")
        print(rows[-1], flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--methods", default="equation-error,output-error,ekf")
    parser.add_argument("--seeds", type=int, default=10)
    args = parser.parse_args()
    methods = args.methods.split(",")
    seeds = 3 if args.quick else args.seeds
    lines = ["# Consider covariance of an uncertain mass", "",
             "Command: `python benchmarks/bench_consider.py "
             f"--methods {args.methods} --seeds {seeds}`", "",
             "## Cost of S on the reference flight (mass_sd_kg 2.1)", ""]
    lines += cost_rows(methods)
    lines += ["", f"## Mass {MASS_SCALE} x nominal, {SD_FRACTION:.0%} sd given (coast)", ""]
    lines += coverage_rows(methods, seeds)
    lines += ["", f"## Mass right, {SD_FRACTION:.0%} sd given (coast)", ""]
    lines += coverage_rows(methods, seeds, scale=1.0)
    text = "\n".join(lines) + "\n"
    print(text)
    if not args.quick:
        out = Path(__file__).parent / "results" / "consider.md"
        out.write_text(text)


if __name__ == "__main__":
    main()
