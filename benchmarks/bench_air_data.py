"""Equation-error with logged air data (a probe's alpha, beta, airspeed) in wind and turbulence.

Run by hand from the repository root (one process, the fits in turn: ``--jobs 1``)::

    python benchmarks/bench_air_data.py                  # 8 seeds, writes results
    python benchmarks/bench_air_data.py --seeds 2 --no-write

Per seed ``k`` (``rng = k``: the gusts, then the sensor noise, as :func:`aeroid.simulate`):
the reference scenario with the tactical Gaussian IMU (:class:`aeroid.flights.GaussianNoise`
defaults) and a probe drawn by the same noise model (``alpha_sd_rad = beta_sd_rad`` 0.1
deg, ``airspeed_sd_mps`` 0.5: an ``airspeed`` channel), in still air; in a crosswind of
5 m/s (east, across the northward path); in a steady wind of 5 m/s (north 3, east 4: 3
m/s along the path, 4 across); and in that wind with Dryden turbulence of sd 1 and 3 m/s
(scale length 533.4 m). Fits (two-step equation-error, ``air_data = "measured"`` unless
said):

* ``still / IMU only``: the yardstick, the same flight logged without the probe (angles
  from u, v, w: the issue's "still-air error");
* ``kalman``: the default, the implied wind Kalman-smoothed with its gust intensity by
  maximum likelihood (:mod:`aeroid.estimation._air_smoother`);
* ``window 0.1 s``: the former default (Savitzky-Golay over ``air_data_window_s`` =
  ``--window-s``, default 0.1 s);
* ``kalman, Dryden``: the Kalman smoother with a steady wind plus Dryden gusts, their sd
  and scale length by maximum likelihood (``air_data_smoother = "dryden"``,
  :mod:`aeroid.estimation._air_dryden`);
* ``Dryden told the truth``: that smoother given the simulator's gust sd and scale
  length (what a perfect gust model would leave: the floor of smoothing the air data);
* ``kalman, no airspeed``: the same probe without its airspeed channel (the along-path
  wind unseen);
* ``true wind``: the simulator's wind per sample given to the regressors (what no probe
  noise would leave: the floor of this estimator on these flights);
* ``inertial``: ``air_data = "inertial"``, the known-wrong angles the fit check must refuse.

Reported: successes (the fit check's verdict, and equation-error's refusal of turbulence
without an airspeed channel, :func:`baselines._ee_air.refuse_unseen_gusts`), the mean
over seeds of the mean |relative error| of the nine coefficients [%], its ratio to still
air (IMU only), the coverage of the 95 % intervals (coefficient-runs with |error| <= 1.96
se), the median over seeds of the largest |error| / se, Czq's mean |error| (the
coefficient the vane noise moves most) and, for the smoothers, the RMS of the smoothed
wind's error against the simulator's wind (over samples and NED axes, mean over seeds).
The Cramér-Rao floor of the IMU channels in still air (:func:`aeroid.estimation.
cramer_rao_sd`, as a mean |error|: sd sqrt(2/pi)) is printed beside it: no floor of the
air-data channels in turbulence exists in aeroid (the gusts are a random process there).
Target (issue 26): measured air data within 2x the still-air error.
"""

from __future__ import annotations

from _air_flights import (  # first: one BLAS thread before numpy loads
    AIRS,
    AIRSPEED_SD_MPS,
    SCALE_LENGTH_M,
    VANE_SD_DEG,
    WIND,
    coefficient_table,
    probe_noise,
    windy_flight,
)

# isort: split
import argparse
import dataclasses
import datetime as dt
import math
import time
from pathlib import Path

import numpy as np

import aeroid
from aeroid import estimation as rc
from aeroid.estimation import cramer_rao_sd
from aeroid.flights import make_noise, reference_scenario
from baselines._ee_air import with_wind_consider
from baselines.equation_error import EquationErrorEstimator

RESULTS = Path(__file__).parent / "results" / "air_data.md"
IMU = make_noise("gaussian")


def probes(vane_deg: float) -> tuple[aeroid.flights.NoiseModel, aeroid.flights.NoiseModel]:
    """The IMU with a probe of ``vane_deg`` on alpha and beta: with its airspeed, without."""
    vane = float(np.radians(vane_deg))
    return probe_noise(vane, airspeed_sd_mps=AIRSPEED_SD_MPS), probe_noise(vane)


class TrueWind(EquationErrorEstimator):
    """Equation-error given the simulator's wind per sample (the benchmark's floor)."""

    def run(self, flight, rng, holds=None):  # noqa: D102
        return self._solve(flight, wind=flight.metadata["bench_true_wind"])


class ToldDryden(EquationErrorEstimator):
    """Equation-error with the Dryden smoother given the simulator's gust sd and scale
    length (``metadata["bench_gusts"]``), its consider term as the default fit's."""

    def run(self, flight, rng, holds=None):  # noqa: D102
        sd, length = flight.metadata["bench_gusts"]
        smoothed = rc.smooth_air_wind(flight, rc.air_data_wind(flight), model="dryden",
                                      gust_sd_mps=sd, scale_length_m=length)
        air = rc.AirData("measured", smoothed.wind, "told", smoothed=smoothed)
        result = self._solve(flight, wind=smoothed.wind)
        return with_wind_consider(result, flight, air, lambda wind: self._solve(
            flight, theta_only=True, wind=wind).theta, self.name)


def wind_error(estimator, flight) -> float | None:
    """RMS [m/s] of the wind ``estimator`` smooths from ``flight``'s air data against the
    simulator's (None for fits without a smoother)."""
    if isinstance(estimator, ToldDryden):
        sd, length = flight.metadata["bench_gusts"]
        wind = rc.smooth_air_wind(flight, rc.air_data_wind(flight), model="dryden",
                                  gust_sd_mps=sd, scale_length_m=length).wind
    elif estimator.air_data == "measured" and not isinstance(estimator, TrueWind):
        wind = rc.resolve_air_data(flight, "measured", "bench", estimator.air_data_window_s,
                                   estimator.air_data_smoother).wind
    else:
        return None
    return float(np.sqrt(np.mean((wind - flight.metadata["bench_true_wind"]) ** 2)))


def flights(air: str, seed: int, vane_deg: float) -> dict[str, aeroid.flights.Flight]:
    """The seed's flights of ``air``: with the probe, without its airspeed, IMU only."""
    wind = AIRS[air]
    out = {}
    probe, no_airspeed = probes(vane_deg)
    for label, noise in (("probe", probe), ("no airspeed", no_airspeed), ("imu", IMU)):
        f, true_wind = windy_flight(wind, noise, seed)
        gusts = (0.0, SCALE_LENGTH_M) if wind is None else (wind.turbulence_sd_mps,
                                                            wind.scale_length_m)
        out[label] = dataclasses.replace(f, metadata={**f.metadata, "bench_gusts": gusts,
                                                      "bench_true_wind": true_wind})
    return out


def run(seeds: int, vane_deg: float = VANE_SD_DEG, airs: tuple[str, ...] = tuple(AIRS),
        window_s: float = 0.1) -> tuple[dict, list[str]]:
    """Fit every kind on every seed; return per-kind lists of (success, errors, z) and lines."""
    truth = reference_scenario().coefficient_vector
    kinds: dict[str, list] = {}
    lines = []
    for seed in range(1, seeds + 1):
        for air in ("still", *(a for a in airs if a != "still")):
            f = flights(air, seed, vane_deg)
            fits = {f"{air} / kalman": (EquationErrorEstimator(air_data="measured"), "probe"),
                    f"{air} / window {window_s:g} s": (EquationErrorEstimator(
                        air_data="measured", air_data_window_s=window_s), "probe"),
                    f"{air} / kalman, Dryden": (EquationErrorEstimator(
                        air_data="measured", air_data_smoother="dryden"), "probe"),
                    f"{air} / Dryden told the truth": (ToldDryden(air_data="measured"),
                                                       "probe"),
                    f"{air} / kalman, no airspeed": (EquationErrorEstimator(
                        air_data="measured"), "no airspeed"),
                    f"{air} / true wind": (TrueWind(), "imu")}
            fits[f"{air} / " + ("IMU only" if air == "still" else "inertial")] = (
                EquationErrorEstimator(air_data="inertial"), "imu")
            for kind, (estimator, which) in fits.items():
                start = time.perf_counter()
                r = estimator.fit(f[which])
                err = np.abs(r.theta / truth - 1.0) * 100.0
                z = np.abs(r.theta - truth) / r.stderr
                seconds = time.perf_counter() - start
                werr = wind_error(estimator, f[which])
                kinds.setdefault(kind, []).append((r.success, err, z, werr))
                q = r.info.get("air_data_wind_intensity")
                told = r.info.get("air_data_smoother", {})
                lines.append(f"seed {seed} {kind}: success={r.success} mean |err| "
                             f"{err.mean():.3f} % max |err|/se {z.max():.1f} "
                             f"q {'-' if q is None else f'{q:.3g}'} "
                             f"gust sd {told.get('gust_sd_mps', math.nan):.3g} "
                             f"L {told.get('scale_length_m', math.nan):.4g} "
                             f"wind err {math.nan if werr is None else werr:.3f} m/s "
                             f"{seconds:.2f} s {r.message[:90]}")
                print(lines[-1], flush=True)
    return kinds, lines


def floor_line() -> str:
    """The still-air Cramér-Rao floor of the IMU channels as a mean |relative error| [%]."""
    s = reference_scenario()
    sd = np.asarray(cramer_rao_sd(s, IMU), dtype=float)
    e = np.sqrt(2 / np.pi) * sd / np.abs(s.coefficient_vector) * 100.0
    return (f"Cramér-Rao floor, IMU channels, still air: mean |relative error| {e.mean():.3f} %"
            f" (Czq {e[aeroid.NAMES.index('Czq')]:.2f} %)")


def table(kinds: dict) -> str:
    """Return the markdown tables of the kinds."""
    still = np.mean([r[1].mean() for r in kinds["still / IMU only"]])
    czq = aeroid.NAMES.index("Czq")
    out = ["| air / fit | success | mean abs rel error [%] | x still | coverage "
           "| median max abs err/se | Czq mean abs err [%] | wind RMS err [m/s] |",
           "|---|---|---|---|---|---|---|---|"]
    for kind, rows in kinds.items():
        e = np.mean([r[1].mean() for r in rows])
        cover = np.mean(np.concatenate([r[2] <= 1.96 for r in rows]))
        out.append(f"| {kind} | {sum(r[0] for r in rows)}/{len(rows)} | {e:.3f} | "
                   f"{e / still:.2f} | {cover:.2f} | {np.median([r[2].max() for r in rows]):.1f}"
                   f" | {np.mean([r[1][czq] for r in rows]):.2f} | "
                   + ("-" if rows[0][3] is None else f"{np.mean([r[3] for r in rows]):.3f}")
                   + " |")
    out += coefficient_table({kind: [r[1] for r in rows] for kind, rows in kinds.items()})
    return "\n".join(out)


def main() -> None:
    """Run the benchmark and print (and write) the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--vane-deg", type=float, default=VANE_SD_DEG,
                        help="the probe's noise sd on alpha and beta [deg]")
    parser.add_argument("--airs", default=",".join(AIRS),
                        help="comma-separated airs to fly (still air always)")
    parser.add_argument("--window-s", type=float, default=0.1,
                        help="air_data_window_s of the fixed-window fits [s]")
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    airs = tuple(a.strip() for a in args.airs.split(","))
    unknown = sorted(set(airs) - set(AIRS))
    if unknown:
        parser.error(f"unknown air(s) {unknown}; known: {', '.join(AIRS)}")
    kinds, lines = run(args.seeds, args.vane_deg, airs, args.window_s)
    text = table(kinds) + "\n\n" + floor_line()
    print(text)
    if not args.no_write:
        default = args.vane_deg == VANE_SD_DEG and set(airs) == set(AIRS)
        path = (RESULTS if default else RESULTS.with_name(
            f"air_data_vane_{args.vane_deg:g}deg.md"))
        if args.window_s != 0.1:
            path = path.with_name(f"{path.stem}_window_{args.window_s:g}s.md")
        path.write_text(
            f"# Equation-error with logged air data ({dt.date.today()})\n\n"
            f"`python benchmarks/bench_air_data.py --seeds {args.seeds} --vane-deg "
            f"{args.vane_deg:g} --airs '{args.airs}' --window-s {args.window_s:g}`; probe noise "
            f"{args.vane_deg:g} deg on alpha and beta, {AIRSPEED_SD_MPS} m/s on the airspeed; "
            f"wind {WIND} m/s NED, Dryden scale length {SCALE_LENGTH_M} m."
            f"\n\n{text}\n\n```\n" + "\n".join(lines) + "\n```\n")


if __name__ == "__main__":
    main()
