"""Errors in variables with air data: instrumental variables against least squares.

Run by hand from the repository root (one process)::

    python benchmarks/bench_air_data_iv.py --seeds 8            # Dryden sd 3 m/s
    python benchmarks/bench_air_data_iv.py --seeds 8 --sd 1

The vane's noise left in the Kalman-smoothed wind (:func:`aeroid.estimation.
smooth_air_wind`) is an error in equation-error's regressors. Instrumental variables
remove the bias such an error makes (not its variance): the instruments are the same
regressors with the inertial angles (no vane noise in them, correlated with the true
ones through the airframe's motion, ~1.8 deg of alpha against ~0.35 deg of gusts). Per
seed ``k`` (``rng = k``): the reference flight in the 3 / 4 m/s wind with Dryden gusts
of sd ``--sd``, tactical Gaussian IMU, 0.1 deg vanes, an airspeed channel of 0.5 m/s;
each SEBM sub-problem solved by least squares, ``(X^T X)^-1 X^T y``, and by instrumental
variables, ``(Z^T X)^-1 Z^T y`` (no smoothing, the two-step regression of
:func:`aeroid.estimation.regressor_blocks`). Reported: mean |relative error| of the nine
coefficients [%] and of Czq, Cmq.
"""

from __future__ import annotations

from _air_flights import (  # first: one BLAS thread before numpy loads
    AIRSPEED_SD_MPS,
    dryden,
    probe_noise,
    windy_flight,
)

# isort: split
import argparse

import numpy as np

import aeroid
from aeroid import estimation as rc
from aeroid.flights import reference_scenario
from baselines.equation_error import SUBPROBLEMS


def main() -> None:
    """Fit every seed both ways and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--sd", type=float, default=3.0, help="Dryden sd [m/s]")
    args = parser.parse_args()
    truth = reference_scenario().coefficient_vector
    noise = probe_noise(airspeed_sd_mps=AIRSPEED_SD_MPS)
    errors: dict[str, list[np.ndarray]] = {"least squares": [], "instrumental variables": []}
    for seed in range(1, args.seeds + 1):
        f, _ = windy_flight(dryden(args.sd), noise, seed)
        y = rc.regression_target(rc.reconstruct(f), smoothing="none")
        wind = rc.smooth_air_wind(f, rc.air_data_wind(f)).wind
        x = np.concatenate([b[2] for b in rc.regressor_blocks(f, smoothing="none", wind=wind)])
        z = np.concatenate([b[2] for b in rc.regressor_blocks(f, smoothing="none")])
        for label, inst in (("least squares", x), ("instrumental variables", z)):
            theta = np.zeros(truth.size)
            for _, row, cols in SUBPROBLEMS:
                xs, zs = x[:, row, list(cols)], inst[:, row, list(cols)]
                theta[list(cols)] = np.linalg.solve(zs.T @ xs, zs.T @ y[:, row])
            errors[label].append(np.abs(theta / truth - 1) * 100)
    czq, cmq = aeroid.NAMES.index("Czq"), aeroid.NAMES.index("Cmq")
    print(f"Dryden sd {args.sd:g} m/s, {args.seeds} seeds")
    print("| solve | mean abs rel error [%] | Czq [%] | Cmq [%] |\n|---|---|---|---|")
    for label, e in errors.items():
        a = np.array(e)
        print(f"| {label} | {a.mean():.3f} | {a[:, czq].mean():.2f} | {a[:, cmq].mean():.2f} |")


if __name__ == "__main__":
    main()
