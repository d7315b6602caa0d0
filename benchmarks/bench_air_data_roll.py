"""Equation-error's roll row in turbulence: the p derivative's window and the roll pair's se.

Run by hand from the repository root (one process)::

    python benchmarks/bench_air_data_roll.py --seeds 30

Per seed ``k`` (``rng = k``: the gusts, then the sensor noise, as
``benchmarks/bench_air_data.py``): the reference flight with the tactical Gaussian IMU in
still air and in the 3/4 wind with Dryden turbulence of sd 3 m/s, the simulator's wind
per sample given to the regressors (the true wind: no probe noise, so what is left is the
roll row's own consistency). The roll sub-problem (Cl0, Clp on the roll moment) four
ways: its regressors per sample or through the p derivative's window, each with the
Newey-West covariance (equation-error before :mod:`baselines._ee_roll`: per sample) and
with the known-structure covariance (:func:`baselines._ee_roll.roll_covariance`;
equation-error now: through the window when its regressors take a wind per sample, the
air data's, else per sample). Reported: the fits whose roll-moment residual is above the
fit check's limit (3x its noise level, the reconstruction's ``fm_sd``), the range of that
ratio, Cl0's and Clp's mean |error|, the coverage of their 95 % intervals and the mean of
z^2 = (error / se)^2 (1 when the se are right).
"""

from __future__ import annotations

from _air_flights import AIRS as ALL_AIRS  # first: one BLAS thread before numpy loads
from _air_flights import windy_flight

# isort: split
import argparse

import numpy as np

from aeroid import estimation as rc
from aeroid.estimation._fitcheck import RATIO_LIMIT
from aeroid.flights import make_noise, reference_scenario
from baselines._ee_least_squares import _lstsq
from baselines._ee_roll import ROLL_ROW, roll_covariance, through_roll_window

AIRS = {air: ALL_AIRS[air] for air in ("still", "wind + Dryden sd 3")}
WAYS = ("per sample, Newey-West", "per sample, known structure", "window, Newey-West",
        "window, known structure")


def fits(air: str, seed: int, noise: str = "gaussian") -> dict[str, tuple]:
    """The seed's roll sub-problem three ways: ``(ratio, rel errors %, z)`` each."""
    s = reference_scenario()
    f, w = windy_flight(AIRS[air], make_noise(noise), seed)
    rec = rc.reconstruct(f)
    X, y = rc.ebm_regression(f, rec, smoothing="none", wind=w)
    cols = list(next(p.coefficients for p in rc.SEBM_PROBLEMS if p.row == ROLL_ROW))
    b = y[:, ROLL_ROW]
    true = s.coefficient_vector[cols]
    out = {}
    for way in WAYS:
        a = (X[:, ROLL_ROW] if way.startswith("per sample")
             else through_roll_window(f, X[:, ROLL_ROW]))[:, cols]
        theta, cov, _, _ = _lstsq(a, b, covariance="hac")
        if way.endswith("known structure"):
            cov = roll_covariance(f, a, b, theta)
        ratio = float(np.sqrt(np.mean((b - a @ theta) ** 2)) / rec.fm_sd[ROLL_ROW])
        out[way] = (ratio, np.abs(theta / true - 1) * 100,
                    (theta - true) / np.sqrt(np.diag(cov)))
    return out


def main() -> None:
    """Fit and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--noise", default="gaussian", help="noise model (make_noise)")
    args = parser.parse_args()
    print(f"noise: {args.noise}\n\n| air | roll row | refused by MX (> 3x noise) | MX / noise "
          "| Cl0, Clp mean abs err [%] | Cl0, Clp coverage | mean z^2 |\n"
          "|---|---|---|---|---|---|---|")
    for air in AIRS:
        rows = {way: [] for way in WAYS}
        for seed in range(1, args.seeds + 1):
            for way, r in fits(air, seed, args.noise).items():
                rows[way].append(r)
        for way, rs in rows.items():
            ratio = np.array([r[0] for r in rs])
            err = np.mean([r[1] for r in rs], axis=0)
            z = np.array([r[2] for r in rs])
            print(f"| {air} | {way} | {int(np.sum(ratio > RATIO_LIMIT))}/{len(rs)} | "
                  f"{ratio.min():.2f}-{ratio.max():.2f} | {err[0]:.3f}, {err[1]:.3f} | "
                  f"{np.mean(np.abs(z[:, 0]) <= 1.96):.2f}, "
                  f"{np.mean(np.abs(z[:, 1]) <= 1.96):.2f} | "
                  f"{np.mean(z[:, 0] ** 2):.2f}, {np.mean(z[:, 1] ** 2):.2f} |", flush=True)


if __name__ == "__main__":
    main()
