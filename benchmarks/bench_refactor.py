"""Old against new code, side by side in one session: the model written once costs no speed.

Run by hand from the repository root::

    python benchmarks/bench_refactor.py --old /path/to/old/checkout
    python benchmarks/bench_refactor.py --old ../old --rounds 3 --quick   # prints only

``--old`` is a checkout of the code before the model was written once (commit a2f5899:
``git worktree add --detach ../old a2f5899``). Each round starts one fresh process per
tree, in alternating order (old-new, new-old, ...), so both see the same machine load;
each process simulates the reference flight with the paper's noise (seed 1), runs every
task once to compile and warm up, then times ``--repeats`` runs of each with
``time.process_time`` (CPU time of the process; one numba thread). Reported: the median
over all rounds and repeats, and the median of the per-round ratio new / old.

Tasks, with the new code run at the old code's settings so the comparison is the code,
not a changed default (the new defaults are timed too, in their own rows):

* ``rk4``: one batched RK4 pass over the flight for 450 coefficient sets (EAM-PSO's
  inner loop, the compiled kernel on one thread; five times ``--repeats`` timings);
* ``eam-pso``: EAM-PSO at 100 particles x 20 iterations;
* ``output-error``: noise level per channel, sensor positions known;
* ``ekf``: the old defaults (process noise, fixed initial sd, one level per channel,
  positions known);
* ``equation-error``: smoothing of both sides, HAC covariance.

Each estimator is timed twice: ``fit`` (what a user calls: validation, the method, and in
the new code the fit check and the floor check of its standard errors) and ``(method)``,
the method's own ``run`` alone.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "refactor.md"

#: The old code's defaults, spelled out for the new code (which changed them).
OLD_EKF = {"initial_velocity_sd_mps": 0.05, "initial_angle_sd_rad": 0.01,
           "process_velocity_sd_mps": 1e-3, "process_rate_sd_radps": 1e-3,
           "process_angle_sd_rad": 1e-5}
NEW_AS_OLD = {
    "output-error": {"noise_model": "channel", "positions": "known"},
    "ekf": {**OLD_EKF, "noise_model": "channel", "positions": "known"},
    "equation-error": {"smoothing": "both"},
    "eam-pso": {"n_particles": 100, "n_iterations": 20},
}
OLD = {"output-error": {}, "ekf": {}, "equation-error": {"smoothing": "both"},
       "eam-pso": {"n_particles": 100, "n_iterations": 20}}
#: The new defaults, timed in rows of their own (new code only).
NEW_DEFAULTS = {"output-error (new defaults)": ("output-error", {}),
                "ekf (new defaults)": ("ekf", {})}

CHILD = r"""
import json, os, sys, time
import numpy as np
import aeroid
repeats, new = int(sys.argv[1]), sys.argv[2] == "new"
options = json.loads(sys.argv[3])
extra = json.loads(sys.argv[4])
scenario = aeroid.reference_scenario()
noise = aeroid.make_noise("paper")
flight = aeroid.simulate_scenario(scenario, noise=noise, rng=1)
if new:
    from aeroid import model
    const = model.constants(scenario.airframe)
else:
    model = aeroid
    const = aeroid.constants(scenario.airframe)
rng = np.random.default_rng(0)
theta = np.asarray(scenario.coefficient_vector)
sets = np.ascontiguousarray(theta * (1 + 0.3 * rng.uniform(-1, 1, (450, 9))))
x0 = np.ascontiguousarray(np.broadcast_to(flight.states()[0], (450, 9)))
delta = np.ascontiguousarray(flight["delta"][:-1])
tasks = {"rk4": lambda: model.propagate(x0, sets, delta, flight.dt, const, backend="numba")}
for name, opts in options.items():
    est = aeroid.make_estimator(name, opts)
    tasks[name] = (lambda e: lambda: e.fit(flight, rng=1))(est)
    tasks[name + " (method)"] = (
        lambda e: lambda: e.run(flight, np.random.default_rng(1)))(est)
for label, (name, opts) in extra.items():
    est = aeroid.make_estimator(name, opts)
    tasks[label] = (lambda e: lambda: e.fit(flight, rng=1))(est)
out = {}
for label, task in tasks.items():
    task()
    times = []
    for _ in range(repeats * (5 if label == "rk4" else 1)):  # rk4: short, noisy
        t = time.process_time(); task(); times.append(time.process_time() - t)
    out[label] = times
print(json.dumps(out))
"""


def _child(tree: Path, which: str, repeats: int) -> dict[str, list[float]]:
    env = {**os.environ, "PYTHONPATH": str(tree), "NUMBA_NUM_THREADS": "1",
           "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    options = NEW_AS_OLD if which == "new" else OLD
    extra = NEW_DEFAULTS if which == "new" else {}
    done = subprocess.run([sys.executable, "-W", "ignore", "-c", CHILD, str(repeats), which,
                           json.dumps(options), json.dumps(extra)], env=env, cwd=tree,
                          capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"bench_refactor: the {which} tree failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", type=Path, required=True, help="checkout of the old code")
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="print only")
    args = parser.parse_args(argv)
    times: dict[str, dict[str, list[float]]] = {"old": {}, "new": {}}
    ratios: dict[str, list[float]] = {}
    for r in range(args.rounds):
        order = ("old", "new") if r % 2 == 0 else ("new", "old")
        got = {w: _child(args.old if w == "old" else ROOT, w, args.repeats) for w in order}
        for which, result in got.items():
            for label, ts in result.items():
                times[which].setdefault(label, []).extend(ts)
        for label in got["old"]:
            ratios.setdefault(label, []).append(statistics.median(got["new"][label])
                                                / statistics.median(got["old"][label]))
        print(f"round {r + 1}/{args.rounds} done", file=sys.stderr)
    rows = ["| task | old [ms] | new [ms] | new / old (median of rounds) |", "|---|---|---|---|"]
    for label in times["new"]:
        new = statistics.median(times["new"][label]) * 1e3
        if label in times["old"]:
            old = statistics.median(times["old"][label]) * 1e3
            rows.append(f"| {label} | {old:.1f} | {new:.1f} | "
                        f"{statistics.median(ratios[label]):.3f} |")
        else:
            rows.append(f"| {label} | - | {new:.1f} | - |")
    stamp = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    text = "\n".join([
        "# Old against new code (benchmarks/bench_refactor.py)", "",
        f"Measured {stamp} on {platform.machine()}, {os.cpu_count()} cores (shared), with "
        f"`python benchmarks/bench_refactor.py --old <a2f5899 checkout> --rounds "
        f"{args.rounds} --repeats {args.repeats}`: CPU time per task, one numba thread, "
        "medians over all rounds and repeats; old at a2f5899 (before the model was "
        "written once), new at the working tree.", "", *rows, ""])
    print(text)
    if not args.quick:
        OUT.write_text(text)
        print(f"written to {OUT.relative_to(ROOT)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
