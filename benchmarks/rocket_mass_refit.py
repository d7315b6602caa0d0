"""Re-fit one run of studies/rocket_measure.toml with the file's mass, or with the true one.

Issue 25: the measure study's failures (max_iterations) come from the 2 % mass error.
This fits run RUN's flight (the study's own, :func:`aeroid.study._fits.simulate_run`) with
Cx constant and without the mass sd (the cheapest fit that shows it), once with the file's
10 kg and, with ``--true-mass``, with the airframe's mass set to the flown one (the run's
draw of the study's ``[perturb]``; before it, the scenario's fixed 10.2 kg).

    python benchmarks/rocket_mass_refit.py RUN [--true-mass] [--staged]
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from aeroid.study import load_study
from aeroid.study._fits import estimator_seed, simulate_run
from aeroid.study._perturb import run_mass_scale

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("run", type=int)
parser.add_argument("--true-mass", action="store_true")
parser.add_argument("--staged", action="store_true",
                    help="output-error's staged_start (Cx first, then all)")
args = parser.parse_args()
study = load_study("studies/rocket_measure.toml")
flight = simulate_run(study, args.run, 0)
airframe = flight.airframe.replace(tables=None, mass_sd_kg=0.0)
if args.true_mass:
    drawn = run_mass_scale(study, args.run)  # the run's own draw ([perturb]), else fixed
    scale = study.scenario.manoeuvre.mass_scale if drawn is None else drawn
    airframe = airframe.replace(mass_kg=airframe.mass_kg * scale)
flight = dataclasses.replace(flight, airframe=airframe)
start = time.perf_counter()
estimator = study.estimators[0].estimator
if args.staged:
    estimator = dataclasses.replace(estimator, staged_start=True)
result = estimator.fit(
    flight, rng=np.random.default_rng(estimator_seed(study.seed, args.run)))
print(f"run {args.run}, mass {airframe.mass_kg:g} kg: success {result.success} "
      f"({result.message}), {time.perf_counter() - start:.1f} s")
for name, value, se in zip(result.names, result.theta, result.stderr, strict=True):
    print(f"  {name:6s} {value:12.5g} {se:10.3g}")
info = result.info
for key in ("start_labels", "start_converged", "start_costs", "start_distance_sd",
            "failed_starts", "iterations"):
    print(f"  {key}: {info.get(key)}")
for line in result.warnings:
    print(f"  warning: {line}")
