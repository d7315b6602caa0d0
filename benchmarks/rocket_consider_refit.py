"""Re-fit one run of studies/rocket_measure.toml and show its consider share in full.

Issue 25: the measure study's standard errors carry the coast mass's 3 % sd through two
consider re-fits at +-1 sd (:mod:`aeroid.estimation._consider`). This fits run RUN's
flight (the study's own, with the run's drawn mass) with the study's estimator and prints,
per parameter, the estimate, the truth, the method's own se, the mass share's se, the total
and |error|/se, then the re-fits' messages and the fitted initial-attitude offset.

With ``--cold`` it also makes the re-fits from the airframe's prior (``warm_start=False``,
the default before 2026-11-26 12:00) and prints both: their time, messages and shares.

    python benchmarks/rocket_consider_refit.py RUN [--cold]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from aeroid.estimation import consider_covariance
from aeroid.study import load_study
from aeroid.study._fits import estimator_seed, simulate_run
from aeroid.study._perturb import run_mass_scale
from aeroid.study._tables import parameter_truth

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("run", type=int)
parser.add_argument("--study", default="studies/rocket_measure.toml")
parser.add_argument("--cold", action="store_true", help="also the re-fits from the prior")
args = parser.parse_args()
study = load_study(args.study)
flight = simulate_run(study, args.run, 0)
start = time.perf_counter()
result = study.estimators[0].estimator.fit(
    flight, rng=np.random.default_rng(estimator_seed(study.seed, args.run)))
print(f"run {args.run}: flown mass scale {run_mass_scale(study, args.run)}, success "
      f"{result.success} ({result.message}), {time.perf_counter() - start:.1f} s")
consider = result.consider
truth = parameter_truth(study.scenario, result.names)
own = consider.stderr_without if consider is not None else result.stderr
share = consider.stderr_share if consider is not None else np.zeros_like(result.stderr)
print(f"  {'name':10s} {'estimate':>12s} {'truth':>10s} {'own se':>10s} {'mass se':>10s} "
      f"{'total se':>10s} {'|err|/se':>8s}")
for k, name in enumerate(result.names):
    se = result.stderr[k]
    z = abs(result.theta[k] - truth[k]) / se if se > 0 else float("nan")
    print(f"  {name:10s} {result.theta[k]:12.6g} {truth[k]:10.4g} {own[k]:10.3g} "
          f"{share[k]:10.3g} {se:10.3g} {z:8.2f}")
if consider is not None:
    print(" ", consider.describe())
    for line in consider.refit_messages:
        print("  re-fit:", line[:300])
print("  attitude offset [rad]:", result.info.get("attitude_offset_rad"), "+-",
      result.info.get("attitude_offset_stderr_rad"))
if args.cold and consider is not None:
    import dataclasses

    plain = dataclasses.replace(result, stderr=consider.stderr_without,
                                covariance=consider.covariance_without)
    for warm in (True, False):
        again = consider_covariance(study.estimators[0].estimator, flight, plain,
                                    rng=estimator_seed(study.seed, args.run),
                                    warm_start=None if warm else False)
        print(f"  from {again.started}: {again.wall_time_s:.1f} s, "
              f"{len(again.refit_messages)} re-fit(s) unsuccessful; share se "
              + " ".join(f"{n}={v:.3g}" for n, v in zip(result.names, again.stderr_share,
                                                          strict=True)))
        for line in again.refit_messages:
            print("    re-fit:", line[:200])
