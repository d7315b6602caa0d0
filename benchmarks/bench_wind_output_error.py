"""Output-error (and the filters) in a steady wind (issue 26): the wind estimated against still air.

Run by hand from the repository root (one process, the fits in turn: ``--jobs 1``)::

    python benchmarks/bench_wind_output_error.py                 # 6 seeds, writes results
    python benchmarks/bench_wind_output_error.py --seeds 2 --no-write
    python benchmarks/bench_wind_output_error.py --methods output-error ekf --seeds 6

``--methods``: the estimators to run (default output-error; ``ekf`` and ``ukf`` carry the
wind as three constant states, :mod:`baselines._kalman_wind`); with any other than
output-error alone the results go to ``results/wind_filters.md``.

Per seed ``k`` (``rng = k``): the reference scenario's flight with Gaussian IMU noise
(:class:`aeroid.flights.GaussianNoise` defaults: 0.05 m/s^2, 0.005 rad/s) in still air,
and the same manoeuvre in a steady wind of 5 m/s (default north 3, east 4, down 0 m/s:
3 m/s along the reference flight's path, 4 across it), no turbulence. Fits:

* ``still / off``: output-error (defaults) on the still-air flight: the yardstick;
* ``still / on``: with ``estimate_wind`` on the still-air flight (the option's cost);
* ``wind / off``: defaults on the windy flight: the known-wrong model, which the fit
  check must refuse;
* ``wind / on``: ``estimate_wind`` on the windy flight.

Reported per fit kind: successes, the mean over seeds of the mean |relative error| of
the nine coefficients [%] and of their mean relative standard error (Cramér-Rao: the
expected error, less noisy than a few seeds' errors), the largest |error| / se over
coefficients (and wind components), and how many runs have every coefficient and wind
component within 3 se.
Targets (issue 26): ``wind / on`` mean error <= 1.2x ``still / off``'s, every coefficient
and wind component within 3 se; ``wind / off`` refused.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # shared 2-core machine
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import datetime as dt  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import aeroid  # noqa: E402
from aeroid.flights import Wind, make_noise, reference_scenario, simulate  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "wind_output_error.md"
RESULTS_FILTERS = Path(__file__).parent / "results" / "wind_filters.md"
WITHIN_SE = 3.0


def run(seeds: int, wind: tuple[float, float, float], methods: tuple[str, ...] = (
        "output-error",)) -> tuple[dict, list[str]]:
    """Fit every kind on every seed; return per-kind rows and the per-run lines."""
    s = reference_scenario()
    truth = s.coefficient_vector
    windy = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=wind))
    noise = make_noise("gaussian")
    kinds: dict = {(m, air, on): [] for m in methods
                   for air, on in (("still", False), ("still", True), ("wind", False),
                                   ("wind", True))}
    lines = []
    for seed in range(1, seeds + 1):
        flights = {"still": simulate(s.airframe, truth, s.manoeuvre, noise, rng=seed),
                   "wind": simulate(s.airframe, truth, windy, noise, rng=seed)}
        for (method, air, on), rows in kinds.items():
            est = aeroid.make_estimator(method, {"estimate_wind": on})
            start = time.perf_counter()
            r = est.fit(flights[air], rng=seed)
            wall = time.perf_counter() - start
            z = np.abs(r.theta - truth) / r.stderr
            rel = 100.0 * np.mean(np.abs(r.theta / truth - 1.0))
            if on:
                w_true = np.array(wind if air == "wind" else (0.0, 0.0, 0.0))
                w, w_sd = np.array(r.info["wind_ned_mps"]), np.array(r.info["wind_stderr_mps"])
                z = np.concatenate([z, np.abs(w - w_true) / w_sd])
                extra = (f" wind {np.round(w, 2).tolist()} +- {np.round(w_sd, 2).tolist()}")
            else:
                extra = ""
            rows.append({"success": r.success, "rel": rel, "zmax": float(np.max(z)),
                         "se": 100.0 * float(np.mean(r.stderr / np.abs(truth))),
                         "within": bool(np.all(z < WITHIN_SE)), "wall": wall})
            lines.append(f"seed {seed} {method} {air:5s} {'on ' if on else 'off'} "
                         f"success={r.success} "
                         f"mean|err|={rel:.3f}% max z={np.max(z):.2f} {wall:.1f}s{extra}"
                         + ("" if r.success else f" [{r.message[:90]}]"))
            print(lines[-1], flush=True)
    return kinds, lines


def table(kinds: dict) -> str:
    """The summary table (markdown)."""
    out = ["| method: flight / estimate_wind | success | mean abs rel error [%] | x still/off "
           "| mean rel se [%] | x still/off | max err/se | all within 3 se | wall [s] (median) |",
           "|---|---|---|---|---|---|---|---|---|"]
    for (method, air, on), rows in kinds.items():
        base = np.mean([row["rel"] for row in kinds[(method, "still", False)]])
        base_se = np.mean([row["se"] for row in kinds[(method, "still", False)]])
        rel = np.mean([row["rel"] for row in rows])
        se = np.mean([row["se"] for row in rows])
        out.append(f"| {method}: {air} / {'on' if on else 'off'} | "
                   f"{sum(row['success'] for row in rows)}/{len(rows)} | {rel:.3f} | "
                   f"{rel / base:.2f} | {se:.3f} | {se / base_se:.2f} | "
                   f"{max(row['zmax'] for row in rows):.2f} | "
                   f"{sum(row['within'] for row in rows)}/{len(rows)} | "
                   f"{np.median([row['wall'] for row in rows]):.1f} |")
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=6)
    parser.add_argument("--wind", type=float, nargs=3, default=(3.0, 4.0, 0.0),
                        metavar=("NORTH", "EAST", "DOWN"))
    parser.add_argument("--methods", nargs="+", default=["output-error"])
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    kinds, lines = run(args.seeds, tuple(args.wind), tuple(args.methods))
    results = RESULTS if args.methods == ["output-error"] else RESULTS_FILTERS
    text = table(kinds)
    print(text)
    if not args.no_write:
        results.parent.mkdir(exist_ok=True)
        results.write_text(
            f"# {', '.join(args.methods)} in a steady wind ({dt.date.today()})\n\n"
            f"`python benchmarks/bench_wind_output_error.py --methods {' '.join(args.methods)}"
            f" --seeds {args.seeds} --wind "
            f"{' '.join(f'{w:g}' for w in args.wind)}` (one process, fits in turn)\n\n"
            f"{text}\n\nPer run:\n\n```\n" + "\n".join(lines) + "\n```\n")
        print(f"wrote {results}")


if __name__ == "__main__":
    main()
