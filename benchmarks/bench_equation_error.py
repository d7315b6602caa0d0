"""Equation-error's smoothing under each noise model, and the gyro-only floor of Cl0, Clp.

Run by hand from the repository root::

    python benchmarks/bench_equation_error.py             # 20 seeds; writes the results file
    python benchmarks/bench_equation_error.py --seeds 5   # prints only

For each noise model (the paper's eq. 43 with its 10 % sensor-position error; the
Gaussian tactical IMU, :class:`aeroid.flights.GaussianNoise` defaults; none) and seeds
1..N, one flight of the reference scenario is simulated and the ``equation-error``
baseline is fitted in its two forms (two-step, the default, and ``one_step``) with
``smoothing`` = both, forces and none (the same flights for all six). Reported per
condition: the mean |error| in % of the truth per coefficient and over the nine, and
the coverage of the nominal 95 % intervals (``|error| <= 1.96 stderr``, the default
Newey-West standard errors) per coefficient and over the nine. The gyro-only floor of
Cl0 and Clp
(:func:`aeroid.estimation.gyro_only_floor`) is given at the truth with the noise
model's own sd of p (eq. 43: ``|p| xi / sqrt(3)`` per sample), as a standard deviation
and as the mean |error| of an unbiased Gaussian estimator at that floor
(``sqrt(2 / pi)`` sd).
"""

from __future__ import annotations

import argparse
import datetime as dt
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from aeroid.estimation import gyro_only_floor
from aeroid.flights._noise import GaussianNoise, NoNoise, PaperNoise
from aeroid.flights._scenario import reference_scenario
from aeroid.flights._simulate import simulate_scenario
from aeroid.model._coefficients import NAMES
from baselines.equation_error import EquationErrorEstimator

RESULTS = Path(__file__).parent / "results" / "equation_error.md"
SMOOTHINGS = ("both", "forces", "none")
FORMS = ("two-step", "one-step")
NOISES = (("paper (eq. 43, positions +-10 %)", PaperNoise()),
          ("gaussian tactical IMU", GaussianNoise()),
          ("none", NoNoise()))
Z95 = 1.959963984540054
ROLL = [NAMES.index("Cl0"), NAMES.index("Clp")]


def measure(n_seeds: int) -> tuple[list[str], dict]:
    scenario = reference_scenario()
    clean = simulate_scenario(scenario, NoNoise(), rng=0)
    truth = clean.true_coefficients
    lines, summary = [], {}
    conditions = [(form, s) for form in FORMS for s in SMOOTHINGS]
    for label, noise in NOISES:
        errors = {c: [] for c in conditions}
        covered = {c: [] for c in conditions}
        for seed in range(1, n_seeds + 1):
            flight = simulate_scenario(scenario, noise, rng=seed)
            for form, smoothing in conditions:
                result = EquationErrorEstimator(smoothing=smoothing,
                                                one_step=form == "one-step").fit(flight)
                err = np.abs(result.theta - truth)
                errors[form, smoothing].append(err / np.abs(truth) * 100)
                covered[form, smoothing].append(err <= Z95 * result.stderr)
        lines += [f"### {label}", "",
                  "| form | smoothing | " + " | ".join(NAMES) + " | mean | coverage (9) |",
                  "|---|---|" + "---:|" * (len(NAMES) + 2)]
        for form, smoothing in conditions:
            e = np.mean(errors[form, smoothing], axis=0)
            c = np.mean(covered[form, smoothing], axis=0)
            lines.append(f"| {form} | {smoothing} | " + " | ".join(f"{v:.3g}" for v in e)
                         + f" | {e.mean():.3g} | {c.mean():.2f} |")
            lines.append("| | coverage | " + " | ".join(f"{v:.2f}" for v in c) + " | | |")
            summary[label, form, smoothing] = (e.mean(), e[ROLL], c.mean(), c[ROLL])
        if not isinstance(noise, NoNoise):
            if isinstance(noise, PaperNoise):
                sd = np.abs(clean["p"]) * noise.rates_xi / math.sqrt(3.0)
            else:
                sd = noise.rate_sd_radps
            floor = gyro_only_floor(clean, truth, noise_sd=sd) / np.abs(truth[ROLL]) * 100
            mean_abs = math.sqrt(2.0 / math.pi) * floor
            lines += ["", f"Gyro-only floor at the truth: Cl0 {floor[0]:.3g} %, Clp "
                      f"{floor[1]:.3g} % (sd); as a mean |error|: {mean_abs[0]:.3g} %, "
                      f"{mean_abs[1]:.3g} %."]
        lines.append("")
    return lines, summary


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    args = parser.parse_args(argv)
    start = time.time()
    load = os.getloadavg()
    lines, _ = measure(args.seeds)
    head = [
        "# Equation-error: smoothing under each noise model, gyro-only floor of Cl0, Clp", "",
        f"Command: `python benchmarks/bench_equation_error.py --seeds {args.seeds}` "
        f"(repository root), {dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC, "
        f"{time.time() - start:.0f} s.",
        f"Machine: {platform.machine()}, {os.cpu_count()} CPU cores, Python "
        f"{platform.python_version()}, numpy {np.__version__}; load average at the start "
        f"{load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} (shared machine; no timings here).",
        "",
        f"Reference scenario, seeds 1..{args.seeds} per noise model (the same flights for "
        "the six fits), equation-error (two-step and one-step) with its default Newey-West "
        "standard errors. Mean |error| in % of the truth; coverage: fraction of runs with "
        "|error| <= 1.96 standard errors (nominal 0.95).", "",
    ]
    text = "\n".join(head + lines)
    print(text)
    if args.seeds >= 20:
        RESULTS.write_text(text)
        print(f"wrote {RESULTS}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
