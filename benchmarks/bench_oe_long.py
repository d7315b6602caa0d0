"""Output-error's cost on a long record beside the reference flight (issue 23).

Run by hand from the repository root::

    python benchmarks/bench_oe_long.py --label "after"            # appends to results
    python benchmarks/bench_oe_long.py --label "before" --samples 20000 --repeats 2

Two flights of the reference scenario (:func:`aeroid.reference_scenario`: its airframe,
coefficients and relay law), simulated with Gaussian IMU noise
(:class:`aeroid.flights.GaussianNoise` defaults, seed 23): the reference window (5-6 s,
501 samples) and a long window from 5 s of ``--samples`` samples (20 000: 40 s at
500 Hz). Each is fitted with :class:`baselines.output_error.OutputErrorEstimator` at its
defaults through ``Estimator.fit`` (validation, the fit, the fit check and the floor
warnings), in ONE process:

* ``first s`` and ``first RSS MB``: the first fit of that length (CasADi graph build, C
  compile or the disk cache's load, numba JIT on the first flight) and its peak resident
  set above the one before it (as ``RSS MB`` below): not the steady cost, reported apart.
  With ``--fresh-cache`` the compiled models' disk cache (``AEROID_CASADI_CACHE``) is a new
  empty folder, so a first fit that needs a C model compiles it;
* ``build s`` and ``build RSS MB``: after those, the record model alone
  (``OutputErrorEstimator.problem``) built once more with CasADi's graph cache emptied
  and the C library on disk (the graph's construction: what a first fit of a record adds
  when its library exists);
* ``fit s``: the minimum and median wall time of ``--repeats`` later fits (warm), and
  ``CPU s`` the minimum of their process CPU time (the machine is shared: the CPU time
  is the less disturbed figure; one BLAS thread, so CPU time <= wall time);
* ``RSS MB``: the peak resident set during one warm fit above the resident set just
  before it (``VmHWM`` of ``/proc/self/status`` after resetting it through
  ``/proc/self/clear_refs``): everything the fit allocates, CasADi's work vectors included;
* ``traced MB``: tracemalloc's peak during one more warm fit above the memory traced
  before it (numpy's and Python's allocations, not CasADi's; tracemalloc slows Python,
  so that fit is not timed).

Then the fits' numbers: Cx and Cmq and their standard errors, the cost, the iterations.
The rows are appended to ``benchmarks/results/oe_long.md`` under ``--label`` with the
commit of the tree the code was imported from (``PYTHONPATH=/work/main python
benchmarks/bench_oe_long.py`` measures another checkout); ``--no-write`` only prints.
"""

from __future__ import annotations

import os

# One BLAS thread: the machine's two cores are shared (bench_baselines.py's measurement);
# must be set before numpy is imported.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import datetime as dt  # noqa: E402
import platform  # noqa: E402
import shlex  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402
import warnings  # noqa: E402
from dataclasses import replace  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import aeroid  # noqa: E402
from aeroid.flights import GaussianNoise, simulate  # noqa: E402
from baselines.output_error import OutputErrorEstimator  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "oe_long.md"
SEED = 23
RATE_HZ = 500.0
START_S = 5.0


def symbolic_cache_clear() -> None:
    """Empty CasADi's record-graph cache (the next model builds its graph again)."""
    from aeroid.model import _forward  # the cache is private; this benchmark measures it
    _forward._symbolic_record.cache_clear()


def flight_of(n_samples: int) -> aeroid.Flight:
    """The reference scenario recorded for ``n_samples`` samples from 5 s, Gaussian IMU."""
    s = aeroid.reference_scenario()
    window = (START_S, START_S + (n_samples - 1) / RATE_HZ)
    flight = simulate(s.airframe, s.coefficient_vector, replace(s.manoeuvre, window_s=window),
                      GaussianNoise(), rng=SEED)
    if flight.n_samples != n_samples:
        raise SystemExit(f"asked {n_samples} samples, simulated {flight.n_samples}")
    return flight


def _status_mb(key: str) -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def rss_delta_mb(fit) -> float:
    """Peak resident set during ``fit()`` above the resident set before it [MB]."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")  # reset VmHWM to the current resident set
    except OSError:
        return float("nan")
    before = _status_mb("VmRSS")
    fit()
    return _status_mb("VmHWM") - before


def traced_mb(fit) -> float:
    """tracemalloc's peak during ``fit()`` above what was traced before it [MB]."""
    tracemalloc.start()
    try:
        now, _ = tracemalloc.get_traced_memory()
        tracemalloc.reset_peak()
        fit()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return (peak - now) / 2**20


def measure(flight: aeroid.Flight, repeats: int) -> dict:
    """First, warm, RSS and traced figures of output-error's fit of ``flight``."""
    estimator = OutputErrorEstimator()
    results = []

    def fit():
        results.append(estimator.fit(flight, rng=0))

    start = time.perf_counter()
    first_rss = rss_delta_mb(fit)
    first = time.perf_counter() - start
    symbolic_cache_clear()
    start = time.perf_counter()
    build_rss = rss_delta_mb(lambda: estimator.problem(flight))
    build = time.perf_counter() - start
    times, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        fit()
        times.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    rss = rss_delta_mb(fit)
    traced = traced_mb(fit)
    r = results[-1]
    names = list(aeroid.NAMES)
    out = {"n": flight.n_samples, "first": first, "first_rss": first_rss, "build": build,
           "build_rss": build_rss, "min": min(times),
           "cpu": min(cpu), "median": statistics.median(times), "rss": rss, "traced": traced,
           "success": r.success, "iterations": r.n_iterations, "cost": r.cost}
    for name in ("Cx", "Cmq"):
        j = names.index(name)
        out[name] = float(r.theta[j])
        out[name + "_se"] = float(r.stderr[j]) if r.stderr is not None else float("nan")
    return out


def commit() -> str:
    """The commit of the tree aeroid was imported from (and '+dirty' with changes)."""
    tree = Path(aeroid.__file__).resolve().parents[1]
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=tree,
                              capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--",
                                ".", ":!benchmarks/results"],  # the results: not code
                               cwd=tree, capture_output=True, text=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+dirty" if dirty else "")


HEADER = ("| label | commit | samples | first s | first RSS MB | build s | build RSS MB "
          "| fit s (min) | fit s (median) "
          "| CPU s (min) | RSS MB | traced MB | iterations | cost | Cx | se Cx | Cmq | se Cmq "
          "| success |\n"
          "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"
          "\n")


def row(label: str, tree: str, m: dict) -> str:
    """One table row of a measurement."""
    return (f"| {label} | {tree} | {m['n']} | {m['first']:.2f} | {m['first_rss']:.0f} | "
            f"{m['build']:.2f} | {m['build_rss']:.0f} | "
            f"{m['min']:.3f} | {m['median']:.3f} | {m['cpu']:.3f} | {m['rss']:.0f} | "
            f"{m['traced']:.0f} | {m['iterations']} | "
            f"{m['cost']:.6g} | {m['Cx']:.6f} | {m['Cx_se']:.3g} | {m['Cmq']:.2f} | "
            f"{m['Cmq_se']:.3g} | {m['success']} |\n")


def main() -> None:
    """Measure both flights in one process and append the rows."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--label", default="this tree")
    parser.add_argument("--samples", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=3,
                        help="warm fits timed per flight (the long one: at least 1)")
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--fresh-cache", action="store_true",
                        help="compile the C models into a new empty cache folder")
    args = parser.parse_args()
    if args.fresh_cache:
        os.environ["AEROID_CASADI_CACHE"] = tempfile.mkdtemp(prefix="aeroid-casadi-")
    warnings.simplefilter("ignore")
    lines = []
    tree = commit()
    load_before = os.getloadavg()
    for n in (501, args.samples):
        m = measure(flight_of(n), args.repeats)
        lines.append(row(args.label, tree, m))
        print(lines[-1], end="", flush=True)
    if len(lines) == 2:
        short, long = (float(x.split("|")[8]) for x in lines)
        ratio = long / short
        cpu_ratio = float(lines[1].split("|")[10]) / float(lines[0].split("|")[10])
        lines.append(f"\n{args.label}: {args.samples / 501:.0f}x the samples at "
                     f"{ratio:.0f}x the warm wall time, {cpu_ratio:.0f}x the CPU time "
                     "(minima).\n")
        print(lines[-1], end="")
    if args.no_write:
        return
    if not OUT.exists():
        OUT.write_text("# Output-error on a long record (benchmarks/bench_oe_long.py)\n\n"
                       "Columns: module docstring of the benchmark.\n")
    cmd = shlex.join(["python", "benchmarks/bench_oe_long.py", *sys.argv[1:]])
    load = "/".join(f"{a:.1f}-{b:.1f}" for a, b in zip(load_before, os.getloadavg(),
                                                        strict=True))
    with OUT.open("a") as f:
        f.write(f"\n## {args.label}\n\n{dt.date.today()}, {platform.machine()}, Python "
                f"{platform.python_version()}, numpy {np.__version__}, load average "
                f"(1/5/15 min, start-end) {load} on {os.cpu_count()} cores; `{cmd}`\n\n")
        f.write(HEADER)
        f.writelines(lines)


if __name__ == "__main__":
    main()
