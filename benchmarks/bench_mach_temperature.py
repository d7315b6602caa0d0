"""Mach from the logged air temperature against Mach assuming the ISA (issue 23).

Run by hand from the repository root (one process; the seeds one after another)::

    python benchmarks/bench_mach_temperature.py --seeds 0 1 2 3 4 --out /tmp/warm.jsonl
    python benchmarks/bench_mach_temperature.py --summary /tmp/warm.jsonl
    python benchmarks/bench_mach_temperature.py --seeds 0 --noise none --out /tmp/clean.jsonl

``--noise none`` fits the noise-free record (each line keeps ``theta`` and ``truth``).

The Mach sweep (``studies/scenarios/mach_sweep.toml``: a coast through Mach 2.19 -> 1.11
in 20 s at 5 km, Cx and Cmq tables +-15 %) flown in air ``--delta-t`` K warmer than the
ISA (the scenario's ``[air] delta_T_K``, the air temperature logged): the truth is
integrated once (the true tables at the warm air's Mach), each seed records it with the
scenario's tactical-IMU noise and fits the tables with output-error twice: (a) with the
``air_temperature`` channel (Mach per sample from it), (b) without it (Mach from the ISA
at 5 km, what a fit that ignores the weather does). Each line of the output is one fit:
the fit check's verdict, every table point's error in its standard errors (``z``), its
standard error, and the point's expected shift assuming the ISA in closed form: the
point at knot ``K`` then holds the truth at Mach ``K a_ISA / a`` (``a = sqrt(gamma R T)``),
``shift = C(K a_ISA / a) - C(K)`` with ``C`` the scenario's true table (linear between its
rows, held beyond them).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import aeroid  # noqa: E402
from aeroid.flights import (  # noqa: E402
    make_flight,
    noise_for,
    record_flight,
    scenario_from_dict,
    simulate_truth,
)
from aeroid.model import isa_temperature, speed_of_sound_at  # noqa: E402

SCENARIO = Path(__file__).parents[1] / "studies" / "scenarios" / "mach_sweep.toml"
FORMS = ("temperature", "isa")


def verdict(result: aeroid.EstimationResult) -> str:
    """The fit check's verdict in one word (``ok`` when the result passed)."""
    if result.success:
        return "ok"
    for word, key in (("size", "does not fit"), ("whiteness", "structure"),
                      ("noise model", "noise model"), ("identifiability", "information")):
        if key in result.message:
            return word
    return "method"


def _true_value(scenario: aeroid.flights.Scenario, name: str, mach: float) -> float:
    """The scenario's true coefficient ``name`` at ``mach`` (its table, or its constant)."""
    tables = scenario.tables
    layout = dict(tables.layout)
    values = np.array(scenario.coefficients)[layout[name]]
    if name not in dict(tables.knots):
        return float(values[0])
    return float(np.interp(mach, tables.knots_of(name), values))


def run(seeds: list[int], out: Path, delta_t_k: float, substeps: int,
        noise_name: str = "gaussian") -> None:
    """Fit every seed with and without the temperature; one JSON line per fit."""
    data = aeroid.model.read_toml(SCENARIO)
    data["air"] = {"delta_T_K": delta_t_k, "log_temperature": True}
    scenario = scenario_from_dict(data, source=f"{SCENARIO} + [air] delta_T_K = {delta_t_k:g}")
    noise = noise_for(data, noise_name)
    altitude = scenario.airframe.altitude_m
    ratio = float(speed_of_sound_at(isa_temperature(altitude) + delta_t_k)
                  / speed_of_sound_at(isa_temperature(altitude)))  # a / a_ISA
    start = time.perf_counter()
    truth = simulate_truth(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                           tables=scenario.tables)
    print(f"truth integrated in {time.perf_counter() - start:.1f} s; a / a_ISA = {ratio:.6f}",
          flush=True)
    names = scenario.tables.parameter_names()
    true_p = np.array(scenario.coefficients)
    shift = []
    for name in names:
        coefficient, _, knot = name.partition("@M")
        k = float(knot) if knot else 0.0
        shift.append(_true_value(scenario, coefficient, k / ratio)
                     - _true_value(scenario, coefficient, k) if knot else 0.0)
    oe = aeroid.make_estimator("output-error", {"substeps": substeps})
    for seed in seeds:
        flight = record_flight(scenario.airframe, true_p, scenario.manoeuvre, truth, noise,
                               rng=seed, tables=scenario.tables)
        channels = {c: flight[c] for c in flight.channels if c != "air_temperature"}
        isa = make_flight(channels, flight.airframe, dict(flight.metadata))
        for form, fl in zip(FORMS, (flight, isa), strict=True):
            t0 = time.perf_counter()
            result = oe.fit(fl, rng=seed)
            row = {"seed": seed, "form": form, "delta_T_K": delta_t_k, "substeps": substeps,
                   "noise": noise_name, "theta": result.theta.tolist(),
                   "truth": true_p.tolist(),
                   "success": bool(result.success), "verdict": verdict(result),
                   "message": result.message, "wall_s": time.perf_counter() - t0,
                   "speed_of_sound": result.info.get("speed_of_sound"),
                   "names": list(result.names)}
            if tuple(result.names) == tuple(names) and result.stderr is not None:
                row["z"] = ((result.theta - true_p) / result.stderr).tolist()
                row["stderr"] = result.stderr.tolist()
                row["shift_z"] = (np.array(shift) / result.stderr).tolist()
            with out.open("a") as f:
                f.write(json.dumps(row) + "\n")
            print(f"seed {seed} {form:11s} {row['verdict']:10s} {row['wall_s']:.1f} s "
                  f"{result.message[:100]}", flush=True)


def summary(path: Path) -> None:
    """Print per form the verdicts and each table point's |z| (and the expected shift)."""
    rows = [r for r in map(json.loads, path.read_text().splitlines())
            if r.get("noise", "gaussian") == "gaussian"]
    for form in FORMS:
        these = [r for r in rows if r["form"] == form and "z" in r]
        if not these:
            continue
        verdicts = [r["verdict"] for r in these]
        print(f"\n{form}: {len(these)} fits, passed the fit check {verdicts.count('ok')}, "
              f"flagged {', '.join(sorted(set(v for v in verdicts if v != 'ok'))) or '-'}; "
              f"{these[0]['speed_of_sound']}")
        names = these[0]["names"]
        z = np.array([r["z"] for r in these])
        expected = np.array([r["shift_z"] for r in these])
        print(f"{'parameter':12s} {'mean z':>8s} {'max |z|':>8s} {'within 3 se':>11s} "
              f"{'ISA shift / se':>14s}")
        for j, name in enumerate(names):
            if "@M" not in name:
                continue
            print(f"{name:12s} {z[:, j].mean():8.2f} {np.abs(z[:, j]).max():8.2f} "
                  f"{np.mean(np.abs(z[:, j]) <= 3.0):11.2f} {expected[:, j].mean():14.2f}")
        points = [j for j, n in enumerate(names) if "@M" in n]
        constants = [j for j, n in enumerate(names) if "@M" not in n]
        print(f"table points within 3 se: {np.mean(np.abs(z[:, points]) <= 3.0):.3f}; "
              f"constants' max |z| {np.abs(z[:, constants]).max():.2f}")


def main() -> None:
    """Command line (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="*", default=[0, 1, 2, 3, 4])
    parser.add_argument("--out", type=Path, default=Path("mach_temperature.jsonl"))
    parser.add_argument("--delta-t", type=float, default=20.0, help="ISA offset [K]")
    parser.add_argument("--substeps", type=int, default=4,
                        help="output-error's RK4 steps per sample (README: 4 at 250 Hz)")
    parser.add_argument("--noise", choices=("gaussian", "none"), default="gaussian",
                        help="the scenario's [noise.gaussian] (default), or none")
    parser.add_argument("--summary", type=Path, help="summarise a JSONL file and stop")
    args = parser.parse_args()
    if args.summary:
        summary(args.summary)
        return
    run(args.seeds, args.out, args.delta_t, args.substeps, args.noise)
    summary(args.out)


if __name__ == "__main__":
    main()
