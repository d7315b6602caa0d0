"""How much the raw-IMU output-error fit of the rocket coast moves when the reconstruction's
attitude is off by its own stated sd (issue 25: why the standard errors of
studies/rocket_pitch_plane.toml's fits are too small).

Output-error takes the attitude as measured (baselines/output_error.py); the
reconstruction states its sd (``flight.metadata["initial_state_sd"]``). This re-fits one
run of the study with ``theta`` (then ``phi``) shifted by that sd over the whole flight
and prints the estimates beside the unshifted fit's.

    python benchmarks/rocket_attitude_shift.py RUN
"""

import dataclasses
import sys

import numpy as np

from aeroid.study import load_study
from aeroid.study._fits import estimator_seed, simulate_run

study = load_study("studies/rocket_pitch_plane.toml")
run = int(sys.argv[1])
flight = simulate_run(study, run, 0)
sd = flight.metadata.get("initial_state_sd")
print("initial_state_sd", sd)
est = study.estimators[0].estimator


def fit(f):
    r = est.fit(f, rng=np.random.default_rng(estimator_seed(study.seed, run)))
    d = dict(zip(r.names, zip(r.theta, r.stderr, strict=True), strict=True))
    return r.success, {k: d[k] for k in ("Cx", "Cl0", "Clp", "Cza")}


print("base", fit(flight))
for ch in ("theta", "phi"):
    s = sd[ch]  # the reconstruction's own sd of this angle [rad]
    data = flight.data.copy()
    data[ch] = data[ch] + s
    print(ch, "+", s, fit(dataclasses.replace(flight, data=data)))
