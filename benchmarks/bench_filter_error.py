"""The filter-error method in Dryden turbulence and in still air, beside output-error (issue 26).

Run by hand from the repository root (one process, the fits in turn: ``--jobs 1``)::

    python benchmarks/bench_filter_error.py --seeds 20 --still-seeds 6   # writes results
    python benchmarks/bench_filter_error.py --seeds 2 --still-seeds 1 --no-write
    python benchmarks/bench_filter_error.py --timing 5     # the cost, side by side
    python benchmarks/bench_filter_error.py --wrong-seeds 6  # the verdict on wrong models
    python benchmarks/bench_filter_error.py --checks         # steady wind, paper noise, substeps

Per seed ``k`` (``rng = k``, seeds 1..N): the reference scenario's flight with Gaussian
IMU noise (0.05 m/s^2, 0.005 rad/s) in Dryden turbulence of sd ``--sd`` (default 3 m/s,
scale length 533.4 m: the scenario ``[wind]`` table's ``turbulence_sd_mps``), and, for
the first ``--still-seeds`` seeds, the same flight in still air. Both methods with their
defaults on each flight, timed one after the other in this process (the compiled models
warmed up by a first fit that is not counted).

Reported per flight kind and method: fit check passed, runs with every coefficient
within 3 of its own se, coverage of the 95 % intervals (``|error| <= 1.96 se`` over
coefficient-runs), the mean |relative error| [%], the median largest |error| / se, the
mean wall time [s] and, for filter-error, the estimated gust sd. In still air also the
largest ``|filter-error - output-error| / se`` per run (agreement). Targets (issue 26):
filter-error in sd 3 m/s: every coefficient within 3 se on >= 90 % of runs, coverage
0.90-0.97, fit check passing; output-error flagged; cost <= 10x output-error's.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # shared 2-core machine
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import datetime as dt  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from aeroid.estimation import make_estimator  # noqa: E402
from aeroid.flights import Wind, make_noise, reference_scenario, simulate  # noqa: E402
from aeroid.model import NAMES  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "filter_error.md"
RESULTS_COST = Path(__file__).parent / "results" / "filter_error_cost.md"
RESULTS_WRONG = Path(__file__).parent / "results" / "filter_error_wrong.md"
RESULTS_CHECKS = Path(__file__).parent / "results" / "filter_error_checks.md"
#: Known-wrong models for the verdict: one coefficient held off its true value.
WRONG_HOLDS = (("Cma", 1.1), ("Cma", 1.3), ("Clp", 1.1), ("Clp", 1.3), ("Cx", 1.1),
               ("Cza", 1.3), ("Cmq", 1.3), ("Cmq", 2.0))
WITHIN_SE = 3.0
Z95 = 1.959964
METHODS = ("filter-error", "output-error")


def _estimator(name: str):
    if name == "filter-error":  # by class: the entry point may not be installed yet
        from baselines.filter_error import FilterErrorEstimator
        return FilterErrorEstimator()
    return make_estimator(name, {"estimate_wind": False})  # output-error in still air, as measured


def run(seeds: int, still_seeds: int, sd: float) -> tuple[dict, list[str]]:
    """Fit both methods on every flight; return per (kind, method) records and lines."""
    s = reference_scenario()
    truth = s.coefficient_vector
    noise = make_noise("gaussian")
    estimators = {name: _estimator(name) for name in METHODS}
    warm = simulate(s.airframe, truth, s.manoeuvre, noise, rng=0)
    for est in estimators.values():  # compile and cache: not timed
        est.fit(warm, rng=0)
    rows: dict[tuple[str, str], list[dict]] = {}
    lines = []
    kinds = [("turbulence", k) for k in range(1, seeds + 1)]
    kinds += [("still", k) for k in range(1, still_seeds + 1)]
    for kind, seed in kinds:
        wind = Wind(turbulence_sd_mps=sd) if kind == "turbulence" else None
        man = dataclasses.replace(s.manoeuvre, wind=wind)
        flight = simulate(s.airframe, truth, man, noise, rng=seed)
        fits = {}
        for name, est in estimators.items():
            r = est.fit(flight, rng=seed)
            fits[name] = r
            err_se = np.abs(r.theta - truth) / r.stderr
            rec = {"success": r.success, "err_se": err_se,
                   "rel": 100 * np.mean(np.abs(r.theta / truth - 1)), "time": r.wall_time_s,
                   "sigma": r.info.get("gust_sd_mps", np.nan), "message": r.message}
            rows.setdefault((kind, name), []).append(rec)
            lines.append(f"{kind} seed {seed} {name}: success {r.success} max err/se "
                         f"{np.nanmax(err_se):.2f} mean rel err {rec['rel']:.3f} % time "
                         f"{r.wall_time_s:.2f} s sigma {rec['sigma']:.3g} "
                         f"{'' if r.success else r.message[:90]}")
            print(lines[-1], flush=True)
        if kind == "still":
            fe, oe = fits["filter-error"], fits["output-error"]
            agree = float(np.max(np.abs(fe.theta - oe.theta) / oe.stderr))
            rows[(kind, "filter-error")][-1]["agree"] = agree
            lines.append(f"still seed {seed}: max |filter-error - output-error| / se "
                         f"{agree:.3f}")
            print(lines[-1], flush=True)
    return rows, lines


def cost(repeats: int, sd: float) -> list[str]:
    """Median wall time of each method on the 501-sample reference flight (Gaussian IMU,
    seed 1), in still air and in turbulence, the fits alternating (the same machine load)."""
    s = reference_scenario()
    truth = s.coefficient_vector
    noise = make_noise("gaussian")
    estimators = {name: _estimator(name) for name in METHODS}
    out = ["| flight | filter-error median [s] | output-error median [s] | ratio | "
           "filter-error filter runs | iterations (FE / OE) |", "|---|---|---|---|---|---|"]
    for kind, wind in (("still", None), ("turbulence", Wind(turbulence_sd_mps=sd))):
        flight = simulate(s.airframe, truth, dataclasses.replace(s.manoeuvre, wind=wind),
                          noise, rng=1)
        times: dict[str, list[float]] = {name: [] for name in METHODS}
        last = {}
        for _ in range(repeats + 1):  # the first round warms up (compiled models): dropped
            for name, est in estimators.items():
                last[name] = est.fit(flight, rng=1)
                times[name].append(last[name].wall_time_s)
        fe, oe = (float(np.median(times[name][1:])) for name in METHODS)
        out.append(f"| {kind} | {fe:.2f} | {oe:.2f} | {fe / oe:.1f} | "
                   f"{last['filter-error'].n_evaluations} | "
                   f"{last['filter-error'].n_iterations} / {last['output-error'].n_iterations} |")
        print(out[-1], flush=True)
    return out


def wrong(seeds: int, sds: tuple[float, ...]) -> list[str]:
    """How often filter-error's verdict refuses a known-wrong model (a coefficient held off
    its truth, :data:`WRONG_HOLDS`) and a right one, in still air (sd 0) and in each
    Dryden intensity of ``sds``, seeds 1..N; with the gust verdict's figures
    (:mod:`baselines._gust_verdict`) and which check refused."""
    from baselines.filter_error import FilterErrorEstimator

    s = reference_scenario()
    truth = s.coefficient_vector
    noise = make_noise("gaussian")
    names = list(NAMES)
    models = [("right model", None), *((f"{name} held {factor:g}x", (name, factor))
                                       for name, factor in WRONG_HOLDS)]
    records: dict[tuple[float, str], list[dict]] = {}
    for seed in range(1, seeds + 1):
        for sd in sds:
            wind = Wind(turbulence_sd_mps=sd) if sd > 0 else None
            flight = simulate(s.airframe, truth, dataclasses.replace(s.manoeuvre, wind=wind),
                              noise, rng=seed)
            for label, held in models:
                holds = None if held is None else {
                    "hold": {held[0]: held[1] * float(truth[names.index(held[0])])}}
                r = FilterErrorEstimator().fit(flight, rng=seed, holds=holds)
                fig = r.info.get("gust_verdict", {})
                by = ("passed" if r.success else "gust verdict" if "gust carries" in r.message
                      else "not converged" if "converged" in r.message else "fit check")
                records.setdefault((sd, label), []).append(
                    {"by": by, "axial": fig.get("axial_z", np.nan),
                     "roll": fig.get("roll_ratio", np.nan),
                     "slope": fig.get("incidence_slope", np.nan),
                     "sigma": r.info.get("gust_sd_mps", np.nan)})
                print(f"sd {sd:g} seed {seed} {label}: {by} axial {fig.get('axial_z', np.nan):.2f}"
                      f" roll {fig.get('roll_ratio', np.nan):.2f} slope "
                      f"{fig.get('incidence_slope', np.nan):.3f} gust sd "
                      f"{r.info.get('gust_sd_mps', np.nan):.2f} {r.message[:110]}", flush=True)
    out = ["| Dryden sd [m/s] | model | refused | by the fit check | by the gust verdict | "
           "axial z (min-max) | roll ratio (min-max) | incidence slope (min-max) | "
           "gust sd [m/s] (min-max) |", "|---|---|---|---|---|---|---|---|---|"]
    for (sd, label), recs in records.items():
        n = len(recs)
        count = {k: sum(r["by"] == k for r in recs) for k in ("fit check", "gust verdict")}
        refused = sum(r["by"] != "passed" for r in recs)

        def span(key: str, recs: list[dict] = recs) -> str:
            v = np.array([r[key] for r in recs])
            return f"{np.nanmin(v):.2f}-{np.nanmax(v):.2f}"

        out.append(f"| {sd:g} | {label} | {refused}/{n} | {count['fit check']} | "
                   f"{count['gust verdict']} | {span('axial')} | {span('roll')} | "
                   f"{span('slope')} | {span('sigma')} |")
    return out


def checks(sd: float) -> list[str]:
    """Single-flight checks the README and the options cite: a steady wind in turbulence,
    the paper's noise, one RK4 substep against two (the reference flight, seeds 1-2)."""
    from baselines.filter_error import FilterErrorEstimator

    s = reference_scenario()
    truth = s.coefficient_vector
    out = ["| flight | fit | success | max abs err/se | gust sd [m/s] | note |",
           "|---|---|---|---|---|---|"]

    def row(label: str, fit: str, r, note: str = "") -> None:
        out.append(f"| {label} | {fit} | {r.success} | "
                   f"{np.max(np.abs(r.theta - truth) / r.stderr):.2f} | "
                   f"{r.info.get('gust_sd_mps', float('nan')):.3g} | {note or r.message[:90]} |")
        print(out[-1], flush=True)

    windy = Wind(steady_ned_mps=(3.0, 4.0, 0.0), turbulence_sd_mps=sd)
    for seed in (1, 2):
        flight = simulate(s.airframe, truth, dataclasses.replace(s.manoeuvre, wind=windy),
                          make_noise("gaussian"), rng=seed)
        row(f"steady (3, 4, 0) m/s + Dryden sd {sd:g}, seed {seed}", "filter-error",
            FilterErrorEstimator().fit(flight, rng=seed))
    paper = simulate(s.airframe, truth, s.manoeuvre, make_noise("paper"), rng=1)
    row("still air, paper noise, seed 1", "filter-error", FilterErrorEstimator().fit(paper, rng=1))
    row("still air, paper noise, seed 1", "output-error",
        make_estimator("output-error").fit(paper, rng=1))
    for kind, wind in (("still", None), (f"Dryden sd {sd:g}", Wind(turbulence_sd_mps=sd))):
        flight = simulate(s.airframe, truth, dataclasses.replace(s.manoeuvre, wind=wind),
                          make_noise("gaussian"), rng=1)
        one, two = (FilterErrorEstimator(substeps=k).fit(flight, rng=1) for k in (1, 2))
        moved = np.max(np.abs(one.theta - two.theta) / two.stderr)
        row(f"{kind}, seed 1", "substeps 1", one, f"against substeps 2: max |change| / se "
            f"{moved:.2g}")
    return out


def table(rows: dict) -> list[str]:
    """The markdown table of :func:`run`'s records."""
    out = ["| flight | method | fit check passed | all within 3 se | coverage 95 % | "
           "mean abs rel error [%] | median max err/se | mean time [s] | gust sd [m/s] | "
           "max abs FE-OE / se |", "|" + "---|" * 10]
    for (kind, name), recs in rows.items():
        err = np.array([r["err_se"] for r in recs])
        n = len(recs)
        agree = [r["agree"] for r in recs if "agree" in r]
        shown = f"{max(agree):.3f}" if agree else "-"
        out.append(
            f"| {kind} | {name} | {sum(r['success'] for r in recs)}/{n} | "
            f"{int(np.sum(np.all(err <= WITHIN_SE, axis=1)))}/{n} | "
            f"{np.mean(err <= Z95):.3f} | {np.mean([r['rel'] for r in recs]):.3f} | "
            f"{np.median(np.max(err, axis=1)):.2f} | {np.mean([r['time'] for r in recs]):.2f} | "
            f"{np.nanmean([r['sigma'] for r in recs]):.3g} | {shown} |")
    return out


def main() -> None:
    """Run, print, and write ``results/filter_error.md`` unless ``--no-write``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--still-seeds", type=int, default=6)
    parser.add_argument("--sd", type=float, default=3.0)
    parser.add_argument("--jobs", type=int, default=1, choices=[1],
                        help="one process (the fits in turn); timing needs it")
    parser.add_argument("--timing", type=int, default=0,
                        help="instead: time both methods this many times on the reference "
                             "flight (results/filter_error_cost.md)")
    parser.add_argument("--wrong-seeds", type=int, default=0,
                        help="instead: the verdict on known-wrong models, this many seeds "
                             "(results/filter_error_wrong.md)")
    parser.add_argument("--wrong-sd", type=float, nargs="+", default=[0.0, 1.0, 3.0],
                        help="with --wrong-seeds: the Dryden intensities [m/s] (0: still "
                             "air; default 0 1 3)")
    parser.add_argument("--checks", action="store_true",
                        help="instead: the single-flight checks (results/filter_error_checks.md)")
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    if args.checks:
        out = checks(args.sd)
        if not args.no_write:
            RESULTS_CHECKS.write_text(
                f"# filter-error: single-flight checks\n\n{dt.date.today()}, "
                "`python benchmarks/bench_filter_error.py --checks`\n\n" + "\n".join(out) + "\n")
            print(f"wrote {RESULTS_CHECKS}")
        return
    if args.wrong_seeds:
        sds = tuple(args.wrong_sd)
        out = wrong(args.wrong_seeds, sds)
        print("\n".join(out))
        if not args.no_write:
            command = (f"python benchmarks/bench_filter_error.py --wrong-seeds {args.wrong_seeds}"
                       f" --wrong-sd {' '.join(f'{v:g}' for v in sds)}")
            RESULTS_WRONG.write_text(f"# filter-error's verdict on known-wrong models\n\n"
                                     f"{dt.date.today()}, `{command}`\n\n" + "\n".join(out)
                                     + "\n")
            print(f"wrote {RESULTS_WRONG}")
        return
    if args.timing:
        out = cost(args.timing, args.sd)
        print("\n".join(out))
        if not args.no_write:
            command = f"python benchmarks/bench_filter_error.py --timing {args.timing}"
            RESULTS_COST.write_text(f"# filter-error's cost against output-error's\n\n"
                                    f"{dt.date.today()}, `{command}`\n\n" + "\n".join(out)
                                    + "\n")
            print(f"wrote {RESULTS_COST}")
        return
    rows, lines = run(args.seeds, args.still_seeds, args.sd)
    out = table(rows)
    print("\n".join(out))
    if not args.no_write:
        results = RESULTS if args.sd == 3.0 else RESULTS.with_name(f"filter_error_sd{args.sd:g}.md")
        RESULTS.parent.mkdir(exist_ok=True)
        command = (f"python benchmarks/bench_filter_error.py --seeds {args.seeds} "
                   f"--still-seeds {args.still_seeds} --sd {args.sd:g}")
        results.write_text(
            f"# filter-error against output-error (issue 26)\n\n{dt.date.today()}, "
            f"`{command}`\n\n" + "\n".join(out) + "\n\nPer run:\n\n```\n" + "\n".join(lines)
            + "\n```\n")
        print(f"wrote {results}")


if __name__ == "__main__":
    main()
