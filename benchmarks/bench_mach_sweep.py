"""The verdict across the record (issue 23): constants against tables on the Mach sweep.

Run by hand from the repository root (one process; the seeds one after another)::

    python benchmarks/bench_mach_sweep.py --seeds 0 1 2 3 4 --out /tmp/sweep.jsonl
    python benchmarks/bench_mach_sweep.py --summary /tmp/sweep.jsonl
    python benchmarks/bench_mach_sweep.py --seeds 5 6 7 --methods output-error --forms tables
    python benchmarks/bench_mach_sweep.py --scenario studies/scenarios/alpha_table.toml \
        --seeds 0 1 2 --out /tmp/alpha.jsonl     # Cma a table in the angle of attack

The truth of ``studies/scenarios/mach_sweep.toml`` (a coasting airframe through Mach
2.19 -> 1.11 in 20 s, Cx and Cmq tables +-15 %) is integrated once; each seed records it
with the scenario's tactical-IMU noise (``[noise.gaussian]``) and fits it four ways:
output-error and equation-error with constant coefficients (the airframe's ``[tables]``
removed) and with the tables. Each line of the output is one fit: its ``success``, the
fit check's verdict and message, and for a table fit every parameter's error in its
standard errors, its standard error and the Cramér-Rao floor of the table points at the
truth (:func:`baselines._tables_fit.table_floor`, the noise's true sd).

``--coverage results.jsonl`` reads a study's records (``aeroid study
studies/mach_sweep.toml --runs 200 --jobs 1 --out DIR``: ``DIR/results.jsonl``, complete or
still running) and prints each table point's coverage of the 95 % intervals with its exact
(Clopper-Pearson) binomial interval, and the points pooled.

``--scenario`` fits another scenario with tables and ``[noise.gaussian]`` the same way
(``studies/scenarios/alpha_table.toml``: Cma a table in the total angle of attack).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import aeroid  # noqa: E402
from aeroid.flights import load_scenario, noise_for, record_flight, simulate_truth  # noqa: E402
from baselines._tables_fit import table_floor  # noqa: E402

SCENARIO = Path(__file__).parents[1] / "studies" / "scenarios" / "mach_sweep.toml"
METHODS = ("output-error", "equation-error")


def verdict(result: aeroid.EstimationResult) -> str:
    """The fit check's verdict in one word (``ok`` when the result passed)."""
    if result.success:
        return "ok"
    text = result.message
    for word, key in (("size", "does not fit"), ("whiteness", "structure"),
                      ("noise model", "noise model"), ("identifiability", "information")):
        if key in text:
            return word
    return "method"


def run(seeds: list[int], out: Path, methods: tuple[str, ...] = METHODS,
        forms: tuple[str, ...] = ("constants", "tables"), substeps: int | None = None,
        path: Path = SCENARIO) -> None:
    """Fit every seed (up to) four ways; one JSON line per fit appended to ``out``."""
    scenario = load_scenario(path)
    data = aeroid.model.read_toml(path)
    noise = noise_for(data, "gaussian")
    sd = np.array([noise.accel_sd_mps2] * len(aeroid.model.ACCEL_CHANNELS)
                  + [noise.rate_sd_radps] * len(aeroid.model.RATE_CHANNELS))
    start = time.perf_counter()
    truth = simulate_truth(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                           tables=scenario.tables)
    print(f"truth integrated in {time.perf_counter() - start:.1f} s", flush=True)
    names = scenario.tables.parameter_names()
    true_p = np.array(scenario.coefficients)
    floor = None
    for seed in seeds:
        flight = record_flight(scenario.airframe, true_p, scenario.manoeuvre, truth, noise,
                               rng=seed, tables=scenario.tables)
        if floor is None:
            floor = table_floor(flight, true_p, sd)
        constant = dataclasses.replace(flight, airframe=flight.airframe.replace(tables=None))
        for method in methods:
            for form, fl in (("constants", constant), ("tables", flight)):
                if form not in forms:
                    continue
                t0 = time.perf_counter()
                options = ({"substeps": substeps}
                           if substeps is not None and method == "output-error" else {})
                result = aeroid.make_estimator(method, options).fit(fl, rng=seed)
                row = {"seed": seed, "method": method, "form": form, "options": options,
                       "success": bool(result.success), "verdict": verdict(result),
                       "message": result.message, "wall_s": time.perf_counter() - t0,
                       "worst_ratio": _worst(result)}
                if form == "tables" and result.names == names:
                    row["z"] = ((result.theta - true_p) / result.stderr).tolist()
                    row["stderr"] = result.stderr.tolist()
                    row["floor"] = floor.tolist()
                    row["names"] = list(names)
                with out.open("a") as f:
                    f.write(json.dumps(row) + "\n")
                print(f"seed {seed} {method:15s} {form:9s} {row['verdict']:10s} "
                      f"worst ratio {row['worst_ratio']:.3g} {row['wall_s']:.1f} s "
                      f"{result.message[:90]}", flush=True)


def _worst(result: aeroid.EstimationResult) -> float:
    check = result.info.get("fit_check")
    return float(check["ratio"][check["worst"]]) if check else float("nan")


def summary(path: Path) -> None:
    """Print the verdict rates and each table point's |z| and standard error / floor."""
    rows = [json.loads(line) for line in path.read_text().splitlines()]
    for method in METHODS:
        for form in ("constants", "tables"):
            these = [r for r in rows if r["method"] == method and r["form"] == form]
            if not these:
                continue
            counts: dict[str, int] = {}
            for r in these:
                counts[r["verdict"]] = counts.get(r["verdict"], 0) + 1
            print(f"{method:15s} {form:9s} {len(these)} fits: "
                  + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
            table = [r for r in these if "z" in r]
            if table:
                z = np.abs(np.array([r["z"] for r in table]))
                print(f"    all points: {z.size} point-runs, within 1.96 se: "
                      f"{np.mean(z <= 1.96):.3f}, within 3 se: {np.mean(z <= 3.0):.3f}")
                ratio = np.array([r["stderr"] for r in table]) / np.array(table[0]["floor"])
                for j, name in enumerate(table[0]["names"]):
                    print(f"    {name:12s} max |z| {z[:, j].max():5.2f}  within 1.96: "
                          f"{np.mean(z[:, j] <= 1.96):.2f}  se/floor "
                          f"{np.median(ratio[:, j]):.3g}  floor {table[0]['floor'][j]:.3g}")


def coverage(path: Path) -> None:
    """Print each table point's coverage with its exact binomial 95 % interval."""
    from scipy.stats import binomtest

    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    rows = [r for r in rows if r["success"]]
    names = rows[0]["names"]
    err = np.array([r["theta"] for r in rows]) - np.array([r["truth"] for r in rows])
    signed = err / np.array([r["stderr"] for r in rows])
    z = np.abs(signed)
    print(f"{len(rows)} successful fits (runs {min(r['run'] for r in rows)}-"
          f"{max(r['run'] for r in rows)})")
    points = [j for j, n in enumerate(names) if "@" in n]
    for j, name in enumerate(names):
        k = int(np.sum(z[:, j] <= 1.96))
        ci = binomtest(k, len(rows)).proportion_ci(method="exact")
        print(f"    {name:12s} {k:4d} of {len(rows)} = {k / len(rows):.3f} "
              f"({ci.low:.3f}-{ci.high:.3f})  max |z| {z[:, j].max():.2f}  mean z "
              f"{signed[:, j].mean():+.2f}  sd z {signed[:, j].std(ddof=1):.2f}"
              + ("" if j in points else "  (constant)"))
    k, n = int(np.sum(z[:, points] <= 1.96)), z[:, points].size
    ci = binomtest(k, n).proportion_ci(method="exact")
    print(f"    table points pooled: {k} of {n} = {k / n:.3f} ({ci.low:.3f}-{ci.high:.3f})")


def main() -> None:
    """Command line (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="*", default=[0, 1, 2])
    parser.add_argument("--out", type=Path, default=Path("mach_sweep.jsonl"))
    parser.add_argument("--methods", nargs="*", default=list(METHODS), choices=METHODS)
    parser.add_argument("--forms", nargs="*", default=["constants", "tables"],
                        choices=["constants", "tables"])
    parser.add_argument("--substeps", type=int, help="output-error's RK4 steps per sample")
    parser.add_argument("--summary", type=Path)
    parser.add_argument("--coverage", type=Path, help="a study's results.jsonl")
    parser.add_argument("--scenario", type=Path, default=SCENARIO,
                        help="a scenario with tables and [noise.gaussian]")
    args = parser.parse_args()
    if args.coverage:
        coverage(args.coverage)
    elif args.summary:
        summary(args.summary)
    else:
        run(args.seeds, args.out, tuple(args.methods), tuple(args.forms), args.substeps,
            args.scenario)


if __name__ == "__main__":
    main()
