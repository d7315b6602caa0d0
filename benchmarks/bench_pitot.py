"""Equation-error with a pitot-static probe's pressures against an airspeed channel (issue 26).

Run by hand from the repository root (one process, the fits in turn)::

    nice -n 10 python benchmarks/bench_pitot.py              # 12 seeds, writes results
    python benchmarks/bench_pitot.py --seeds 2 --no-write
    nice -n 10 python benchmarks/bench_pitot.py --timing-only   # the inversion's cost

Per seed ``k`` (``rng = k``: the gusts, then the sensor noise, as :func:`aeroid.simulate`):
the reference scenario (Mach 1.68 at 10 km) with the tactical Gaussian IMU and 0.1 deg
vanes on alpha and beta, in a steady wind of 5 m/s (north 3, east 4) and in that wind
with Dryden turbulence of sd 1 m/s (scale length 533.4 m). One truth per seed and air,
recorded with the same IMU and vane noise (the probe's readings are drawn last) and:

* ``airspeed 0.5 m/s``: an airspeed channel of sd 0.5 m/s (the air-data benchmarks' probe);
* ``pressures 50 Pa``: a pitot-static probe's total and static pressures, sd 50 Pa each
  (0.56 m/s of airspeed at Mach 1.68, 10 km: :func:`aeroid.flights.pitot_airspeed`);
* ``pressures 200 Pa``: the same probe four times noisier (2.3 m/s of airspeed).

Plus ``still / IMU only``: the still-air yardstick (no probe, angles from u, v, w).
Fits: two-step equation-error with ``air_data = "measured"`` (its default Kalman air
smoother). Reported: successes (the fit check), the mean over seeds of the mean |relative
error| of the nine coefficients [%], its ratio to still air, the coverage of the 95 %
intervals, the median of the largest |error| / se, the RMS of the airspeed's error against
the true air-relative speed, and, paired with the airspeed channel's fit of the same
flight, the median and largest |difference| / se.
"""

from __future__ import annotations

from _air_flights import AIRS as ALL_AIRS  # first: one BLAS thread before numpy loads
from _air_flights import probe_noise, windy_flight

# isort: split
import argparse
import datetime as dt
from pathlib import Path

import numpy as np

import aeroid
from aeroid.flights import make_noise, reference_scenario, with_pitot_airspeed
from baselines.equation_error import EquationErrorEstimator

RESULTS = Path(__file__).parent / "results" / "pitot.md"
AIRS = {air: ALL_AIRS[air] for air in ("wind 5 m/s", "wind + Dryden sd 1")}
PROBES = {"airspeed 0.5 m/s": {"airspeed_sd_mps": 0.5},
          "pressures 50 Pa": {"total_pressure_sd_pa": 50.0, "static_pressure_sd_pa": 50.0},
          "pressures 200 Pa": {"total_pressure_sd_pa": 200.0, "static_pressure_sd_pa": 200.0}}
PAIRED = "airspeed 0.5 m/s"


def _true_airspeed(f: aeroid.flights.Flight, wind_ned: np.ndarray) -> np.ndarray:
    """|u, v, w less the wind in body axes| of the clean states (the model's rotation)."""
    from aeroid.model import equations

    phi, theta, psi = f["phi"], f["theta"], f["psi"]
    body = [equations.ned_to_body(phi, theta, psi, *wind_ned.T)[i] for i in range(3)]
    return np.sqrt(sum((f[c] - b) ** 2 for c, b in zip(("u", "v", "w"), body, strict=True)))


def run(seeds: int) -> tuple[dict, list[str]]:
    """Fit every kind on every seed; return per-kind rows and the log lines."""
    s = reference_scenario()
    truth = s.coefficient_vector
    kinds: dict[str, list] = {}
    lines: list[str] = []
    estimator = EquationErrorEstimator(air_data="measured")
    for seed in range(1, seeds + 1):
        still, _ = windy_flight(None, make_noise("gaussian"), seed)
        r = EquationErrorEstimator(air_data="inertial").fit(still)
        kinds.setdefault("still / IMU only", []).append(
            (r.success, np.abs(r.theta / truth - 1) * 100, np.abs(r.theta - truth) / r.stderr,
             np.nan, None))
        for air, wind in AIRS.items():
            fits = {}
            for label, options in PROBES.items():
                f, true_wind = windy_flight(wind, probe_noise(**options), seed)
                speed = with_pitot_airspeed(f)["airspeed"]
                v_err = float(np.sqrt(np.mean((speed - _true_airspeed(f, true_wind)) ** 2)))
                fits[label] = r = estimator.fit(f, rng=0)
                err = np.abs(r.theta / truth - 1) * 100
                z = np.abs(r.theta - truth) / r.stderr
                kinds.setdefault(f"{air} / {label}", []).append((r.success, err, z, v_err, r))
                lines.append(f"seed {seed} {air} / {label}: success={r.success} mean |err| "
                             f"{err.mean():.3f} % max |err|/se {z.max():.2f} airspeed RMS "
                             f"error {v_err:.3f} m/s {r.message[:80]}")
                print(lines[-1], flush=True)
            ref = fits[PAIRED]
            for label, r in fits.items():
                if label != PAIRED:
                    gap = np.abs(r.theta - ref.theta) / np.minimum(r.stderr, ref.stderr)
                    kinds.setdefault(f"{air} / {label} (paired gap)", []).append(gap)
    return kinds, lines


def table(kinds: dict) -> str:
    """Return the markdown table of the kinds."""
    still = np.mean([row[1].mean() for row in kinds["still / IMU only"]])
    out = ["| air / airspeed from | success | mean abs rel error [%] | x still | coverage | "
           "median max abs err/se | airspeed RMS error [m/s] | paired gap /se: median, max |",
           "|---|---|---|---|---|---|---|---|"]
    for kind, rows in kinds.items():
        if kind.endswith("(paired gap)"):
            continue
        e = np.mean([row[1].mean() for row in rows])
        cover = np.mean(np.concatenate([row[2] <= 1.96 for row in rows]))
        gaps = kinds.get(f"{kind} (paired gap)")
        paired = ("-" if gaps is None else
                  f"{np.median(np.concatenate(gaps)):.2f}, {np.max(np.concatenate(gaps)):.2f}")
        v = np.mean([row[3] for row in rows])
        out.append(f"| {kind} | {sum(row[0] for row in rows)}/{len(rows)} | {e:.3f} | "
                   f"{e / still:.2f} | {cover:.2f} | "
                   f"{np.median([row[2].max() for row in rows]):.2f} | "
                   f"{'-' if np.isnan(v) else f'{v:.3f}'} | {paired} |")
    return "\n".join(out)


def timing(n: int = 100_000, n_brentq: int = 2_000) -> str:
    """Time the supersonic inversion: :func:`aeroid.flights.mach_from_pitot` (scipy's
    vectorised bracketed root finder) on ``n`` ratios of Mach 1.5-1.8 against
    :func:`scipy.optimize.brentq` per sample on ``n_brentq`` of them (per sample, scaled)."""
    import time

    from scipy.optimize import brentq

    from aeroid.flights import mach_from_pitot, pitot_ratio

    ratio = pitot_ratio(np.linspace(1.5, 1.8, n))
    start = time.perf_counter()
    mach_from_pitot(ratio)
    vector = time.perf_counter() - start
    start = time.perf_counter()
    for r in ratio[:: n // n_brentq][:n_brentq]:
        brentq(lambda m, r=r: float(pitot_ratio(m)) - r, 1.0, 20.0, xtol=1e-13)
    per = (time.perf_counter() - start) / n_brentq
    return (f"supersonic inversion of {n} samples: find_root {vector:.2f} s; brentq per "
            f"sample {per * 1e6:.0f} us ({per * n:.1f} s for {n})")


def main() -> None:
    """Run the benchmark and print (and write) the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=12)
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--timing-only", action="store_true",
                        help="time the Mach inversion only (results/pitot_timing.md)")
    args = parser.parse_args()
    if args.timing_only:
        line = timing()
        print(line)
        if not args.no_write:
            RESULTS.with_name("pitot_timing.md").write_text(
                f"# The pitot inversion's cost\n\n`nice -n 10 python benchmarks/bench_pitot.py "
                f"--timing-only` ({dt.date.today().isoformat()}, shared 2-core machine)\n\n"
                f"{line}\n")
        return
    kinds, lines = run(args.seeds)
    text = table(kinds)
    print(text)
    if not args.no_write:
        RESULTS.parent.mkdir(exist_ok=True)
        RESULTS.write_text(
            f"# Equation-error: a probe's pressures against an airspeed channel\n\n"
            f"`nice -n 10 python benchmarks/bench_pitot.py --seeds {args.seeds}` "
            f"({dt.date.today().isoformat()}, aeroid {aeroid.__version__}; "
            f"{args.seeds} seeds)\n\n{text}\n\n## Runs\n\n" + "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
