"""The fit check's false-alarm and detection rates (issue 18), measured on seeded fits.

Run by hand from the repository root (``--jobs`` is not offered: one process)::

    python benchmarks/fitcheck_rates.py correct --runs 10 --out /tmp/correct.jsonl
    python benchmarks/fitcheck_rates.py wrong --runs 10 --out /tmp/wrong.jsonl
    python benchmarks/fitcheck_rates.py summary /tmp/correct.jsonl /tmp/wrong.jsonl

``correct``: every shipped study (``studies/*.toml``), every noise condition, every
estimator whose input is right for its scenario (the reference scenario's relay is
latched at the log clock: its default ``hold``; the continuous and delayed relays:
``law`` and ``events``, output-error's ``law + delay``, equation-error's per-sample
deflection), runs ``0 .. runs-1`` exactly as the study runs them (same flight, prior and
seed: ``aeroid.study._fits``). Methods in ``--skip`` (default the PSO methods at the
studies' budgets: minutes per fit on this machine) are left out.

``wrong``: fits a verdict must refuse, each on flight seeds ``0 .. runs-1``:

- ``midpoint``: output-error ``input = midpoint`` on the continuous relay, paper noise;
- ``hold``: output-error, EKF and UKF with ``input = "hold"`` on the continuous and
  delayed relays (tactical IMU and paper noise);
- ``poorer optimum``: output-error on ``paper_table5_prior``'s runs (paper noise, prior
  10-25 % off), and the same with ``tol`` 30, 10, 3 (stops early, says "converged"); a fit
  counts as a poorer optimum when its cost exceeds the cost of the same fit started at
  the truth by more than :data:`COST_GAP` (``--poorer-runs``, default 60).

Each line of the output is one fit: where, what, ``success``, the verdict (``ok``,
``size``, ``whiteness``, ``identifiability`` or the method's own failure), the smallest
whiteness p-value and the limit, the mean |error| % and the wall time.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import aeroid  # noqa: E402
from aeroid.study import load_study  # noqa: E402
from aeroid.study._fits import estimator_seed, run_prior, simulate_run  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
#: A fit whose likelihood cost exceeds the same fit's from the truth by more than this
#: stopped in a poorer optimum (the issue's: -1408 and +3275 against about -11 000).
COST_GAP = 50.0
CHECKS = ("size", "noise model", "whiteness", "identifiability")
SKIP = ("eam-pso", "ebm-pso", "sebm-pso", "pyswarms")


def verdict(result: aeroid.EstimationResult) -> str:
    """Return which check decided the result."""
    if result.success:
        return "ok"
    message = result.message
    if message.startswith("the model does not fit"):
        return "size"
    if message.startswith("the model leaves structure"):
        return "whiteness"
    if message.startswith("no information"):
        return "identifiability"
    if message.startswith("the method's noise model"):
        return "noise model"
    return "method"


def record(result: aeroid.EstimationResult, truth: np.ndarray, **where) -> dict:
    """Return one JSON line of a fit."""
    check = result.info.get("fit_check", {})
    ps = [p for tests in check.get("whiteness", {}).values() for p in tests.values()]
    err = result.relative_error_pct(truth)
    return {**where, "success": bool(result.success), "verdict": verdict(result),
            "message": result.message[:160], "min_p": min(ps) if ps else None,
            "n_tests": len(ps), "white_limit": check.get("white_limit"),
            "ratio": max(check.get("ratio", {}).values(), default=None),
            "standardized": max(check.get("standardized", {}).values(), default=None),
            "mean_error_pct": float(np.mean(err)) if np.all(np.isfinite(err)) else None,
            "cost": float(result.cost), "warnings": list(result.warnings),
            "wall_time_s": result.wall_time_s}


def right_input(scenario_path: str, options: dict) -> bool:
    """Is the estimator's deflection input right for the scenario's relay?"""
    inp = options.get("input")
    if "continuous_relay" in scenario_path or "delayed_relay" in scenario_path:
        if inp is None:  # equation-error: each sample's own deflection
            return True
        if options.get("estimate_delay"):
            return inp == "law"
        return inp in ("law", "events")
    return inp in (None, "hold")


def correct(args: argparse.Namespace, out) -> None:
    for path in sorted((ROOT / "studies").glob("*.toml")):
        if args.studies and path.stem not in args.studies:
            continue
        study = load_study(path)
        text = path.read_text()
        scen = next((line for line in text.splitlines() if line.startswith("scenario")), "")
        for k_est, spec in enumerate(study.estimators):
            opts = spec.estimator.options()
            if (spec.method in args.skip or not right_input(scen, opts)
                    or (args.only and spec.method not in args.only)):
                continue
            for k_noise, noise in enumerate(study.noise):
                for run in range(min(args.runs, study.runs)):
                    flight = simulate_run(study, run, k_noise)
                    prior = run_prior(study, run)
                    if prior is not None:
                        flight = dataclasses.replace(flight, airframe=flight.airframe.replace(
                            prior=tuple(float(v) for v in prior)))
                    result = spec.estimator.fit(flight, rng=np.random.default_rng(
                        estimator_seed(study.seed, run)))
                    line = record(result, flight.true_coefficients, study=study.name,
                                  noise=noise.label, estimator=spec.label, run=run, k=k_est)
                    print(json.dumps(line), file=out, flush=True)
                    print(study.name, noise.label, spec.label, run, line["verdict"],
                          line["min_p"], file=sys.stderr, flush=True)


def wrong(args: argparse.Namespace, out) -> None:
    cases = []
    for scen in ("continuous_relay", "delayed_relay"):
        for noise in ("gaussian", "paper"):
            for method in ("output-error", "ekf", "ukf"):
                if method in args.skip:
                    continue
                cases.append((f"hold {method}", scen, noise, method, {"input": "hold"}))
    cases.insert(0, ("midpoint output-error", "continuous_relay", "paper", "output-error",
                     {"input": "midpoint"}))
    for label, scen, noise, method, opts in cases:
        scenario = aeroid.load_scenario(ROOT / "studies" / "scenarios" / f"{scen}.toml")
        est = aeroid.make_estimator(method, opts)
        for seed in range(args.runs):
            flight = aeroid.simulate_scenario(scenario, aeroid.make_noise(noise), rng=seed)
            result = est.fit(flight, rng=seed)
            line = record(result, flight.true_coefficients, case=label, scenario=scen,
                          noise=noise, seed=seed)
            print(json.dumps(line), file=out, flush=True)
            print(label, scen, noise, seed, line["verdict"], line["min_p"],
                  line["mean_error_pct"], file=sys.stderr, flush=True)
    poorer_optima(args, out)


def poorer_optima(args: argparse.Namespace, out) -> None:
    """Output-error on the paper condition from the priors of ``paper_table5_prior``
    (10-25 % off), as the study runs it, and from the same start with each ``tol`` of
    ``--tol`` (it stops as soon as no step exceeds that many standard errors: a start
    that ends elsewhere and says "converged"); each against the fit started at the
    truth."""
    study = load_study(ROOT / "studies" / "paper_table5_prior.toml")
    truth = np.asarray(study.scenario.coefficient_vector, dtype=float)
    cases = [("poorer optimum", aeroid.make_estimator("output-error"))]
    cases += [(f"stopped early (tol {tol:g})", aeroid.make_estimator("output-error", {"tol": tol}))
              for tol in args.tol]
    for run in range(args.poorer_runs):
        flight = simulate_run(study, run, 0)
        rng = estimator_seed(study.seed, run)
        at_truth = dataclasses.replace(flight, airframe=flight.airframe.replace(
            prior=tuple(truth)))
        best = aeroid.make_estimator("output-error").fit(at_truth, rng=np.random.default_rng(rng))
        start = dataclasses.replace(flight, airframe=flight.airframe.replace(
            prior=tuple(float(v) for v in run_prior(study, run))))
        for label, est in cases:
            result = est.fit(start, rng=np.random.default_rng(rng))
            gap = float(result.cost - best.cost)
            line = record(result, truth, case=label, scenario="reference", noise="paper",
                          seed=run, cost_gap=gap,
                          poorer=bool(np.isfinite(gap) and gap > COST_GAP))
            print(json.dumps(line), file=out, flush=True)
            print(label, run, line["verdict"], gap, line["mean_error_pct"], file=sys.stderr,
                  flush=True)


def summary(paths: list[str]) -> None:
    lines = [json.loads(x) for p in paths for x in Path(p).read_text().splitlines() if x]
    good = [x for x in lines if "study" in x]
    if good:
        tested = [x for x in good if x["n_tests"]]
        alarms = [x for x in good if x["verdict"] in CHECKS]
        print(f"correct-input fits: {len(good)} ({len(tested)} with whiteness tests); "
              f"refused by the fit check: {len(alarms)} ({100 * len(alarms) / len(good):.2f} %)")
        for v in (*CHECKS, "method"):
            n = sum(x["verdict"] == v for x in good)
            print(f"  {v}: {n}")
        for x in alarms:
            print("   ", x["study"], x["noise"], x["estimator"], x["run"], x["message"][:100])
        ps = np.array([x["min_p"] * x["n_tests"] for x in tested])
        for alpha in (1e-1, 1e-2, 1e-3, 1e-4):
            print(f"  whiteness alarms at family alpha {alpha:g} (Bonferroni): "
                  f"{np.sum(ps < alpha)} of {ps.size} ({100 * np.mean(ps < alpha):.2f} %)")
    bad = [x for x in lines if "case" in x]
    for case in sorted({x["case"] + " | " + x["scenario"] + " | " + x["noise"] for x in bad}):
        rows = [x for x in bad if x["case"] + " | " + x["scenario"] + " | " + x["noise"] == case]
        if "poorer" in rows[0]:
            poor = [x for x in rows if x["poorer"]]
            flagged = sum(not x["success"] for x in poor)
            others = sum(not x["success"] for x in rows if not x["poorer"])
            print(f"{case}: {len(poor)} of {len(rows)} fits in a poorer optimum, "
                  f"{flagged} refused; of the others {others} refused")
            for x in poor:
                print(f"    seed {x['seed']} gap {x['cost_gap']:.0f} err "
                      f"{x['mean_error_pct']} {x['verdict']}")
            continue
        refused = sum(not x["success"] for x in rows)
        errs = [x["mean_error_pct"] for x in rows if x["mean_error_pct"] is not None]
        print(f"{case}: {refused} of {len(rows)} refused "
              f"({', '.join(sorted({x['verdict'] for x in rows}))}); mean error "
              f"{np.median(errs):.2f} % median, {np.min(errs):.2f}-{np.max(errs):.2f} %")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("part", choices=("correct", "wrong", "poorer", "summary"))
    parser.add_argument("paths", nargs="*", help="summary: the JSON-lines files")
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--poorer-runs", type=int, default=60,
                        help="runs of paper_table5_prior for the poorer optima")
    parser.add_argument("--tol", type=float, nargs="*", default=[30.0, 10.0, 3.0],
                        help="poorer: output-error's tol of the early stops")
    parser.add_argument("--skip", nargs="*", default=list(SKIP))
    parser.add_argument("--only", nargs="*", default=[], help="correct: only these methods")
    parser.add_argument("--studies", nargs="*", default=[], help="correct: only these studies")
    parser.add_argument("--out", default="-")
    args = parser.parse_args()
    if args.part == "summary":
        summary(args.paths)
        return
    start = time.perf_counter()
    with (sys.stdout if args.out == "-" else open(args.out, "a")) as out:
        {"correct": correct, "wrong": wrong, "poorer": poorer_optima}[args.part](args, out)
    print(f"done in {time.perf_counter() - start:.0f} s", file=sys.stderr)


if __name__ == "__main__":
    main()
