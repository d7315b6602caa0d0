"""The EKF and UKF with air data as measured outputs, in a 5 m/s steady wind (issue 26).

Run by hand from the repository root (one process, the fits in turn: ``--jobs 1``)::

    python benchmarks/bench_kalman_air.py --seeds 8            # writes results/kalman_air.md
    python benchmarks/bench_kalman_air.py --seeds 2 --no-write --fits ekf-wind-air

Per seed ``k`` (``rng = k`` for the flight, ``[k, 26]`` for the probe): the reference
scenario with Gaussian IMU noise in still air and in a steady wind of 5 m/s (north 3,
along the path; east 4, across), the probe's readings those of
``bench_air_data_outputs.py`` (:func:`with_probe`: the simulator's true states and wind
at the c.g., alpha and beta with a factor +2 % and offsets +2 / -1 mrad and 0.1 deg of
white noise, the airspeed with 0.5 m/s). Fits (``--fits``; defaults otherwise):

* ``ekf-still``: the EKF on the still flight, still air assumed, air data ignored (the
  yardstick);
* ``ekf-wind``: ``estimate_wind`` on the windy flight (smoothed passes, no air data);
* ``ekf-wind-air``: ``estimate_wind, air_data = measured`` on the windy flight;
* ``ekf-still-air``: the same on the still flight;
* ``ekf-still-wind``: ``estimate_wind`` on the still flight (no air data);
* ``ukf-wind``, ``ukf-still-wind``, ``ukf-wind-air``: the UKF as the EKF's (``passes =
  auto``: smoothed with ``estimate_wind``, :mod:`baselines._kalman_ukf_smoother`);
  ``ukf-wind-carried``, ``ukf-wind-air-carried``: with ``passes = carried``.

Reported per fit: successes (fit check and the passes' verdict), the mean |relative
error| of the nine coefficients [%], its ratio to ``ekf-still``'s, the mean relative se,
the largest |error| / se over the coefficients and wind components, how many runs have
all of them within 3 se, the north (along-path) wind's mean |error| and mean sd, the
calibration parameters within 3 se, and the mean wall time.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # shared 2-core machine
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import datetime as dt  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import aeroid  # noqa: E402
from aeroid.flights import Wind, make_noise, reference_scenario, simulate  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
from bench_air_data_outputs import CALIBRATION, WIND, with_probe  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "kalman_air.md"
WITHIN_SE = 3.0
FITS = {
    "ekf-still": ("ekf", "still", {}),
    "ekf-wind": ("ekf", "wind", {"estimate_wind": True}),
    "ekf-wind-air": ("ekf", "wind", {"estimate_wind": True, "air_data": "measured"}),
    "ekf-still-air": ("ekf", "still", {"estimate_wind": True, "air_data": "measured"}),
    "ekf-still-wind": ("ekf", "still", {"estimate_wind": True}),
    "ukf-wind": ("ukf", "wind", {"estimate_wind": True}),
    "ukf-wind-carried": ("ukf", "wind", {"estimate_wind": True, "passes": "carried"}),
    "ukf-still-wind": ("ukf", "still", {"estimate_wind": True}),
    "ukf-wind-air": ("ukf", "wind", {"estimate_wind": True, "air_data": "measured"}),
    "ukf-wind-air-carried": ("ukf", "wind", {"estimate_wind": True, "air_data": "measured",
                                             "passes": "carried"}),
}


def run(seeds: int, chosen: tuple[str, ...]) -> tuple[dict, list[str]]:
    """Fit every chosen kind on every seed; return per-kind rows and the log lines."""
    s = reference_scenario()
    truth = s.coefficient_vector
    kinds: dict[str, list] = {name: [] for name in chosen}
    lines = []
    for seed in range(1, seeds + 1):
        flights = {}
        for air, wind in (("still", (0.0, 0.0, 0.0)), ("wind", WIND)):
            m = s.manoeuvre if air == "still" else dataclasses.replace(
                s.manoeuvre, wind=Wind(steady_ned_mps=wind))
            flights[air] = (with_probe(simulate(s.airframe, truth, m, make_noise("gaussian"),
                                                rng=seed), wind,
                                       np.random.default_rng([seed, 26])), np.array(wind))
        for name in chosen:
            method, air, options = FITS[name]
            flight, wind = flights[air]
            start = time.perf_counter()
            r = aeroid.make_estimator(method, options).fit(flight, rng=seed)
            took = time.perf_counter() - start
            err = np.abs(r.theta / truth - 1.0) * 100.0
            z = list(np.abs(r.theta - truth) / r.stderr)
            north = (np.nan, np.nan)
            if "wind_ned_mps" in r.info:
                w, sd = np.array(r.info["wind_ned_mps"]), np.array(r.info["wind_stderr_mps"])
                z += list(np.abs(w - wind) / sd)
                north = (abs(w[0] - wind[0]), sd[0])
            cal = r.info.get("air_data", {})
            cal_ok = sum(abs(cal["calibration"][k] - v) <= WITHIN_SE
                         * cal["calibration_stderr"][k]
                         for k, v in CALIBRATION.items()) if cal else np.nan
            kinds[name].append((r.success, err.mean(), np.mean(r.stderr / np.abs(truth)) * 100,
                                max(z), north, cal_ok, took))
            noise = cal.get("noise_sd", {})
            lines.append(f"seed {seed} {name}: success={r.success} mean |err| {err.mean():.3f} "
                         f"% max |err|/se {max(z):.2f} north |err| {north[0]:.3f} +- "
                         f"{north[1]:.3f} m/s calibration within 3 se {cal_ok}/4 noise sd "
                         + " ".join(f"{c} {v:.3g}" for c, v in noise.items())
                         + f" passes {r.info.get('passes')} {took:.1f} s {r.message[:90]}")
            print(lines[-1], flush=True)
    return kinds, lines


def summary(kinds: dict) -> str:
    """The summary table (markdown)."""
    base = (float(np.mean([row[1] for row in kinds["ekf-still"]]))
            if kinds.get("ekf-still") else np.nan)
    out = ["| fit | success | mean abs rel error [%] | x ekf-still | mean rel se [%] | "
           "max err/se | all within 3 se | north wind mean abs err / sd [m/s] | "
           "calibration within 3 se | mean time [s] |", "|---|---|---|---|---|---|---|---|---|---|"]
    for name, rows in kinds.items():
        rel = float(np.mean([row[1] for row in rows]))
        north = np.array([row[4] for row in rows])
        cal = [row[5] for row in rows if np.isfinite(row[5])]
        out.append(
            f"| {name} | {sum(row[0] for row in rows)}/{len(rows)} | {rel:.3f} | "
            f"{rel / base:.2f} | {np.mean([row[2] for row in rows]):.3f} | "
            f"{max(row[3] for row in rows):.2f} | "
            f"{sum(row[3] <= WITHIN_SE for row in rows)}/{len(rows)} | "
            + ("-" if np.all(np.isnan(north)) else
               f"{np.nanmean(north[:, 0]):.3f} / {np.nanmean(north[:, 1]):.3f}")
            + f" | {f'{int(sum(cal))}/{4 * len(cal)}' if cal else '-'} | "
            f"{np.mean([row[6] for row in rows]):.1f} |")
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--fits", nargs="+", default=list(FITS), choices=list(FITS))
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    kinds, lines = run(args.seeds, tuple(args.fits))
    text = summary(kinds)
    print(text)
    if not args.no_write:
        RESULTS.parent.mkdir(exist_ok=True)
        RESULTS.write_text(
            f"# The EKF and UKF with air data as measured outputs ({dt.date.today()})\n\n"
            f"`python benchmarks/bench_kalman_air.py --seeds {args.seeds} --fits "
            f"{' '.join(args.fits)}` (one process, fits in turn)\n\n{text}\n\nPer run:\n\n"
            "```\n" + "\n".join(lines) + "\n```\n")
        print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
