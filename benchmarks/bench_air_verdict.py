"""Equation-error's verdict with air data: known-wrong fits caught, correct ones refused.

Run by hand from the repository root (one process)::

    python benchmarks/bench_air_verdict.py                 # 20 seeds, writes results
    python benchmarks/bench_air_verdict.py --seeds 4 --no-write

Per seed ``k`` (``rng = k``) the reference flight with the tactical Gaussian IMU and a
probe drawn by the noise model (alpha, beta 0.1 deg; with or without an airspeed channel
of 0.5 m/s), fitted by equation-error with ``air_data = "measured"`` (its defaults: the
Kalman-smoothed wind, :mod:`baselines._ee_air`'s consider term):

* known wrong: a steady wind of 5 m/s with 3 m/s **along** the path and no airspeed
  channel (the along-path wind biases every coefficient by ~1.2 %, Cx ~70 of its plain
  se); Dryden turbulence of sd 1 and 3 m/s in that wind without an airspeed channel (the
  gusts along the path change the dynamic pressure sample by sample, unseen);
* correct: a 5 m/s crosswind without an airspeed channel (no along-path wind: the fit is
  right); the steady 3 / 4 wind and Dryden sd 1 and 3 m/s with the airspeed channel.

A fit is **caught** when it is refused (``success = False``: the fit check, or the
turbulence-without-airspeed refusal of :func:`baselines._ee_air.refuse_unseen_gusts`;
the column "fit check's size test" counts the fits whose worst residual is above 3x its
noise level, ``info["fit_check"]``, whoever refused them first). Reported per
condition: refused / runs with the exact (Clopper-Pearson) 95 % interval of the rate
(:meth:`scipy.stats.binomtest`), the coverage of the 95 % intervals (coefficient-runs
with |error| <= 1.96 se), the runs whose largest |error| / se exceeds 3, and, for the
steady winds, the same coverage with the plain covariance (the consider term taken out:
``info["air_data_wind_consider"]``).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # shared 2-core machine
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import datetime as dt  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

from aeroid.flights import Wind, make_noise, reference_scenario, simulate  # noqa: E402
from baselines.equation_error import EquationErrorEstimator  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "air_verdict.md"
WIND = (3.0, 4.0, 0.0)
VANE_RAD = float(np.radians(0.1))
AIRSPEED_SD_MPS = 0.5
L_M = 533.4
WITH_AIRSPEED = make_noise("gaussian", alpha_sd_rad=VANE_RAD, beta_sd_rad=VANE_RAD,
                           airspeed_sd_mps=AIRSPEED_SD_MPS)
NO_AIRSPEED = make_noise("gaussian", alpha_sd_rad=VANE_RAD, beta_sd_rad=VANE_RAD)
#: The fit check's size test: a residual RMS above this multiple of its noise level
#: (aeroid.estimation._fitcheck's RATIO_LIMIT) refuses the fit.
FIT_CHECK_RATIO = 3.0
#: (label, wind, noise model, known wrong?)
CONDITIONS = (
    ("wind 3 along + 4 across, no airspeed", Wind(steady_ned_mps=WIND), NO_AIRSPEED, True),
    ("wind + Dryden sd 1, no airspeed", Wind(steady_ned_mps=WIND, turbulence_sd_mps=1.0,
                                             scale_length_m=L_M), NO_AIRSPEED, True),
    ("wind + Dryden sd 3, no airspeed", Wind(steady_ned_mps=WIND, turbulence_sd_mps=3.0,
                                             scale_length_m=L_M), NO_AIRSPEED, True),
    ("crosswind 5, no airspeed", Wind(steady_ned_mps=(0.0, 5.0, 0.0)), NO_AIRSPEED, False),
    ("wind 3 along + 4 across, airspeed", Wind(steady_ned_mps=WIND), WITH_AIRSPEED, False),
    ("wind + Dryden sd 1, airspeed", Wind(steady_ned_mps=WIND, turbulence_sd_mps=1.0,
                                          scale_length_m=L_M), WITH_AIRSPEED, False),
    ("wind + Dryden sd 3, airspeed", Wind(steady_ned_mps=WIND, turbulence_sd_mps=3.0,
                                          scale_length_m=L_M), WITH_AIRSPEED, False),
)


def run(seeds: int) -> tuple[list[str], list[str]]:
    """Fit every condition on every seed; return the table rows and the per-run lines."""
    s = reference_scenario()
    truth = s.coefficient_vector
    rows, lines = [], []
    for label, wind, noise, wrong in CONDITIONS:
        m = dataclasses.replace(s.manoeuvre, wind=wind)
        refused, fitcheck, cover, plain_cover, big, errors = 0, 0, [], [], 0, []
        for seed in range(1, seeds + 1):
            flight = simulate(s.airframe, truth, m, noise, rng=seed)
            r = EquationErrorEstimator(air_data="measured").fit(flight)
            z = np.abs(r.theta - truth) / r.stderr
            consider = r.info.get("air_data_wind_consider")
            if consider is not None:
                g, c = consider["sensitivity"], consider["covariance_mps2"]
                share = g @ c @ g.T
                if consider["along_path_sd_mps"] is not None:
                    g_along = consider["along_path_sensitivity"]
                    share = share + consider["along_path_sd_mps"] ** 2 * np.outer(g_along,
                                                                                  g_along)
                plain = np.sqrt(np.abs(np.diag(r.covariance - share)))
                plain_cover.append(np.abs(r.theta - truth) <= 1.96 * plain)
            refused += not r.success
            check = r.info["fit_check"]
            fitcheck += bool(check["ratio"][check["worst"]] > FIT_CHECK_RATIO)
            cover.append(z <= 1.96)
            big += bool(z.max() > 3)
            errors.append(np.mean(np.abs(r.theta / truth - 1)) * 100)
            lines.append(f"{label} seed {seed}: success={r.success} mean |err| "
                         f"{errors[-1]:.3f} % max |err|/se {z.max():.2f} "
                         f"{r.message[:80]}")
            print(lines[-1], flush=True)
        ci = stats.binomtest(refused, seeds).proportion_ci(method="exact")
        plain_text = (f"{np.mean(plain_cover):.2f}" if plain_cover else "-")
        rows.append(f"| {label} | {'known wrong' if wrong else 'correct'} | "
                    f"{refused}/{seeds} | {ci.low:.2f}-{ci.high:.2f} | {fitcheck}/{seeds} | "
                    f"{np.mean(errors):.3f} | "
                    f"{np.mean(cover):.2f} | {plain_text} | {big}/{seeds} |")
    return rows, lines


def main() -> None:
    """Run and print (and write) the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    rows, lines = run(args.seeds)
    text = "\n".join(["| flight | fit | refused | exact 95 % interval of the rate | fit "
                      "check's size test | mean abs rel error [%] | coverage | coverage, plain "
                      "covariance | runs with max abs err/se > 3 |",
                      "|---|---|---|---|---|---|---|---|---|",
                      *rows])
    print(text)
    if not args.no_write:
        RESULTS.write_text(
            f"# Equation-error's verdict with air data ({dt.date.today()})\n\n"
            f"`python benchmarks/bench_air_verdict.py --seeds {args.seeds}`\n\n{text}\n\n"
            "```\n" + "\n".join(lines) + "\n```\n")


if __name__ == "__main__":
    main()
