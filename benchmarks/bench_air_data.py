"""Equation-error with logged air-data angles in wind and turbulence (issue 26).

Run by hand from the repository root (one process, the fits in turn: ``--jobs 1``)::

    python benchmarks/bench_air_data.py                  # 8 seeds, writes results
    python benchmarks/bench_air_data.py --seeds 2 --no-write
    python benchmarks/bench_air_data.py --window-s 1.0    # air_data_window_s = 1 s

Per seed ``k`` (``rng = k`` for the flight; ``[k, 26]`` for the vane noise): the
reference scenario with Gaussian IMU noise (:class:`aeroid.flights.GaussianNoise`
defaults) in still air; in a crosswind of 5 m/s (east, across the northward path: the
airspeed is the inertial speed to second order, so the angles alone carry the wind); in
a steady wind of 5 m/s (north 3, east 4: 3 m/s along the path, 4 across); and in that
wind with Dryden turbulence of sd 1 and 3 m/s (scale length 533.4 m). The logged
``alpha`` and ``beta`` (the simulator's air-relative angles) get white Gaussian noise of
sd 0.1 deg (a vane), except in still air. Fits (two-step equation-error, defaults):

* ``still``: the yardstick (its angles from u, v, w: the logged ones are the inertial ones);
* ``<air> / measured``: ``air_data = "measured"`` (the implied wind smoothed over
  ``air_data_window_s`` = ``--window-s``, default 0.1 s: the option's default);
  ``measured, unsmoothed``: ``air_data_window_s = 0``;
* ``<air> / inertial``: ``air_data = "inertial"``: the known-wrong angles, which the fit
  check must refuse.

Reported: successes (the fit check's verdict), the mean over seeds of the mean |relative
error| of the nine coefficients [%], its ratio to still air, and the same without Cl0,
Clp (the roll pair comes from the p gyro alone, whatever the angles), and the median over
seeds of the largest |error| / se over the coefficients (the standard errors' honesty).
Target (issue 26): measured angles within 2x the still-air error.
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
from baselines.equation_error import EquationErrorEstimator  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "air_data.md"
WIND = (3.0, 4.0, 0.0)
VANE_SD_DEG = 0.1
SCALE_LENGTH_M = 533.4
AIRS = {"still": None, "crosswind 5 m/s": Wind(steady_ned_mps=(0.0, 5.0, 0.0)),
        "wind 5 m/s": Wind(steady_ned_mps=WIND),
        "wind + Dryden sd 1": Wind(steady_ned_mps=WIND, turbulence_sd_mps=1.0,
                                   scale_length_m=SCALE_LENGTH_M),
        "wind + Dryden sd 3": Wind(steady_ned_mps=WIND, turbulence_sd_mps=3.0,
                                   scale_length_m=SCALE_LENGTH_M)}


def with_vane_noise(flight: aeroid.flights.Flight, sd_rad: float,
                    rng: np.random.Generator) -> aeroid.flights.Flight:
    """Return ``flight`` with white noise of ``sd_rad`` on its logged alpha and beta."""
    n = flight.n_samples
    data = flight.data.assign(alpha=flight["alpha"] + sd_rad * rng.standard_normal(n),
                              beta=flight["beta"] + sd_rad * rng.standard_normal(n))
    return dataclasses.replace(flight, data=data)


def run(seeds: int, window_s: float = 0.1) -> tuple[dict, list[str]]:
    """Fit every kind on every seed; return per-kind lists of (success, errors) and lines."""
    s = reference_scenario()
    truth = s.coefficient_vector
    noise = make_noise("gaussian")
    roll = [aeroid.NAMES.index(n) for n in ("Cl0", "Clp")]
    keep = np.setdiff1d(np.arange(truth.size), roll)
    kinds: dict[str, list] = {}
    lines = []
    for seed in range(1, seeds + 1):
        for air, wind in AIRS.items():
            m = s.manoeuvre if wind is None else dataclasses.replace(s.manoeuvre, wind=wind)
            flight = simulate(s.airframe, truth, m, noise, rng=seed)
            if wind is not None:
                flight = with_vane_noise(flight, np.radians(VANE_SD_DEG),
                                         np.random.default_rng([seed, 26]))
            fits = ({"still": EquationErrorEstimator()} if wind is None else {
                f"{air} / measured": EquationErrorEstimator(air_data="measured",
                                                             air_data_window_s=window_s),
                f"{air} / measured, unsmoothed": EquationErrorEstimator(
                    air_data="measured", air_data_window_s=0.0),
                f"{air} / inertial": EquationErrorEstimator(air_data="inertial")})
            for kind, estimator in fits.items():
                start = time.perf_counter()
                r = estimator.fit(flight)
                err = np.abs(r.theta / truth - 1.0) * 100.0
                z = np.abs(r.theta - truth) / r.stderr
                kinds.setdefault(kind, []).append((r.success, err, err[keep], z.max()))
                lines.append(f"seed {seed} {kind}: success={r.success} mean |err| "
                             f"{err.mean():.3f} % (no roll {err[keep].mean():.3f} %) "
                             f"max |err|/se {z.max():.1f} {time.perf_counter() - start:.2f} s "
                             f"{r.message[:90]}")
                print(lines[-1], flush=True)
    return kinds, lines


def table(kinds: dict) -> str:
    """Return the markdown table of the kinds."""
    still = np.mean([r[1].mean() for r in kinds["still"]])
    still_k = np.mean([r[2].mean() for r in kinds["still"]])
    out = ["| air / angles | success | mean abs rel error [%] | x still | without Cl0, Clp [%] "
           "| x still | median max abs err/se |", "|---|---|---|---|---|---|---|"]
    for kind, rows in kinds.items():
        e = np.mean([r[1].mean() for r in rows])
        k = np.mean([r[2].mean() for r in rows])
        out.append(f"| {kind} | {sum(r[0] for r in rows)}/{len(rows)} | {e:.3f} | "
                   f"{e / still:.2f} | {k:.3f} | {k / still_k:.2f} | "
                   f"{np.median([r[3] for r in rows]):.1f} |")
    out += ["", "Mean |relative error| per coefficient [%]:", "",
            "| air / angles | " + " | ".join(aeroid.NAMES) + " |",
            "|---|" + "---|" * len(aeroid.NAMES)]
    for kind, rows in kinds.items():
        per = np.mean([r[1] for r in rows], axis=0)
        out.append(f"| {kind} | " + " | ".join(f"{v:.2f}" for v in per) + " |")
    return "\n".join(out)


def main() -> None:
    """Run the benchmark and print (and write) the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--window-s", type=float, default=0.1,
                        help="air_data_window_s of the 'measured' fits [s]")
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    kinds, lines = run(args.seeds, args.window_s)
    text = table(kinds)
    print(text)
    if not args.no_write:
        path = RESULTS if args.window_s == 0.1 else RESULTS.with_name(
            f"air_data_window_{args.window_s:g}s.md")
        path.write_text(
            f"# Equation-error with logged air-data angles ({dt.date.today()})\n\n"
            f"`python benchmarks/bench_air_data.py --seeds {args.seeds} --window-s "
            f"{args.window_s:g}`; vane noise "
            f"{VANE_SD_DEG} deg, wind {WIND} m/s NED, Dryden scale length {SCALE_LENGTH_M} m"
            f".\n\n{text}\n\n```\n" + "\n".join(lines) + "\n```\n")


if __name__ == "__main__":
    main()
