"""A refactoring against the code before it, side by side in one session: same numbers, same speed.

Run by hand from the repository root::

    python benchmarks/bench_refactor.py --old /work/main
    python benchmarks/bench_refactor.py --old ../main --rounds 1 --repeats 1 --quick  # prints only

``--old`` is a checkout of the code before the refactoring (for the sizes-from-the-model
work: main). Each round starts one fresh process per tree, in alternating order (old-new,
new-old, ...), so both see the same machine load; each process simulates the reference
flight with the paper's noise (seed 1), runs every task once to compile and warm up (and
keeps that run's numbers), then times ``--repeats`` runs of each with
``time.process_time`` (CPU time of the process; one numba thread). Reported: the median
over all rounds and repeats, the median of the per-round ratio new / old, and the largest
difference of the numbers relative to the old ones' largest magnitude.

Tasks, each at the same settings in both trees:

* ``rk4``: one batched RK4 pass over the flight for 450 coefficient sets (EAM-PSO's
  inner loop, the compiled kernel on one thread; five times ``--repeats`` timings); its
  numbers are the final states of the 450 trajectories;
* ``eam-pso``: EAM-PSO at 100 particles x 20 iterations;
* ``output-error``, ``ekf``, ``equation-error``: the defaults.

Each estimator is timed twice: ``fit`` (what a user calls: validation, the method, the
fit check and the floor check of its standard errors) and ``(method)``, the method's own
``run`` alone; its numbers are the estimated coefficients and standard errors.
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

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "refactor.md"

OPTIONS = {"output-error": {}, "ekf": {}, "equation-error": {},
           "eam-pso": {"n_particles": 100, "n_iterations": 20}}

CHILD = r"""
import json, sys, time
import numpy as np
import aeroid
from aeroid import model
repeats = int(sys.argv[1])
options = json.loads(sys.argv[2])
scenario = aeroid.reference_scenario()
flight = aeroid.simulate_scenario(scenario, noise=aeroid.make_noise("paper"), rng=1)
const = model.constants(scenario.airframe)
rng = np.random.default_rng(0)
theta = np.asarray(scenario.coefficient_vector)
sets = np.ascontiguousarray(theta * (1 + 0.3 * rng.uniform(-1, 1, (450, theta.size))))
x0 = np.ascontiguousarray(np.broadcast_to(flight.states()[0], (450, flight.states().shape[1])))
delta = np.ascontiguousarray(flight["delta"][:-1])
tasks = {"rk4": lambda: model.propagate(x0, sets, delta, flight.dt, const,
                                        backend="numba")[:, -1]}
for name, opts in options.items():
    est = aeroid.make_estimator(name, opts)
    tasks[name] = (lambda e: lambda: e.fit(flight, rng=1))(est)
    tasks[name + " (method)"] = (
        lambda e: lambda: e.run(flight, np.random.default_rng(1)))(est)


def numbers(out):
    if isinstance(out, np.ndarray):
        return out.ravel().tolist()
    stderr = [] if out.stderr is None else list(out.stderr)
    return [float(v) for v in (*out.theta, *stderr)]


out = {}
for label, task in tasks.items():
    first = numbers(task())
    times = []
    for _ in range(repeats * (5 if label == "rk4" else 1)):  # rk4: short, noisy
        t = time.process_time(); task(); times.append(time.process_time() - t)
    out[label] = {"times": times, "numbers": first}
print(json.dumps(out))
"""


def _child(tree: Path, repeats: int) -> dict[str, dict[str, list[float]]]:
    env = {**os.environ, "PYTHONPATH": str(tree), "NUMBA_NUM_THREADS": "1",
           "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, "-W", "ignore", "-c", CHILD, str(repeats),
                           json.dumps(OPTIONS)], env=env, cwd=tree,
                          capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"bench_refactor: the tree {tree} failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _commit(tree: Path) -> str:
    done = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True, check=False)
    return done.stdout.strip() or "?"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", type=Path, required=True, help="checkout of the old code")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--quick", action="store_true", help="print only")
    args = parser.parse_args(argv)
    times: dict[str, dict[str, list[float]]] = {"old": {}, "new": {}}
    ratios: dict[str, list[float]] = {}
    differences: dict[str, float] = {}
    for r in range(args.rounds):
        order = ("old", "new") if r % 2 == 0 else ("new", "old")
        got = {w: _child(args.old if w == "old" else ROOT, args.repeats) for w in order}
        for which, result in got.items():
            for label, entry in result.items():
                times[which].setdefault(label, []).extend(entry["times"])
        for label, entry in got["old"].items():
            ratios.setdefault(label, []).append(
                statistics.median(got["new"][label]["times"]) / statistics.median(entry["times"]))
            old, new = np.array(entry["numbers"]), np.array(got["new"][label]["numbers"])
            diff = (float(np.max(np.abs(new - old)) / np.max(np.abs(old)))
                    if old.shape == new.shape else float("inf"))
            differences[label] = max(differences.get(label, 0.0), diff)
        print(f"round {r + 1}/{args.rounds} done", file=sys.stderr)
    rows = ["| task | old [ms] | new [ms] | new / old (median of rounds) "
            "| numbers: largest change / largest old |", "|---|---|---|---|---|"]
    for label in times["new"]:
        new = statistics.median(times["new"][label]) * 1e3
        old = statistics.median(times["old"][label]) * 1e3
        rows.append(f"| {label} | {old:.1f} | {new:.1f} | "
                    f"{statistics.median(ratios[label]):.3f} | {differences[label]:.1e} |")
    stamp = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    text = "\n".join([
        "# Refactoring against the code before it (benchmarks/bench_refactor.py)", "",
        f"Measured {stamp} on {platform.machine()}, {os.cpu_count()} cores (shared), with "
        f"`python benchmarks/bench_refactor.py --old <checkout> --rounds {args.rounds} "
        f"--repeats {args.repeats}`: CPU time per task, one numba thread, medians over all "
        f"rounds and repeats; old at {_commit(args.old)}, new at {_commit(ROOT)} (the "
        "working tree). Numbers: the first (warm-up) run's coefficients and standard "
        "errors (rk4: final states), largest difference over the rounds.", "", *rows, ""])
    print(text)
    if not args.quick:
        OUT.write_text(text)
        print(f"written to {OUT.relative_to(ROOT)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
