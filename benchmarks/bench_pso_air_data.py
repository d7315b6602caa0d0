"""EBM-PSO and SEBM-PSO with the logged air data: the Kalman smoother against the window.

Run by hand from the repository root (one process, the fits in turn: ``--jobs 1``)::

    python benchmarks/bench_pso_air_data.py                  # 8 seeds, writes results
    python benchmarks/bench_pso_air_data.py --seeds 2 --no-write

Per seed ``k`` (``rng = k``: the gusts, then the sensor noise, as :func:`aeroid.simulate`;
the truth is simulated once and recorded with each noise model, as
``benchmarks/bench_air_data.py`` does, so these are its flights): the reference scenario
with the tactical Gaussian IMU and a probe drawn by the same noise model (0.1 deg on
alpha and beta, an ``airspeed`` channel with 0.5 m/s), in still air; in a crosswind of
5 m/s (east, across the northward path); in a steady wind of 5 m/s (north 3, along the
path; east 4); in that wind with Dryden turbulence of sd 1 and 3 m/s (scale length
533.4 m).
The crosswind and the turbulence are also flown with the vanes alone (no airspeed
channel): the crosswind is the setting of the former 0.1 s figure (2.68x still air),
the turbulence a known-wrong input the methods must refuse.

Fits, every PSO one with ``polish = true`` (the exact minimum of its cost; otherwise the
paper's swarms and options), ``air_data = "measured"`` unless said:

* ``IMU only``: the still flight without the probe, inertial angles (each method's
  still-air yardstick);
* ``kalman``: the default, the implied wind Kalman-smoothed with its gust intensity by
  maximum likelihood (:mod:`aeroid.estimation._air_smoother`);
* ``window 0.1 s``: the former default (``air_data_window_s = 0.1``).

Equation-error (its defaults; ``air_data = "measured"``) is fitted on the same flights.
Reported per method and fit: successes (the fit check and the refusal of turbulence
without an airspeed channel), the mean over seeds of the mean |relative error| of the
nine coefficients [%], its ratio to the method's own still-air error, its ratio to
equation-error's (Kalman) error on the same flights, Czq's mean |error| (the coefficient
the vane noise moves most) and the mean time per fit; the smoother against the window
paired over seeds (the mean difference, its standard error, the seeds it wins). The PSO
methods report no standard errors, so no coverage.
"""

from __future__ import annotations

from _air_flights import AIRS as WINDS  # first: one BLAS thread before numpy loads
from _air_flights import (
    AIRSPEED_SD_MPS,
    SCALE_LENGTH_M,
    WIND,
    coefficient_table,
    probe_noise,
    windy_flight,
)

# isort: split
import argparse
import datetime as dt
import time
from pathlib import Path

import numpy as np

import aeroid
from aeroid.estimation import get_estimator
from aeroid.flights import make_noise, reference_scenario
from baselines.equation_error import EquationErrorEstimator

RESULTS = Path(__file__).parent / "results" / "pso_air_data.md"
#: The airs whose vanes-only flight (no airspeed channel) is fitted too.
BLIND = ("crosswind 5 m/s", "wind + Dryden sd 1")
#: air -> (its wind, whether the vanes-only flight is fitted too)
AIRS = {air: (wind, air in BLIND) for air, wind in WINDS.items()}
NOISES = {"probe": probe_noise(airspeed_sd_mps=AIRSPEED_SD_MPS),
          "no airspeed": probe_noise(),
          "imu": make_noise("gaussian")}
METHODS = ("equation-error", "ebm-pso", "sebm-pso")


def flights(air: str, seed: int) -> dict[str, aeroid.flights.Flight]:
    """The seed's flights of ``air``, one per noise model of :data:`NOISES` it needs."""
    wind, blind = AIRS[air]
    wanted = ("imu",) if wind is None else ("probe", "no airspeed") if blind else ("probe",)
    return {label: windy_flight(wind, NOISES[label], seed)[0] for label in wanted}


def estimator(method: str, air_data: str, window_s: float | None):
    """The method with the air-data options (every PSO one polished)."""
    if method == "equation-error":
        return EquationErrorEstimator(air_data=air_data, air_data_window_s=window_s)
    return get_estimator(method)(air_data=air_data, air_data_window_s=window_s, polish=True)


def run(seeds: int) -> tuple[dict, list[str]]:
    """Fit every method and kind on every seed; return per-(method, kind) rows and lines."""
    truth = reference_scenario().coefficient_vector
    kinds: dict[tuple[str, str], list] = {}
    lines = []
    for seed in range(1, seeds + 1):
        for air in AIRS:
            f = flights(air, seed)
            fits = []
            for label, flight in f.items():
                tail = "" if label == "probe" else ", no airspeed"
                if label == "imu":
                    fits += [(f"{air} / IMU only", flight, "inertial", None)]
                    continue
                fits += [(f"{air} / kalman{tail}", flight, "measured", None),
                         (f"{air} / window 0.1 s{tail}", flight, "measured", 0.1)]
            for kind, flight, air_data, window in fits:
                for method in METHODS:
                    if method == "equation-error" and "window" in kind:
                        continue  # measured in bench_air_data.py
                    start = time.perf_counter()
                    r = estimator(method, air_data, window).fit(flight, rng=seed)
                    took = time.perf_counter() - start
                    err = np.abs(r.theta / truth - 1.0) * 100.0
                    kinds.setdefault((method, kind), []).append((r.success, err, took))
                    q = r.info.get("air_data_wind_intensity")
                    lines.append(f"seed {seed} {method} {kind}: success={r.success} mean |err| "
                                 f"{err.mean():.3f} % q {'-' if q is None else f'{q:.3g}'} "
                                 f"{took:.2f} s {r.message[:100]}")
                    print(lines[-1], flush=True)
    return kinds, lines


def table(kinds: dict) -> str:
    """Return the markdown tables of the kinds."""
    czq = aeroid.NAMES.index("Czq")

    def mean(method: str, kind: str) -> float:
        return float(np.mean([r[1].mean() for r in kinds[(method, kind)]]))

    out = ["| method: air / fit | success | mean abs rel error [%] | x still | "
           "x equation-error | Czq mean abs err [%] | mean time [s] |",
           "|---|---|---|---|---|---|---|"]
    for (method, kind), rows in kinds.items():
        e = mean(method, kind)
        still = mean(method, "still / IMU only")
        base = kind.replace("window 0.1 s", "kalman")
        ee = mean("equation-error", base) if ("equation-error", base) in kinds else np.nan
        out.append(f"| {method}: {kind} | {sum(r[0] for r in rows)}/{len(rows)} | {e:.3f} | "
                   f"{e / still:.2f} | {e / ee:.2f} | "
                   f"{np.mean([r[1][czq] for r in rows]):.2f} | "
                   f"{np.mean([r[2] for r in rows]):.2f} |")
    out += ["", "Paired over seeds (the same flights): the Kalman smoother's mean |relative "
            "error| minus the 0.1 s window's [%], mean +- its standard error, and the seeds "
            "where the smoother is closer:", "",
            "| method: air | kalman - window [%] | smoother closer |", "|---|---|---|"]
    for (method, kind), rows in kinds.items():
        window = kinds.get((method, kind.replace("kalman", "window 0.1 s")))
        if "kalman" not in kind or window is None:
            continue
        d = np.array([k[1].mean() - w[1].mean() for k, w in zip(rows, window, strict=True)])
        out.append(f"| {method}: {kind.replace(' / kalman', '')} | {d.mean():+.3f} +- "
                   f"{d.std(ddof=1) / np.sqrt(d.size) if d.size > 1 else np.nan:.3f} | "
                   f"{int(np.sum(d < 0))}/{d.size} |")
    out += coefficient_table({f"{method}: {kind}": [r[1] for r in rows]
                              for (method, kind), rows in kinds.items()}, "method: air / fit")
    return "\n".join(out)


def main() -> None:
    """Run the benchmark and print (and write) the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    kinds, lines = run(args.seeds)
    text = table(kinds)
    print(text)
    if not args.no_write:
        RESULTS.parent.mkdir(exist_ok=True)
        RESULTS.write_text(
            f"# EBM-PSO and SEBM-PSO with logged air data ({dt.date.today()})\n\n"
            f"`python benchmarks/bench_pso_air_data.py --seeds {args.seeds}`; probe noise "
            f"0.1 deg on alpha and beta, {AIRSPEED_SD_MPS} m/s on the airspeed; wind {WIND} "
            f"m/s NED, Dryden scale length {SCALE_LENGTH_M} m; PSO fits polished."
            f"\n\n{text}\n\n```\n" + "\n".join(lines) + "\n```\n")


if __name__ == "__main__":
    main()
