"""EAM-PSO with logged air data (a probe's alpha, beta, airspeed) in wind and turbulence.

Run by hand from the repository root (one process, the fits in turn)::

    python benchmarks/bench_eam_air.py                  # 4 seeds, writes results
    python benchmarks/bench_eam_air.py --seeds 1 --no-write

Per seed ``k`` (``rng = k``: the gusts, then the sensor noise, as :func:`aeroid.simulate`):
the reference scenario with the tactical Gaussian IMU (:class:`aeroid.flights.GaussianNoise`
defaults) in still air (no probe: the yardstick), and with a probe (``alpha_sd_rad =
beta_sd_rad`` 0.1 deg, ``airspeed_sd_mps`` 0.5) in a steady wind of 5 m/s (north 3, east
4: 3 m/s along the northward path, 4 across) and in that wind with Dryden turbulence of sd
3 m/s (scale length 533.4 m). EAM-PSO, polished (``polish = True``: the exact minimum of
the same cost from the swarm's best, so the table measures the cost, not the swarm's
luck), a reduced swarm (``--particles``, ``--iterations``; 100 x 50 by default), with
``air_data = "measured"`` (the wind the air data imply, Kalman-smoothed,
:mod:`aeroid.estimation._eam_air`) and ``"inertial"`` (still air: the known-wrong model).

Reported: successes (the fit check's verdict), the mean over seeds of the mean |relative
error| of the nine coefficients [%], its ratio to still air, Czq's mean |error|, the
mean time per fit. Issue 26's target for the regressions (equation-error within 2x its
still-air error with 0.1 deg vanes in Dryden sd 3) is the yardstick.
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
from aeroid.estimation import get_estimator  # noqa: E402
from aeroid.flights import GaussianNoise, Wind, load_scenario, simulate  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "eam_air.md"
WIND = (3.0, 4.0, 0.0)
VANE_RAD = float(np.radians(0.1))
PROBE = GaussianNoise(alpha_sd_rad=VANE_RAD, beta_sd_rad=VANE_RAD, airspeed_sd_mps=0.5)
#: air -> (its wind, the noise model, the air_data options fitted)
AIRS = {"still": (None, GaussianNoise(), ("inertial",)),
        "wind 5 m/s": (Wind(steady_ned_mps=WIND), PROBE, ("measured", "inertial")),
        "wind + Dryden sd 3": (Wind(steady_ned_mps=WIND, turbulence_sd_mps=3.0,
                                    scale_length_m=533.4), PROBE, ("measured", "inertial"))}


def run(seeds: int, particles: int, iterations: int) -> tuple[dict, list[str]]:
    """Fit every air and option on every seed; return per-kind rows and the log lines."""
    s = load_scenario(None)
    truth = s.coefficient_vector
    kinds: dict[str, list] = {}
    lines = []
    for seed in range(1, seeds + 1):
        for air, (wind, noise, choices) in AIRS.items():
            m = s.manoeuvre if wind is None else dataclasses.replace(s.manoeuvre, wind=wind)
            flight = simulate(s.airframe, truth, m, noise, rng=seed)
            for air_data in choices:
                est = get_estimator("eam-pso")(air_data=air_data, polish=True,
                                               n_particles=particles,
                                               n_iterations=iterations)
                start = time.perf_counter()
                r = est.fit(flight, rng=seed)
                took = time.perf_counter() - start
                err = np.abs(r.theta / truth - 1.0) * 100.0
                kind = f"{air} / {air_data}"
                kinds.setdefault(kind, []).append((r.success, err, took))
                lines.append(f"seed {seed} {kind}: success={r.success} mean |err| "
                             f"{err.mean():.3f} % {took:.1f} s {r.message[:90]}")
                print(lines[-1], flush=True)
    return kinds, lines


def table(kinds: dict) -> str:
    """The markdown table of the kinds."""
    czq = aeroid.NAMES.index("Czq")
    still = float(np.mean([r[1].mean() for r in kinds["still / inertial"]]))
    out = ["| air / air_data | success | mean abs rel error [%] | x still | "
           "Czq mean abs err [%] | mean time [s] |", "|---|---|---|---|---|---|"]
    for kind, rows in kinds.items():
        e = float(np.mean([r[1].mean() for r in rows]))
        out.append(f"| {kind} | {sum(r[0] for r in rows)}/{len(rows)} | {e:.3f} | "
                   f"{e / still:.2f} | {np.mean([r[1][czq] for r in rows]):.2f} | "
                   f"{np.mean([r[2] for r in rows]):.1f} |")
    out += ["", "Mean |relative error| per coefficient [%]:", "",
            "| air / air_data | " + " | ".join(aeroid.NAMES) + " |",
            "|---|" + "---|" * len(aeroid.NAMES)]
    for kind, rows in kinds.items():
        per = np.mean([r[1] for r in rows], axis=0)
        out.append(f"| {kind} | " + " | ".join(f"{v:.2f}" for v in per) + " |")
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--particles", type=int, default=100)
    parser.add_argument("--iterations", type=int, default=50)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    kinds, lines = run(args.seeds, args.particles, args.iterations)
    text = table(kinds)
    print(text)
    if not args.no_write:
        command = (f"python benchmarks/bench_eam_air.py --seeds {args.seeds} --particles "
                   f"{args.particles} --iterations {args.iterations}")
        RESULTS.write_text(f"# EAM-PSO with logged air data\n\n`{command}` "
                           f"({dt.date.today().isoformat()}, one process)\n\n{text}\n\n"
                           "Per fit:\n\n```\n" + "\n".join(lines) + "\n```\n")


if __name__ == "__main__":
    main()
