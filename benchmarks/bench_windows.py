"""Several windows in one fit: accuracy, coverage, the gain over one window, the verdict.

Run by hand from the repository root::

    python benchmarks/bench_windows.py              # 10 flights, writes results/windows.md
    python benchmarks/bench_windows.py --flights 3  # prints only

Flights: the reference scenario recorded over 5-8 s with the Gaussian IMU
(``make_noise("gaussian")`` defaults, positions exact), flight seed 0..N-1. Each flight is
cut into the windows 5-6 and 7-8 s (501 samples each) and fitted by output-error, the EKF
and equation-error (two-step) with the two windows together, and by output-error on the
first window alone. Reported per method: mean |error| over the nine coefficients and the
flights [% of the truth], coverage of the 95 % intervals (share of coefficient-flights
with ``|theta - truth| <= 1.96 stderr``), the median of stderr (two windows) / stderr (one
window) for output-error, and how often the fit was refused (``success=False``: the fit
check's verdict on a correct model).

Known wrong: the second window taken from a flight whose true Cma and Cmq are 10 %
larger (the coefficients are NOT shared); how often each method's fit is refused.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import aeroid  # noqa: E402
from aeroid.flights import (  # noqa: E402
    Windows,
    cut_windows,
    make_noise,
    reference_scenario,
    simulate_scenario,
)

SPEC = "5-6,7-8"
METHODS = {"output-error": {}, "ekf": {}, "equation-error": {}}
#: The known-wrong windows: these coefficients 10 % larger in the second window's flight.
CHANGED = ("Cma", "Cmq")


def _scenario(factor: dict[str, float] | None = None):
    sc = reference_scenario()
    sc = dataclasses.replace(sc, manoeuvre=dataclasses.replace(sc.manoeuvre,
                                                               window_s=(5.0, 8.0)))
    if factor:
        coefs = list(sc.coefficients)
        for name, f in factor.items():
            coefs[aeroid.NAMES.index(name)] *= f
        sc = dataclasses.replace(sc, coefficients=tuple(coefs))
    return sc


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--flights", type=int, default=10)
    args = parser.parse_args()
    noise = make_noise("gaussian")
    truth = aeroid.nominal()
    rows: dict[str, list] = {m: [] for m in [*METHODS, "output-error (window 1)"]}
    wrong: dict[str, list] = {m: [] for m in METHODS}
    ratios, times = [], {m: [] for m in rows}
    for seed in range(args.flights):
        flight = simulate_scenario(_scenario(), noise, rng=seed)
        windows = cut_windows(flight, SPEC)
        other = simulate_scenario(_scenario(dict.fromkeys(CHANGED, 1.1)), noise,
                                  rng=1000 + seed)
        mixed = Windows((windows.flights[0], cut_windows(other, "7-8").flights[0]),
                        ("5-6", "7-8 (other coefficients)"))
        for name, options in METHODS.items():
            est = aeroid.make_estimator(name, options)
            start = time.perf_counter()
            res = est.fit(windows, rng=seed)
            times[name].append(time.perf_counter() - start)
            rows[name].append(res)
            wrong[name].append(est.fit(mixed, rng=seed))
        est = aeroid.make_estimator("output-error", {})
        start = time.perf_counter()
        one = est.fit(windows.flights[0], rng=seed)
        times["output-error (window 1)"].append(time.perf_counter() - start)
        rows["output-error (window 1)"].append(one)
        ratios.append(rows["output-error"][-1].stderr / one.stderr)
        print(f"flight {seed} done", flush=True)
    lines = [f"# Several windows in one fit ({args.flights} flights, windows {SPEC} s)", "",
             "`python benchmarks/bench_windows.py --flights "
             f"{args.flights}`; reference scenario over 5-8 s, Gaussian IMU.", "",
             "| method | mean abs error % | coverage 95 % | refused (correct) | "
             "refused (wrong: Cma, Cmq +10 % in window 2) | median time s |",
             "| --- | --- | --- | --- | --- | --- |"]
    for name, results in rows.items():
        theta = np.array([r.theta for r in results])
        sd = np.array([r.stderr for r in results])
        err = np.mean(np.abs(theta / truth - 1.0)) * 100.0
        cover = np.mean(np.abs(theta - truth) <= 1.96 * sd)
        refused = sum(not r.success for r in results)
        bad = (f"{sum(not r.success for r in wrong[name])} / {len(wrong[name])}"
               if name in wrong else "-")
        lines.append(f"| {name} | {err:.3f} | {cover:.3f} | {refused} / {len(results)} | "
                     f"{bad} | {np.median(times[name]):.2f} |")
    ratio = np.median(np.array(ratios), axis=0)
    lines += ["", "Output-error, median stderr (two windows) / stderr (window 1) per "
              "coefficient: " + ", ".join(f"{n} {r:.3f}" for n, r in zip(aeroid.NAMES, ratio,
                                                                           strict=True)), ""]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.flights >= 10:
        out = Path(__file__).parent / "results" / "windows.md"
        out.write_text(text)
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
