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

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # shared 2-core machine
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402

import numpy as np  # noqa: E402

from aeroid import estimation as rc  # noqa: E402
from aeroid.estimation._fitcheck import RATIO_LIMIT  # noqa: E402
from aeroid.flights import (  # noqa: E402
    Wind,
    make_noise,
    record_flight,
    reference_scenario,
    simulate_truth,
)
from baselines._ee_least_squares import _lstsq  # noqa: E402
from baselines._ee_roll import ROLL_ROW, roll_covariance, through_roll_window  # noqa: E402

AIRS = {"still": None,
        "wind + Dryden sd 3": Wind(steady_ned_mps=(3.0, 4.0, 0.0), turbulence_sd_mps=3.0)}
WAYS = ("per sample, Newey-West", "per sample, known structure", "window, Newey-West",
        "window, known structure")


def fits(air: str, seed: int, noise: str = "gaussian") -> dict[str, tuple]:
    """The seed's roll sub-problem three ways: ``(ratio, rel errors %, z)`` each."""
    s = reference_scenario()
    wind = AIRS[air]
    m = s.manoeuvre if wind is None else dataclasses.replace(s.manoeuvre, wind=wind)
    rng = np.random.default_rng(seed)
    truth = simulate_truth(s.airframe, s.coefficient_vector, m, rng=rng)
    f = record_flight(s.airframe, s.coefficient_vector, m, truth, make_noise(noise), rng=rng)
    k0 = int(round(m.window_s[0] / m.dt))
    w = (np.zeros((f.n_samples, 3)) if truth.wind is None
         else np.asarray(truth.wind[k0:], dtype=float))
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
