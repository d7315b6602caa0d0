"""How often ``estimate_wind = "auto"`` calls a log still air (issue 26; no fits).

Run by hand from the repository root (one process)::

    python benchmarks/bench_wind_auto.py --seeds 50            # writes results/wind_auto.md
    python benchmarks/bench_wind_auto.py --seeds 5 --no-write

Per seed ``k`` (``rng = k``): the reference scenario with Gaussian IMU noise and a probe
(alpha and beta with 0.1 deg of white noise, airspeed with 0.5 m/s; "vanes": the angles
alone), in still air, in steady winds (the issue's 3 north / 4 east, and small ones along
and across the path) and in Dryden turbulence. Each log is judged by
:func:`aeroid.estimation.log_air` as the simulator wrote it (its metadata declares the
air flown) and as an undeclared log (the key removed). Reported per case: how many logs
were called still air (the wind then not estimated by default). Wrong answers: a still-air
log the rule does not call still (the wind estimated for nothing: a cost, not a wrong
physics) and a windy log called still (the wind assumed away: the dangerous one).
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

from aeroid.estimation import log_air  # noqa: E402
from aeroid.flights import GaussianNoise, Wind, reference_scenario, simulate  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "wind_auto.md"
VANE_SD = np.radians(0.1)
AIRSPEED_SD = 0.5
#: (name, wind, probe): the probe "full" logs alpha, beta and airspeed; "vanes" the angles.
CASES = (
    ("still air, probe", None, "full"),
    ("still air, vanes", None, "vanes"),
    ("wind 3 N 4 E, probe", Wind(steady_ned_mps=(3.0, 4.0, 0.0)), "full"),
    ("wind 0.5 N (along the path), probe", Wind(steady_ned_mps=(0.5, 0.0, 0.0)), "full"),
    ("wind 0.2 N (along the path), probe", Wind(steady_ned_mps=(0.2, 0.0, 0.0)), "full"),
    ("wind 0.2 E (across), probe", Wind(steady_ned_mps=(0.0, 0.2, 0.0)), "full"),
    ("Dryden sd 1, probe", Wind(turbulence_sd_mps=1.0), "full"),
)


def _flight(wind: Wind | None, probe: str, seed: int):
    s = reference_scenario()
    noise = GaussianNoise(alpha_sd_rad=VANE_SD, beta_sd_rad=VANE_SD,
                          airspeed_sd_mps=AIRSPEED_SD if probe == "full" else 0.0)
    manoeuvre = dataclasses.replace(s.manoeuvre, wind=wind)
    return simulate(s.airframe, s.coefficient_vector, manoeuvre, noise, rng=seed)


def main(argv: list[str] | None = None) -> int:
    """Judge the logs; print (and write) the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=50)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    rows = []
    for name, wind, probe in CASES:
        declared, bare, kinds = 0, 0, {}
        for seed in range(1, args.seeds + 1):
            flight = _flight(wind, probe, seed)
            declared += log_air(flight).still
            stripped = dataclasses.replace(flight, metadata={
                k: v for k, v in flight.metadata.items() if k != "wind"})
            said = log_air(stripped)
            bare += said.still
            kind = said.verdict or "not read (no airspeed)"
            kinds[kind] = kinds.get(kind, 0) + 1
        shown = ", ".join(f"{k} {v}" for k, v in sorted(kinds.items()))
        rows.append(f"| {name} | {declared}/{args.seeds} | {bare}/{args.seeds} | {shown} |")
    elapsed = time.perf_counter() - start
    head = ["| log | called still air, as simulated (declared) | called still air, "
            "undeclared | the air-data verdict, undeclared |", "|---|---|---|---|"]
    text = "\n".join([
        "# estimate_wind = auto: what log_air calls still air",
        "",
        f"`python benchmarks/bench_wind_auto.py --seeds {args.seeds}` "
        f"({dt.date.today().isoformat()}, {elapsed:.0f} s, one process); seeds 1-{args.seeds}, "
        "reference flight, Gaussian IMU, vanes 0.1 deg, airspeed 0.5 m/s.",
        "", *head, *rows, ""])
    print(text)
    if not args.no_write:
        RESULTS.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
