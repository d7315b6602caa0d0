"""Filter-error's verdicts on pitch-plane errors in turbulence: catch and false-alarm rates.

Run by hand from the repository root (one process, the fits in turn: ``--jobs 1``)::

    python benchmarks/bench_gust_verdict.py --seeds 40        # writes results
    python benchmarks/bench_gust_verdict.py --seeds 20 --priors   # priors instead of holds
    python benchmarks/bench_gust_verdict.py --seeds 10 \
        --scenario studies/scenarios/turbulence_steady.toml  # no gusts: results/..._steady.md
    python benchmarks/bench_gust_verdict.py --seeds 10 --scenario reference  # still air
    python benchmarks/bench_gust_verdict.py --seeds 2 --no-write

Per seed ``k`` (``rng = k``, seeds 1..N): the turbulence study's flight
(``studies/scenarios/turbulence.toml``: the reference flight in a 5 m/s steady wind with
Dryden gusts of sd 3 m/s, L 533.4 m; every seed flies its own gusts) with Gaussian IMU
noise (0.05 m/s^2, 0.005 rad/s), fitted by filter-error with its defaults:

- the right model, all nine free (no hold: nothing for the likelihood-ratio test);
- each of Cma, Cza, Cmq held at its truth (the likelihood-ratio test's null: how often a
  right hold is refused) and at 0.7x and 1.3x its truth (known wrong: how often caught);
- Cx and Clp held at 1.1x (the gust verdict's catches, kept);
- with ``--priors`` instead: a Gaussian prior on each of Cma, Cza, Cmq of sd 10 % of the
  truth, its mean drawn from ``N(truth, sd^2)`` (an honest prior: the test's null) or at
  1.3x the truth (far off); ``results/gust_verdict_priors.md``.

Reported per model: refused, and by which check (the hold test,
:mod:`baselines._fem_holds`; the gust verdict, :mod:`baselines._gust_verdict`; the fit
check or not converged), the likelihood ratio (min / median / max), the fitted gust sd
and the gust verdict's incidence slope (the regression candidate, shown for the choice).
Then the catch rate on the wrong pitch-plane holds and the false-alarm rate on the right
ones with the exact (Clopper-Pearson) one-sided 95 % upper bound, and the null's mean
likelihood ratio per coefficient (chi-square(1): 1).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # shared 2-core machine
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import datetime as dt  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy.stats import beta  # noqa: E402

from aeroid.flights import load_scenario, make_noise, simulate  # noqa: E402
from aeroid.model import NAMES  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "studies" / "scenarios" / "turbulence.toml"
RESULTS = Path(__file__).parent / "results" / "gust_verdict.md"
PITCH = ("Cma", "Cza", "Cmq")
WRONG_FACTORS = (0.7, 1.3)
KEPT = (("Cx", 1.1), ("Clp", 1.1))
#: ``--priors``: each prior's sd, a fraction of the truth (a wind-tunnel value's spread).
PRIOR_SD_REL = 0.10
RESULTS_PRIORS = Path(__file__).parent / "results" / "gust_verdict_priors.md"


def upper_bound(k: int, n: int, level: float = 0.95) -> float:
    """Exact one-sided upper confidence bound of a binomial rate ``k / n``."""
    return 1.0 if k >= n else float(beta.ppf(level, k + 1, n - k))


def _by(r) -> str:
    if r.success:
        return "passed"
    if "data refuse the user's" in r.message:
        return "hold test"
    if "gust carries" in r.message:
        return "gust verdict"
    return "not converged" if "converged" in r.message else "fit check"


#: The fit check's noise-model limit (aeroid.estimation's NOISE_MODEL_LIMIT, not on its
#: public face): a mean squared standardized residual above it refuses.
NOISE_MODEL_LIMIT = 2.0


def _fit_check_refuses(r) -> bool:
    """Whether the fit check alone refuses the fit (another verdict's message may have
    come first): the size, the noise model or whiteness (``info['fit_check']``)."""
    check = r.info.get("fit_check") or {}
    if not check:
        return False
    size = check["ratio"][check["worst"]] > check["limit"]
    noise = any(v > NOISE_MODEL_LIMIT for v in (check.get("standardized") or {}).values())
    return bool(size or noise or check.get("not_white"))


def _models(priors: bool) -> list[tuple[str, str | None, float]]:
    """``(label, coefficient, factor)`` of each fit (module docstring)."""
    if priors:
        return [(f"{name} prior {what}", name, f) for name in PITCH
                for what, f in (("at the truth", 1.0), ("1.3x", 1.3))]
    models: list[tuple[str, str | None, float]] = [("right model, all free", None, 1.0)]
    for name in PITCH:
        models += [(f"{name} held {f:g}x", name, f) for f in (1.0, *WRONG_FACTORS)]
    return models + [(f"{name} held {f:g}x", name, f) for name, f in KEPT]


def _constraint(label: str, name: str | None, factor: float, truth: np.ndarray, seed: int
                ) -> tuple[dict | None, float]:
    """The fit's ``holds`` and the constrained value. A prior "at the truth" has its mean
    drawn from ``N(truth, sd^2)`` (seeded by the seed and the coefficient): the null under
    which the likelihood ratio is chi-square; "1.3x" is centred there; sd
    :data:`PRIOR_SD_REL` of the truth."""
    if name is None:
        return None, np.nan
    value = factor * float(truth[NAMES.index(name)])
    if " prior " not in label:
        return {"hold": {name: value}}, value
    sd = PRIOR_SD_REL * abs(value / factor)
    if factor == 1.0:
        value += sd * float(np.random.default_rng([seed, NAMES.index(name)]).standard_normal())
    return {"prior": {name: [value, sd]}}, value


def run(seeds: int, scenario: Path, priors: bool = False) -> tuple[dict, list[str]]:
    """Fit every model on every flight; return per model the records, and the lines."""
    from baselines.filter_error import FilterErrorEstimator

    s = load_scenario(None if str(scenario) == "reference" else scenario)  # still air
    truth = s.coefficient_vector
    noise = make_noise("gaussian")
    models = _models(priors)
    est = FilterErrorEstimator()
    records: dict[str, list[dict]] = {label: [] for label, _, _ in models}
    lines = []
    for seed in range(1, seeds + 1):
        flight = simulate(s.airframe, truth, s.manoeuvre, noise, rng=seed)
        for label, name, factor in models:
            holds, value = _constraint(label, name, factor, truth, seed)
            r = est.fit(flight, rng=seed, holds=holds)
            test = r.info.get("hold_test", {})
            verdict = r.info.get("gust_verdict", {})
            rec = {"by": _by(r), "lr": test.get("lr", np.nan), "p": test.get("p_value", np.nan),
                   "done": test.get("done", name is None), "sigma": r.info.get("gust_sd_mps",
                                                                              np.nan),
                   "slope": verdict.get("incidence_slope", np.nan),
                   "axial": verdict.get("axial_z", np.nan), "time": r.wall_time_s,
                   "rel_se": np.nan, "wald": np.nan, "fit_check": _fit_check_refuses(r)}
            if name is not None and test.get("done"):  # the data's information on it
                se = test["free_stderr"][name]
                rec["rel_se"] = se / abs(float(truth[NAMES.index(name)]))
                rec["wald"] = abs(test["free_values"][name] - value) / se
            records[label].append(rec)
            lines.append(f"seed {seed} {label}: {rec['by']} (fit check alone: "
                         f"{'refuses' if rec['fit_check'] else 'passes'}) LR {rec['lr']:.2f} "
                         f"p {rec['p']:.3g} "
                         f"free se/|truth| {rec['rel_se']:.3f} |free-held|/se {rec['wald']:.2f} "
                         f"gust sd {rec['sigma']:.2f} slope {rec['slope']:.3f} axial z "
                         f"{rec['axial']:.2f} {r.wall_time_s:.1f} s {r.message[:100]}")
            print(lines[-1], flush=True)
    return records, lines


def _span(recs: list[dict], key: str, fmt: str = ".2f") -> str:
    v = np.array([r[key] for r in recs], dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return "-"
    return f"{np.min(v):{fmt}} / {np.median(v):{fmt}} / {np.max(v):{fmt}}"


def _refused(recs: list[dict]) -> int:
    return sum(r["by"] != "passed" for r in recs)


def _median(recs: list[dict], key: str, fmt: str = ".2f") -> str:
    v = np.array([r[key] for r in recs], dtype=float)
    v = v[np.isfinite(v)]
    return f"{np.median(v):{fmt}}" if v.size else "-"


def table(records: dict) -> list[str]:
    """The per-model table and the summary lines (module docstring)."""
    out = ["| model | refused | by the hold test | by the gust verdict | by the fit check or "
           "not converged | the fit check alone would refuse | test not done | likelihood "
           "ratio (min / median / max) | free se / "
           "abs truth (median) | abs(free - held) / se (median) | gust sd [m/s] (min / median / "
           "max) | incidence slope (min / median / max) |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for label, recs in records.items():
        n = len(recs)
        count = {k: sum(r["by"] == k for r in recs)
                 for k in ("hold test", "gust verdict", "fit check", "not converged")}
        refused = sum(r["by"] != "passed" for r in recs)
        undone = sum(not r["done"] for r in recs)
        out.append(f"| {label} | {refused}/{n} | {count['hold test']} | {count['gust verdict']}"
                   f" | {count['fit check'] + count['not converged']} | "
                   f"{sum(r['fit_check'] for r in recs)} | {undone} | "
                   f"{_span(recs, 'lr')} | {_median(recs, 'rel_se', '.3f')} | "
                   f"{_median(recs, 'wald')} | {_span(recs, 'sigma')} | "
                   f"{_span(recs, 'slope', '.3f')} |")
    if "right model, all free" not in records:  # --priors
        null = [r for name in PITCH for r in records[f"{name} prior at the truth"]]
        far = [r for name in PITCH for r in records[f"{name} prior 1.3x"]]
        alarms = sum(r["by"] != "passed" for r in null)
        caught = sum(r["by"] != "passed" for r in far)
        return out + ["", f"- Priors 1.3x off (sd {PRIOR_SD_REL:.0%} of the truth) refused: "
                      f"{caught}/{len(far)}; per coefficient: " + ", ".join(
                          f"{name} {_refused(records[f'{name} prior 1.3x'])}"
                          f"/{len(records[f'{name} prior 1.3x'])}" for name in PITCH),
                      f"- Honest priors (mean drawn from N(truth, sd^2)) refused: {alarms}/"
                      f"{len(null)} (exact one-sided 95 % upper bound "
                      f"{100 * upper_bound(alarms, len(null)):.1f} %)"]
    wrong = [r for name in PITCH for f in WRONG_FACTORS for r in records[f"{name} held {f:g}x"]]
    null = [r for name in PITCH for r in records[f"{name} held 1x"]]
    caught = sum(r["by"] != "passed" for r in wrong)
    alarms = sum(r["by"] != "passed" for r in null)
    free = records["right model, all free"]
    free_refused = sum(r["by"] != "passed" for r in free)
    out += ["", f"- Wrong pitch-plane holds (Cma, Cza, Cmq at 0.7x and 1.3x) refused: "
            f"{caught}/{len(wrong)} ({100 * caught / len(wrong):.1f} %); per coefficient: "
            + ", ".join(f"{name} {sum(r['by'] != 'passed' for f in WRONG_FACTORS for r in records[f'{name} held {f:g}x'])}/"  # noqa: E501
                        f"{2 * len(records[f'{name} held 1x'])}" for name in PITCH),
            f"- Right holds (each at its truth) refused: {alarms}/{len(null)} "
            f"({100 * alarms / len(null):.1f} %, exact one-sided 95 % upper bound "
            f"{100 * upper_bound(alarms, len(null)):.1f} %)",
            f"- The right model, all free, refused: {free_refused}/{len(free)} (exact one-sided "
            f"95 % upper bound {100 * upper_bound(free_refused, len(free)):.1f} %)",
            "- The null's likelihood ratio (right holds; chi-square(1): mean 1, above "
            "6.63 on 1 %): " + ", ".join(
                f"{name} mean {np.nanmean([r['lr'] for r in records[f'{name} held 1x']]):.2f}, "
                f"above 6.63 {sum(r['lr'] > 6.63 for r in records[f'{name} held 1x'])}/"
                f"{len(records[f'{name} held 1x'])}" for name in PITCH)]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--scenario", type=Path, default=SCENARIO)
    parser.add_argument("--priors", action="store_true",
                        help="priors on Cma, Cza, Cmq instead of holds")
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    if args.seeds < 1:
        parser.error("--seeds must be >= 1")
    records, lines = run(args.seeds, args.scenario, args.priors)
    out = table(records)
    print("\n".join(out))
    if not args.no_write:
        path = RESULTS_PRIORS if args.priors else RESULTS
        if str(args.scenario) == "reference" or args.scenario.resolve() != SCENARIO:
            path = path.with_name(f"{path.stem}_{args.scenario.stem}.md")
        path.parent.mkdir(parents=True, exist_ok=True)
        stamp = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
        path.write_text(
            f"# Filter-error's verdicts on pitch-plane errors in turbulence\n\n{stamp}; "
            f"`python benchmarks/bench_gust_verdict.py --seeds {args.seeds}"
            f"{' --priors' if args.priors else ''}`"
            f"{'' if args.scenario == SCENARIO else f' --scenario {args.scenario}'}; "
            f"the flights: {args.scenario.name}, Gaussian IMU, seeds 1-{args.seeds}.\n\n"
            + "\n".join(out) + "\n\n## Runs\n\n```\n" + "\n".join(lines) + "\n```\n")
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
