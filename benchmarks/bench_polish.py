"""Do the PSO estimators reach their own optimum? J_pso / J_opt with and without polish.

Run by hand from the repository root::

    python benchmarks/bench_polish.py              # writes benchmarks/results/polish.md
    python benchmarks/bench_polish.py --quick      # fewer seeds, prints only

For every PSO estimator, on seeded flights of the reference scenario (flight seed = PSO
seed = 1..N), the final cost of the estimator's own objective ``J_pso`` is divided by
that objective's optimum ``J_opt`` over the same search box (the airframe's prior x
[0.5, 1.5]), with and without the ``polish`` option:

* EBM-PSO, SEBM-PSO, pyswarms on the EBM objective (quadratic costs): ``J_opt`` is the
  bounded least-squares minimum computed independently of the polish, by
  ``scipy.optimize.lsq_linear`` (BVLS) on the weighted residual rows ``sqrt(w) (y -
  X theta)`` of the cost's own X, y, weights (the polish works on the quadratic form).
  SEBM: the sum over its four problems.
* EAM-PSO and pyswarms on the EAM objective (output error), at a reduced budget (stated
  in the table): two objectives. With the initial rates held at the cost's smoothed
  values (the swarm's objective; ``polish_initial_rates=False``) and with the initial p,
  q, r fitted too (the default polish). ``J_opt`` is the lower of two converged solves:
  ``scipy.optimize.least_squares`` with MINPACK's Levenberg-Marquardt (unbounded,
  serial 2-point Jacobian: a code path independent of the polish) from the truth, and
  the polish's own solver from the polished answer; when the LM optimum leaves the box
  the bounded one is taken (counted in the table). The unpolished numbers are the
  swarm's point recorded by the polished fit (``info["polish"]``: the swarm is the same
  run, the polish draws no random numbers).

Conditions: the paper's noise (eq. 43 with its 10 % sensor-position error), the
Gaussian tactical IMU, noise-free; "prior off the truth": the airframe's prior is the
truth times ``1 + s U(0.10, 0.25)``, s a random sign per coefficient drawn from the seed
(issue 11's study set-up), so the box is centred off the truth. Last, EAM-PSO at the
paper's budget (450 x 200) on the noise-free flight, default polish only.

Also the mean |error| in % of the truth over the nine coefficients, the mean over runs of
the largest one, and the wall time per fit (indicative: the machine is shared).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # see bench_baselines.py
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import datetime as dt  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy.optimize  # noqa: E402

from aeroid.estimation import (  # noqa: E402
    OutputErrorCost,
    ebm_cost,
    make_estimator,
    polish,
    prior_bounds,
    reconstruct,
    sebm_costs,
)
from aeroid.flights._noise import GaussianNoise, NoNoise, PaperNoise  # noqa: E402
from aeroid.flights._scenario import reference_scenario  # noqa: E402
from aeroid.flights._simulate import simulate_scenario  # noqa: E402
from aeroid.model._dynamics import P, Q, R  # noqa: E402
from baselines.pyswarms_gbest import PyswarmsEstimator  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "polish.md"
#: issue 11's target: J_pso <= (1 + RATIO_TOL) J_opt in >= 95 % of runs.
RATIO_TOL = 1e-3
NOISES = {"paper": PaperNoise(), "gaussian": GaussianNoise(), "none": NoNoise()}
#: Range of the prior's offset from the truth with ``prior_off`` (issue 11, item 1).
PRIOR_OFFSET = (0.10, 0.25)


def flight_for(noise_name: str, seed: int, prior_off: bool):
    """The seeded flight; with ``prior_off`` its airframe's prior is the truth times
    ``1 + s U(0.10, 0.25)`` per coefficient, s a random sign (issue 11's study set-up),
    drawn from the seed: the box is centred on the prior, not on the truth."""
    flight = simulate_scenario(reference_scenario(), NOISES[noise_name], rng=seed)
    if not prior_off:
        return flight
    rng = np.random.default_rng([seed, 11])
    factor = 1.0 + rng.choice([-1.0, 1.0], 9) * rng.uniform(*PRIOR_OFFSET, 9)
    prior = tuple(flight.true_coefficients * factor)
    return dataclasses.replace(flight, airframe=flight.airframe.replace(prior=prior))


def bounded_lsq(cost, bounds: np.ndarray) -> float:
    """Minimum of a QuadraticCost over the box from its X, y, weights (BVLS)."""
    sw = np.sqrt(cost.weights.reshape(-1) / cost.n_samples)
    A = cost.X.reshape(-1, cost.n_params) * sw[:, None]
    b = cost.y.reshape(-1) * sw
    scale = np.abs(bounds).max(axis=1)
    res = scipy.optimize.lsq_linear(A * scale, b, bounds=(bounds[:, 0] / scale,
                                                          bounds[:, 1] / scale),
                                    method="bvls", tol=1e-14)
    return float(cost.direct(res.x * scale))


def eam_optimum(cost: OutputErrorCost, bounds: np.ndarray, truth: np.ndarray,
                polished: np.ndarray, initial_rates: bool) -> tuple[float, bool]:
    """Optimum of the output error (module docstring); True when LM left the box."""
    free = [P, Q, R] if initial_rates else []

    def fun(x: np.ndarray) -> np.ndarray:
        state = cost.state0.copy()
        state[free] = x[9:]
        return cost.residuals(x[:9], state)

    x0 = np.concatenate([truth, cost.state0[free]])
    lm = scipy.optimize.least_squares(fun, x0, method="lm", x_scale=np.abs(x0) + 1e-3,
                                      ftol=1e-12, xtol=1e-12, gtol=1e-12)
    outside = bool(np.any(lm.x[:9] < bounds[:, 0]) or np.any(lm.x[:9] > bounds[:, 1]))
    candidates = [polish(cost, bounds, polished, initial_rates=initial_rates).cost,
                  polish(cost, bounds, truth, initial_rates=initial_rates).cost]
    if not outside:
        candidates.append(2.0 * lm.cost)
    return min(candidates), outside


def summarise(label: str, ratios: list[float], errors: list[np.ndarray],
              times: list[float], note: str = "") -> str:
    r = np.asarray(ratios)
    e = np.asarray(errors)
    if np.all(np.isnan(r)):
        return (f"| {label} | {len(r)} | - | - | - | {e.mean():.3g} | "
                f"{e.max(axis=1).mean():.3g} | {np.median(times):.2f} | {note} |")
    met = np.mean(r <= 1 + RATIO_TOL)
    return (f"| {label} | {len(r)} | {np.median(r):.6g} | {r.max():.4g} | {met:.2f} | "
            f"{e.mean():.3g} | {e.max(axis=1).mean():.3g} | {np.median(times):.2f} | {note} |")


def quadratic_rows(noise_name: str, n_seeds: int, prior_off: bool) -> list[str]:
    acc: dict[str, tuple[list, list, list]] = {}
    for seed in range(1, n_seeds + 1):
        flight = flight_for(noise_name, seed, prior_off)
        truth = flight.true_coefficients
        bounds = prior_bounds(flight.airframe)
        rec = reconstruct(flight)
        j_ebm = bounded_lsq(ebm_cost(flight, rec), bounds)
        j_sebm = sum(bounded_lsq(cost, bounds[list(cols)])
                     for _, cols, cost in sebm_costs(flight, rec))
        for name, make, j_opt in (
                ("ebm-pso", lambda o: make_estimator("ebm-pso", o), j_ebm),
                ("sebm-pso", lambda o: make_estimator("sebm-pso", o), j_sebm),
                ("pyswarms ebm", lambda o: PyswarmsEstimator(**o), j_ebm)):
            for polished in (False, True):
                result = make({"polish": polished}).fit(flight, rng=seed)
                key = f"{name}{', polish' if polished else ''}"
                ratios, errors, times = acc.setdefault(key, ([], [], []))
                ratios.append(result.cost / j_opt)
                errors.append(result.relative_error_pct(truth))
                times.append(result.wall_time_s)
    return [summarise(key, *values, note="450 x 200" if "sebm" not in key
                      else "50/150/100/150 x 200") for key, values in acc.items()]


def eam_rows(noise_name: str, n_seeds: int, budget: dict, pyswarms: bool,
             prior_off: bool = False, held: bool = True) -> list[str]:
    name = "pyswarms eam" if pyswarms else "eam-pso"
    keys = (f"{name} (no polish)", f"{name}, polish, initial rates held",
            f"{name}, polish, initial rates fitted (default)")
    acc: dict[str, tuple[list, list, list]] = {key: ([], [], []) for key in keys}
    outside = [0, 0]
    for seed in range(1, n_seeds + 1):
        flight = flight_for(noise_name, seed, prior_off)
        truth = flight.true_coefficients
        bounds = prior_bounds(flight.airframe)
        cost = OutputErrorCost(flight)
        for k, initial_rates in enumerate((False, True)):
            if not (held or initial_rates):
                continue
            options = dict(budget, polish=True, polish_initial_rates=initial_rates)
            est = (PyswarmsEstimator(objective="eam", **options) if pyswarms
                   else make_estimator("eam-pso", options))
            result = est.fit(flight, rng=seed)
            j_opt, left = eam_optimum(cost, bounds, truth, result.theta, initial_rates)
            outside[k] += left
            rows = [(keys[1 + k], result.cost, result.theta)]
            if not initial_rates:  # the swarm, against the optimum of the objective it searched
                record = result.info["polish"]
                rows.append((keys[0], record["swarm_cost"], record["swarm_theta"]))
            elif not held:  # its error only: its objective's optimum was not computed
                record = result.info["polish"]
                rows.append((keys[0], np.nan, record["swarm_theta"]))
            for key, j, theta in rows:
                ratios, errors, times = acc[key]
                ratios.append(j / j_opt)
                errors.append(np.abs(theta - truth) / np.abs(truth) * 100)
                times.append(result.wall_time_s)
    note = (f"{budget['n_particles']} x {budget['n_iterations']}; unbounded LM optimum "
            f"outside the box: held {outside[0]}, fitted {outside[1]} of {n_seeds}")
    return [summarise(key, *acc[key], note=note) for key in keys if acc[key][0]]


#: (noise, prior off the truth) of the quadratic-cost and the output-error sections.
QUADRATIC_CONDITIONS = (("paper", False), ("gaussian", False), ("none", False), ("paper", True))
EAM_CONDITIONS = (("none", False), ("paper", False), ("gaussian", False), ("gaussian", True))
HEADER = ["| estimator | runs | median J/J_opt | max J/J_opt | share <= 1.001 | "
          "mean abs error % | mean of max error % | median s per fit | budget, notes |",
          "|---|---:|---:|---:|---:|---:|---:|---:|---|"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    n_quad, n_eam = (3, 2) if args.quick else (20, 8)
    eam_budget = {"n_particles": 100, "n_iterations": 50}
    start = time.time()
    load = os.getloadavg()
    out = [
        "# PSO estimators and their optimum: J_pso / J_opt with and without polish", "",
        f"Command: `python benchmarks/bench_polish.py{' --quick' if args.quick else ''}` "
        f"(repository root), started {dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC.",
        f"Machine: {platform.machine()}, {os.cpu_count()} CPU cores, Python "
        f"{platform.python_version()}, numpy {np.__version__}; load average at the start "
        f"{load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} (shared with other agents' tests: "
        "times are indicative).", "",
        "Reference scenario; flight seed = PSO seed = 1..N; box = prior x [0.5, 1.5], "
        "prior = truth (the reference airframe has no [prior] table) or, where marked, "
        "truth x (1 + s U(0.10, 0.25)) with a random sign s per coefficient. J_opt: the "
        "optimum of the same objective over the same box (module docstring of "
        "benchmarks/bench_polish.py). Errors in % of the truth.", "",
    ]
    for noise_name, prior_off in QUADRATIC_CONDITIONS:
        label = noise_name + (", prior off the truth" if prior_off else "")
        out += [f"## Quadratic costs (EBM, SEBM, pyswarms-EBM), {label}, {n_quad} seeds", "",
                *HEADER, *quadratic_rows(noise_name, n_quad, prior_off), ""]
        print("\n".join(out[-5:]), file=sys.stderr)
    for noise_name, prior_off in EAM_CONDITIONS:
        label = noise_name + (", prior off the truth" if prior_off else "")
        out += [f"## Output error (EAM-PSO), {label}, {n_eam} seeds", "", *HEADER,
                *eam_rows(noise_name, n_eam, eam_budget, False, prior_off), ""]
        print("\n".join(out[-5:]), file=sys.stderr)
    out += [f"## Output error, pyswarms (global best), paper noise, {n_eam} seeds", "",
            *HEADER, *eam_rows("paper", n_eam, eam_budget, pyswarms=True), ""]
    if not args.quick:
        out += ["## EAM-PSO at the paper's budget, noise-free, 2 seeds (default polish only)",
                "", *HEADER, *eam_rows("none", 2, {"n_particles": 450, "n_iterations": 200},
                                       False, held=False), ""]
    out.append(f"Total run time {time.time() - start:.0f} s.")
    text = "\n".join(out) + "\n"
    print(text)
    if not args.quick:
        RESULTS.write_text(text)
        print(f"wrote {RESULTS}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
