"""Benchmark the foundation: simulating the reference flight and the batched RK4.

Run by hand from the repository root::

    python benchmarks/bench_foundation.py             # 21 repeats, writes results/foundation.md
    python benchmarks/bench_foundation.py --quick     # 5 repeats, prints only

Cases (medians over the repeats, after one warm-up call that loads or compiles the
numba kernels; the machine may be shared, so the table also gives the minimum and the
load average when the benchmark started):

* ``simulate()`` of the reference flight (t = 0..6 s, truth RK4 at 0.25 ms, relay
  closed on the roll angle, noise-free and with the paper's noise);
* one batched ``propagate`` over the 1-s window (500 steps of 2 ms, substeps = 1) for
  450 coefficient sets (EAM-PSO's swarm), on the numba backend (parallel kernel, all
  numba threads), the serial numba kernel (one thread), the numpy backend, and the
  kernel of the first commit (``git show e4a5cfc:aeroid/integrate.py``) when git can
  provide it; the parallel kernels again with one numba thread (per-thread cost);
* ``cramer_rao_sd`` of the reference scenario (paper noise).
"""

from __future__ import annotations

import argparse
import datetime as dt
import importlib.util
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numba  # noqa: E402

from aeroid.estimation._floor import cramer_rao_sd  # noqa: E402
from aeroid.flights._noise import NoNoise, PaperNoise  # noqa: E402
from aeroid.flights._scenario import reference_scenario  # noqa: E402
from aeroid.flights._simulate import simulate_scenario  # noqa: E402
from aeroid.model import _integrate as integrate  # noqa: E402
from aeroid.model._dynamics import constants  # noqa: E402

N_SETS = 450
FIRST_COMMIT = "e4a5cfc"
RESULTS = ROOT / "benchmarks" / "results" / "foundation.md"


def timed(fun: Callable[[], object], repeats: int) -> tuple[float, float, float]:
    """Return (median wall, min wall, median CPU) time [s] of ``fun`` after a warm-up.

    CPU time is this process's, summed over its threads: for a one-thread case it is the
    work itself and hardly depends on other load; a parallel case shows the total work.
    """
    fun()
    times, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        fun()
        times.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    return float(np.median(times)), float(np.min(times)), float(np.median(cpu))


def old_kernel() -> Callable[..., np.ndarray] | None:
    """Return the first commit's ``_propagate_numba`` loaded from git, or None."""
    try:
        source = subprocess.run(["git", "show", f"{FIRST_COMMIT}:aeroid/integrate.py"],
                                cwd=ROOT, capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    folder = Path(tempfile.mkdtemp(prefix="aeroid-bench-"))
    path = folder / "integrate_first_commit.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location("integrate_first_commit", path)
    module = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
    spec.loader.exec_module(module)  # type: ignore[union-attr]
    return module._propagate_numba


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="5 repeats, print only")
    parser.add_argument("--repeats", type=int, default=21)
    parser.add_argument("--no-write", action="store_true", help="print only")
    args = parser.parse_args(argv)
    repeats = 5 if args.quick else args.repeats
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")

    scenario = reference_scenario()
    clean = simulate_scenario(scenario, NoNoise(), rng=0)
    const = constants(scenario.airframe)
    k = tuple(float(v) for v in const)
    rng = np.random.default_rng(0)
    sets = scenario.coefficient_vector * (1.0 + 0.4 * (rng.random((N_SETS, 9)) - 0.5))
    x0 = clean.states()[0]
    state0 = np.ascontiguousarray(np.broadcast_to(x0, (N_SETS, 9)))
    delta = clean["delta"][:-1]
    h = clean.dt

    rows: list[tuple[str, float, float, float]] = []

    def add(label: str, fun: Callable[[], object], n: int = repeats) -> None:
        median, best, cpu = timed(fun, n)
        rows.append((label, median, best, cpu))
        print(f"{label:64s} median {median * 1e3:8.2f} ms  min {best * 1e3:8.2f} ms  "
              f"CPU {cpu * 1e3:8.2f} ms", flush=True)

    add("simulate() reference flight, no noise",
        lambda: simulate_scenario(scenario, NoNoise(), rng=0))
    add("simulate() reference flight, paper noise",
        lambda: simulate_scenario(scenario, PaperNoise(), rng=1))
    add(f"propagate {N_SETS} sets x 500 steps, numba parallel (auto)",
        lambda: integrate.propagate(x0, sets, delta, h, const))
    add(f"propagate {N_SETS} sets x 500 steps, numba serial kernel",
        lambda: integrate._propagate_serial(state0, sets, delta, h, 1, k))
    add(f"propagate {N_SETS} sets x 500 steps, numpy backend",
        lambda: integrate.propagate(x0, sets, delta, h, const, backend="numpy"),
        max(3, repeats // 4))
    old = old_kernel()
    if old is not None:
        add(f"propagate {N_SETS} sets x 500 steps, first commit's numba kernel",
            lambda: old(state0, sets, delta, h, k, 1))
    # per-thread cost, less sensitive to other work on a shared machine (benchmark only:
    # aeroid itself never sets the number of threads)
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        add(f"propagate {N_SETS} sets x 500 steps, numba parallel kernel, 1 thread",
            lambda: integrate.propagate(x0, sets, delta, h, const))
        if old is not None:
            add(f"propagate {N_SETS} sets x 500 steps, first commit's kernel, 1 thread",
                lambda: old(state0, sets, delta, h, k, 1))
    finally:
        numba.set_num_threads(threads)
    add("cramer_rao_sd(reference scenario, paper noise)",
        lambda: cramer_rao_sd(scenario, PaperNoise()), max(3, repeats // 4))

    command = "python benchmarks/bench_foundation.py" + (" --quick" if args.quick else "")
    lines = [
        "# Foundation benchmarks",
        "",
        f"Command: `{command}` (repository root). Written by the script; medians over "
        f"{repeats} repeats after one warm-up call (numpy backend, first-commit kernel and "
        f"Cramér-Rao floor: {max(3, repeats // 4)} repeats).",
        "",
        f"- date: {dt.datetime.now(dt.UTC).strftime('%Y-%m-%d %H:%M UTC')}",
        f"- machine: {platform.machine()}, {os.cpu_count()} CPUs, {platform.processor() or '?'};"
        f" Python {platform.python_version()}, numpy {np.__version__}, numba {numba.__version__}",
        f"- numba threads: {numba.get_num_threads()}, threading layer: "
        f"{numba.threading_layer()}",
        f"- 1-min load average when started: {load:.2f} (the machine is shared with other "
        "work: medians and minima of wall time, and this process's CPU time, which for the "
        "one-thread rows is the work itself and hardly depends on the load)",
        "",
        "| case | median wall [ms] | min wall [ms] | median CPU [ms] |",
        "|---|---:|---:|---:|",
    ]
    lines += [f"| {label} | {median * 1e3:.2f} | {best * 1e3:.2f} | {cpu * 1e3:.2f} |"
              for label, median, best, cpu in rows]
    lines += [
        "",
        "Targets (task brief): simulate() <= 1 s; one batched propagate of 450 sets <= 25 ms.",
        "",
    ]
    text = "\n".join(lines)
    print()
    print(text)
    if not (args.quick or args.no_write):
        RESULTS.parent.mkdir(parents=True, exist_ok=True)
        notes = ""
        if RESULTS.exists():  # keep the hand-written interpretation below the table
            old_text = RESULTS.read_text()
            if "\n## Notes" in old_text:
                notes = old_text[old_text.index("\n## Notes"):]
        RESULTS.write_text(text + notes)
        print(f"wrote {RESULTS.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
