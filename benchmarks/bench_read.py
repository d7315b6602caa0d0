"""Benchmark reading large flight logs: ``read_flight`` and ``Flight.check`` time and memory.

Run by hand from the repository root::

    python benchmarks/bench_read.py                 # writes the logs to /tmp, then measures
    python benchmarks/bench_read.py --reuse         # measure logs written by an earlier run

Two CSV logs with their sidecars (17 significant digits, the 19 channels): 20,000
samples (7.6 MB) and 560,000 samples (about 213 MB), the reference flight with the
paper's noise repeated end to end (the time column continues; the roll angle restarts
at each repeat, so ``check`` reports a jump there, which costs it nothing). Each is read
in a fresh interpreter, three times; the table gives each run's wall time of
``read_flight`` and of ``Flight.check``; the peak resident memory above the level after
``import aeroid``, during the read and during read + check (Linux: the peak ``VmHWM``,
reset through ``/proc/self/clear_refs`` after the import, is what
``resource.getrusage``'s ``ru_maxrss`` reports but cannot reset); the process's whole
``ru_maxrss`` (imports included); and the flight's own size (8 bytes per value). The
logs are not kept in the repository.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

LOGS = {"20k": (Path("/tmp/aeroid-20k.csv"), 20_000),
        "200MB": (Path("/tmp/aeroid-200mb.csv"), 560_000)}
REPEATS = 3

MEASURE = """
import resource, sys, time, warnings
import aeroid
from aeroid.flights import read_flight

def status_mb(key):
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) for line in fh if line.startswith(key)) / 1024

with open("/proc/self/clear_refs", "w") as fh:  # reset the peak (VmHWM) to the current RSS
    fh.write("5")
base = status_mb("VmRSS")
t0 = time.perf_counter()
flight = read_flight(sys.argv[1])
t1 = time.perf_counter()
read_peak = status_mb("VmHWM") - base
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    flight.check()
t2 = time.perf_counter()
check_peak = status_mb("VmHWM") - base
total = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(flight.n_samples, f"{t1 - t0:.2f}", f"{t2 - t1:.2f}", f"{read_peak:.0f}",
      f"{check_peak:.0f}", f"{total:.0f}", f"{flight.data.memory_usage().sum() / 2**20:.0f}")
"""


def write_logs() -> None:
    """Write both logs (the reference flight, paper noise, seed 1, repeated)."""
    from aeroid.flights import PaperNoise, load_scenario, make_flight, simulate_scenario

    flight = simulate_scenario(load_scenario(None), PaperNoise(), rng=1)
    for path, n in LOGS.values():
        reps = -(-n // flight.n_samples)
        data = {c: np.tile(flight[c], reps)[:n] for c in flight.channels}
        data["t"] = 5.0 + np.arange(n) * flight.dt
        make_flight(data, flight.airframe, dict(flight.metadata)).write(path)
        print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)", flush=True)


def main() -> None:
    """Write (unless --reuse) and measure the logs; print a Markdown table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reuse", action="store_true", help="measure existing logs")
    args = parser.parse_args()
    if not args.reuse:
        write_logs()
    print("| log | samples | file MB | read_flight s | check s | peak +MB read | peak +MB "
          "read+check | ru_maxrss MB | flight MB |")
    print("|---|---|---|---|---|---|---|---|---|")
    for label, (path, _) in LOGS.items():
        for _ in range(REPEATS):
            out = subprocess.run([sys.executable, "-c", MEASURE, str(path)], check=True,
                                 capture_output=True, text=True, cwd=ROOT).stdout.split()
            n, read_s, check_s, read_peak, check_peak, total, size = out
            print(f"| {label} | {n} | {path.stat().st_size / 1e6:.0f} | {read_s} | {check_s} "
                  f"| {read_peak} | {check_peak} | {total} | {size} |", flush=True)


if __name__ == "__main__":
    main()
