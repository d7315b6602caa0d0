"""The Dryden smoother's fitted gust sd and scale length on draws of known gusts.

Run by hand from the repository root (one process)::

    python benchmarks/bench_air_data_dryden.py --records 40

Per record ``k`` (``rng = k``): the simulator's Dryden gusts (:meth:`aeroid.flights.Wind.
gusts`, sd 3 m/s, MIL-F-8785C's 533.4 m, 500 m/s along north, 501 samples at 500 Hz: the
reference record) plus a steady wind of (3, 4, 0) m/s plus white noise of 0.5, 0.87, 0.87
m/s along, across and down (a 0.5 m/s airspeed, 0.1 deg vanes), smoothed by
:func:`aeroid.estimation._air_dryden.fit_dryden`:

* the scale length estimated: how often the likelihood is said to tell a length other
  than the true one (the likelihood-ratio margin
  :data:`aeroid.estimation._air_dryden.LENGTH_LOGLIK_MARGIN`, and the plain chi-square(1)
  95 % point 1.92 for comparison), with the exact Clopper-Pearson 95 % interval;
* the scale length given: the gust sd's z-scores ``(log sd_hat - log 3) / se`` (their
  mean square ~1 when the curvature's se is right) and the smoothed wind's RMS error.
"""

from __future__ import annotations

from _air_flights import WIND  # first: one BLAS thread before numpy loads

# isort: split
import argparse

import numpy as np
from scipy import stats

from aeroid.estimation import _air_dryden as ad
from aeroid.flights import MIL_SCALE_LENGTH_M, Wind

SD, DT, N, SPEED = 3.0, 0.002, 501, 500.0
STEADY = np.array(WIND)
NOISE_SD = np.array([0.5, 0.87, 0.87])


def main() -> None:
    """Draw, fit and print the rates."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=40)
    args = parser.parse_args()
    velocity = np.array([SPEED, 0.0, 0.0]) + STEADY
    r = np.broadcast_to(np.diag(NOISE_SD**2), (N, 3, 3))
    axes = ad.path_axes(velocity - STEADY)
    units = [ad.dryden_system(DT, length, SPEED, axes)
             for length in MIL_SCALE_LENGTH_M * ad.LENGTH_FACTORS]
    mil = int(np.argmin(np.abs(ad.LENGTH_FACTORS - 1.0)))
    gaps, z, wind_rms = [], [], []
    for k in range(args.records):
        rng = np.random.default_rng(k)
        gusts = Wind(turbulence_sd_mps=SD).gusts(N, DT, velocity, rng)
        z_k = STEADY + gusts + rng.standard_normal((N, 3)) * NOISE_SD
        flat, _ = ad._filter(z_k, r, [ad._scaled(u, s) for u in units for s in ad.SD_GRID])
        profile = flat.reshape(len(units), -1).max(axis=1)
        gaps.append(float(profile.max() - profile[mil]))
        told = ad.fit_dryden(z_k, r, DT, velocity - STEADY,
                             scale_length_m=MIL_SCALE_LENGTH_M)
        z.append((np.log(told["gust_sd_mps"]) - np.log(SD)) / told["log_sd_se"])
        wind_rms.append(float(np.sqrt(np.mean((told["wind"] - STEADY - gusts) ** 2))))
    gaps_a = np.array(gaps)
    n = args.records
    for label, margin in (("margin (Bonferroni)", ad.LENGTH_LOGLIK_MARGIN),
                          ("chi-square(1) 95 % / 2", 1.92)):
        k = int(np.sum(gaps_a > margin))
        ci = stats.binomtest(k, n).proportion_ci(method="exact")
        print(f"another length said to be told, {label} {margin:.2f}: {k}/{n} "
              f"(exact 95 % interval {ci.low:.2f}-{ci.high:.2f})")
    z_a = np.array(z)
    print(f"gust sd, length given: mean z {z_a.mean():+.2f}, mean z^2 {np.mean(z_a**2):.2f} "
          f"(chi-square({n}) 95 % band of the mean "
          f"{stats.chi2.ppf(0.025, n) / n:.2f}-{stats.chi2.ppf(0.975, n) / n:.2f}), "
          f"|z| > 1.96 in {int(np.sum(np.abs(z_a) > 1.96))}/{n}")
    print(f"smoothed wind RMS error {np.mean(wind_rms):.3f} m/s (mean over records)")


if __name__ == "__main__":
    main()
