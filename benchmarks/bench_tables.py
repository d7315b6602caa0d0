"""The simulator with coefficient tables: the numpy path against per-sample coefficients.

Run by hand from the repository root::

    python benchmarks/bench_tables.py --window 4

The numba kernels take constant coefficients, so a table airframe is either integrated
by numpy with the coefficients at every RK4 stage's Mach (what
:func:`aeroid.flights.simulate_truth` does: the model the output-error graph
integrates), or by the numba kernel one sample interval at a time with the coefficients
of the interval's first state held over it (an approximation: Mach moves within the
interval). This measures both on the first ``--window`` seconds of
``studies/scenarios/mach_sweep.toml``: CPU time, and how far the held coefficients move
the outputs (largest difference over each channel's range) and the table points a
noise-free output-error fit recovers from them.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import aeroid  # noqa: E402
from aeroid.flights import NoNoise, load_scenario, record_flight, simulate_truth  # noqa: E402

SCENARIO = Path(__file__).parents[1] / "studies" / "scenarios" / "mach_sweep.toml"


def held_truth(scenario, manoeuvre) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The truth with each interval's coefficients held at its first state (numba)."""
    airframe, tables = scenario.airframe, scenario.tables
    p = np.array(scenario.coefficients)
    const = aeroid.model.constants(airframe)
    law = manoeuvre.fin_law(airframe.delta_max_rad)
    n = int(round(manoeuvre.window_s[1] / manoeuvre.dt)) + 1
    t = np.arange(n) * manoeuvre.dt
    states, delta = np.empty((n, aeroid.model.N_STATE)), np.empty(n)
    x = np.array(manoeuvre.initial_state)
    for k in range(n):
        states[k] = x
        delta[k] = law(x[aeroid.model.PHI], None)
        if k < n - 1:
            c = tables.coefficient_array(p, x)[None, :]
            x = aeroid.model.propagate(x, c, delta[k:k + 1], manoeuvre.dt, const,
                                       substeps=manoeuvre.truth_substeps,
                                       backend="numba")[0, -1]
    return t, states, delta


def main() -> None:
    """Command line (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--window", type=float, default=4.0, help="seconds of the sweep")
    args = parser.parse_args()
    scenario = load_scenario(SCENARIO)
    manoeuvre = dataclasses.replace(scenario.manoeuvre, window_s=(0.5, 0.5 + args.window))
    p = scenario.coefficient_vector
    held_truth(scenario, dataclasses.replace(manoeuvre, window_s=(0.0, 0.1)))  # compile
    c0 = time.process_time()
    exact = simulate_truth(scenario.airframe, p, manoeuvre, tables=scenario.tables)
    c1 = time.process_time()
    held = held_truth(scenario, manoeuvre)
    c2 = time.process_time()
    flights = [record_flight(scenario.airframe, p, manoeuvre, truth, NoNoise(), rng=0,
                             tables=scenario.tables) for truth in (exact, held)]
    worst = max(float(np.max(np.abs(flights[1][c] - flights[0][c])) / np.ptp(flights[0][c]))
                for c in aeroid.model.OUTPUT_CHANNELS)
    print(f"{args.window:g} s of the sweep, {flights[0].n_samples} samples, "
          f"{manoeuvre.truth_substeps} RK4 steps per sample")
    print(f"numpy, coefficients at every stage: {c1 - c0:.2f} s CPU")
    print(f"numba, coefficients held per sample: {c2 - c1:.2f} s CPU; outputs differ by "
          f"{worst:.2e} of their range")
    truth = dict(zip(scenario.tables.parameter_names(), p, strict=True))
    # the fits' knots: the truth's within the window's Mach range (from 2.19 down)
    mach = scenario.tables.mach(flights[0].states())
    spec = aeroid.model.TableSpec(tuple(
        (name, tuple(k for i, k in enumerate(knots) if knots[min(i + 1, len(knots) - 1)]
                     > mach.min())) for name, knots in scenario.tables.knots))
    for label, flight in (("stage", flights[0]), ("held", flights[1])):
        fl = dataclasses.replace(flight, airframe=flight.airframe.replace(tables=spec))
        result = aeroid.make_estimator("output-error", {"substeps": manoeuvre.truth_substeps}
                                       ).fit(fl, rng=0)
        err = np.abs(result.theta / np.array([truth[n] for n in result.names]) - 1.0)
        j = int(np.argmax(err))
        print(f"output-error on the {label} truth (knots {spec.to_table()}): largest "
              f"relative error {err[j]:.2e} ({result.names[j]}), success {result.success}")


if __name__ == "__main__":
    main()
