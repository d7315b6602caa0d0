"""A windy suite log through the reconstruction and the air-data fits, against the single file.

Run by hand from the repository root (one process, the fits in turn: ``--jobs 1``)::

    nice -n 10 python benchmarks/bench_suite_wind.py --seeds 8     # writes results
    python benchmarks/bench_suite_wind.py --seeds 1 --no-write
    nice -n 10 python benchmarks/bench_suite_wind.py --reconstruction-seeds 8
    nice -n 10 python benchmarks/bench_suite_wind.py --seeds 10 --turbulence

``--reconstruction-seeds``: the reconstruction's steady wind alone
(:func:`reconstruction_winds`: the default suite with its IMU errors, a 100 Hz probe,
in a 3 / 4 / -0.5 m/s wind flown by the truth; an airspeed, the pressures, a probe off
the c.g. with and without its position in the log; and the airspeed in Dryden sd 3 m/s,
which must be called not steady).

Per seed ``k``: the reference scenario in a steady wind of 5 m/s (north 3, east 4), flown
twice from the same scenario with the same probe (0.1 deg vanes, a 0.5 m/s airspeed, at
the c.g.):

* ``single file``: :func:`aeroid.flights.simulate` at the manoeuvre's 500 Hz with the
  Gaussian IMU of the suite's noise (0.05 m/s^2, 0.002 rad/s), ``rng = k``;
* ``suite, probe N Hz``: :func:`aeroid.flights.simulate_suite` (the default suite's rates
  and noise: IMU at 1000 Hz, GNSS, baro, INS; without biases and scale factors, which the
  reconstruction still estimates, so the air-data path is what differs: on the default
  suite the corrected IMU's axial biases dominate, README "Fitting the IMU's errors";
  the probe at N Hz), ``rng = k``,
  then :func:`aeroid.reconstruction.reconstruct` told the IMU has no errors (:data:`TOLD`;
  one row with the default priors) and ``to_flight()``: at 1000 Hz the air group's
  samples as logged; at 100 Hz ``air = "interpolate"`` (linearly interpolated to the IMU's
  instants) and the default ``"auto"`` (the reconstruction's steady wind only).

Fits: two-step equation-error with ``air_data = "measured"`` (``"reconstruction"`` on the
wind-only flight, and equation-error alone on the default priors' flight) and output-error
with ``air_data = "measured", estimate_wind = true`` (on the suite's flights also
``estimate_initial_velocity = true, initial_velocity_prior = "flight"``: :data:`OE_SUITE`).
Reported per row: successes (the fit check), the mean over seeds of the mean |relative
error| of the nine coefficients [%], its ratio to the single file's, the coverage of the
95 % intervals, the median and the largest |error| / se over the coefficients (and
output-error's wind components), the mean time per fit [s].
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # shared 2-core machine
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import datetime as dt  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from aeroid.flights import (  # noqa: E402
    AirProbe,
    SensorSuite,
    Wind,
    make_noise,
    reference_scenario,
    simulate,
    simulate_suite,
)
from aeroid.reconstruction import reconstruct  # noqa: E402
from baselines.equation_error import EquationErrorEstimator  # noqa: E402
from baselines.output_error import OutputErrorEstimator  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "suite_wind.md"
WIND = (3.0, 4.0, 0.0)
VANE_RAD = float(np.radians(0.1))
AIRSPEED_SD = 0.5
#: The suite without instrument errors (biases and scale factors 0; the reconstruction
#: still estimates them): the air-data path alone against the single file.
SUITE = SensorSuite(accel_bias_mps2=(0.0, 0.0), gyro_bias_radps=(0.0, 0.0),
                    scale_factor=(0.0, 0.0))
EE = EquationErrorEstimator(air_data="measured")
OE = OutputErrorEstimator(air_data="measured", estimate_wind=True)
#: On a reconstruction's flight the initial velocity over the ground is the
#: reconstruction's, with its sd (0.04-0.15 m/s): held at it, its error goes into the wind
#: (measured: the wind 7-43 of its se off, 10/10); free with that prior, within 3.
OE_SUITE = dataclasses.replace(OE, estimate_initial_velocity=True,
                               initial_velocity_prior="flight")
#: The reconstruction told the IMU has no errors (prior sd of its biases and scale factors
#: near 0): with the default priors its axial-bias estimates move Cx by tens of its se
#: (README "Fitting the IMU's errors"), whatever the air data; one row shows it.
TOLD = {"accel_bias_sd": 1e-5, "gyro_bias_sd": 1e-7, "scale_sd": 1e-7}


def flights(seed: int, with_oe: bool) -> dict[str, tuple]:
    """The seed's flights by row label, each with the estimators to fit on it."""
    s = reference_scenario()
    m = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND))
    noise = make_noise("gaussian", accel_sd_mps2=SUITE.accel_noise_mps2,
                       rate_sd_radps=SUITE.gyro_noise_radps, alpha_sd_rad=VANE_RAD,
                       beta_sd_rad=VANE_RAD, airspeed_sd_mps=AIRSPEED_SD)
    both = {"equation-error": EE, **({"output-error": OE_SUITE} if with_oe else {})}
    out: dict[str, tuple] = {
        "single file (500 Hz)": (simulate(s.airframe, s.coefficient_vector, m, noise, rng=seed),
                                 {**both, **({"output-error": OE} if with_oe else {})})}
    for rate in (1000.0, 100.0):
        probe = AirProbe(rate_hz=rate, alpha_sd_rad=VANE_RAD, beta_sd_rad=VANE_RAD,
                         airspeed_sd_mps=AIRSPEED_SD)
        sim = simulate_suite(s.airframe, s.coefficient_vector, m,
                             dataclasses.replace(SUITE, air_probe=probe), rng=seed)
        rec = reconstruct(sim.log, **TOLD)
        if rate == 1000.0:
            out["suite, probe 1000 Hz (as logged)"] = (rec.to_flight(), both)
            out["suite, probe 1000 Hz, IMU errors estimated"] = (
                reconstruct(sim.log).to_flight(), {"equation-error": EE})
            continue
        out["suite, probe 100 Hz interpolated"] = (rec.to_flight(air="interpolate"), both)
        out["suite, probe 100 Hz, wind only (auto)"] = (rec.to_flight(), {
            "equation-error": EquationErrorEstimator(air_data="reconstruction")})
    return out


#: ``--turbulence``: the same steady wind plus Dryden turbulence of sd 3 m/s (MIL scale
#: length 533.4 m), equation-error only (output-error is flagged there by design).
TURBULENCE = Wind(steady_ned_mps=WIND, turbulence_sd_mps=3.0, scale_length_m=533.4)


def turbulent_flights(seed: int, with_oe: bool) -> dict[str, tuple]:
    """The seed's turbulent flights: the single file and the suite with its probe on the
    IMU's clock (each draws its own gusts: the suite's on its 1 kHz grid)."""
    s = reference_scenario()
    m = dataclasses.replace(s.manoeuvre, wind=TURBULENCE)
    noise = make_noise("gaussian", accel_sd_mps2=SUITE.accel_noise_mps2,
                       rate_sd_radps=SUITE.gyro_noise_radps, alpha_sd_rad=VANE_RAD,
                       beta_sd_rad=VANE_RAD, airspeed_sd_mps=AIRSPEED_SD)
    probe = AirProbe(rate_hz=1000.0, alpha_sd_rad=VANE_RAD, beta_sd_rad=VANE_RAD,
                     airspeed_sd_mps=AIRSPEED_SD)
    sim = simulate_suite(s.airframe, s.coefficient_vector, m,
                         dataclasses.replace(SUITE, air_probe=probe), rng=seed)
    return {"single file (500 Hz)": (simulate(s.airframe, s.coefficient_vector, m, noise,
                                              rng=seed), {"equation-error": EE}),
            "suite, probe 1000 Hz (as logged)": (reconstruct(sim.log, **TOLD).to_flight(),
                                                 {"equation-error": EE})}


def run(seeds: int, with_oe: bool, source: Any = None) -> tuple[dict, list[str]]:
    """Fit every row on every seed (``source``: the flights, default :func:`flights`);
    return per-row results and the log lines."""
    source = source or flights
    truth = reference_scenario().coefficient_vector
    rows: dict[str, list] = {}
    lines: list[str] = []
    for seed in range(1, seeds + 1):
        for label, (flight, estimators) in source(seed, with_oe).items():
            for method, estimator in estimators.items():
                start = time.perf_counter()
                r = estimator.fit(flight, rng=0)
                took = time.perf_counter() - start
                err = np.abs(r.theta / truth - 1) * 100
                z = np.abs(r.theta - truth) / r.stderr
                zw = np.array([])
                if "wind_ned_mps" in r.info and r.info.get("wind_stderr_mps") is not None:
                    zw = (np.abs(np.array(r.info["wind_ned_mps"]) - WIND)
                          / np.array(r.info["wind_stderr_mps"]))
                rows.setdefault(f"{method} / {label}", []).append(
                    (r.success, err, z, zw, took))
                lines.append(f"seed {seed} {method} / {label}: success={r.success} mean |err| "
                             f"{err.mean():.3f} % max |err|/se {z.max():.2f} wind |err|/se "
                             f"{np.round(zw, 2).tolist()} {took:.1f} s {r.message[:70]}")
                print(lines[-1], flush=True)
    return rows, lines


def table(rows: dict) -> str:
    """The markdown table of the rows."""
    out = ["| method / flight | success | mean abs rel error [%] | x single file | coverage | "
           "median, max of max abs err/se | wind max err/se | mean time [s] |",
           "|---|---|---|---|---|---|---|---|"]
    for label, runs in rows.items():
        method = label.split(" / ")[0]
        ref = np.mean([r[1].mean() for r in rows[f"{method} / single file (500 Hz)"]])
        e = np.mean([r[1].mean() for r in runs])
        cover = np.mean(np.concatenate([r[2] <= 1.96 for r in runs]))
        zmax = [r[2].max() for r in runs]
        zw = np.concatenate([r[3] for r in runs])
        out.append(f"| {label} | {sum(r[0] for r in runs)}/{len(runs)} | {e:.3f} | "
                   f"{e / ref:.2f} | {cover:.2f} | {np.median(zmax):.2f}, {max(zmax):.2f} | "
                   f"{f'{zw.max():.2f}' if zw.size else '-'} | "
                   f"{np.mean([r[4] for r in runs]):.1f} |")
    return "\n".join(out)


RECONSTRUCTION_RESULTS = Path(__file__).parent / "results" / "suite_wind_reconstruction.md"
#: The reconstruction's wind: the README's earlier table's wind, now flown by the truth.
REC_WIND = (3.0, 4.0, -0.5)
PROBES = {"airspeed 0.5 m/s": AirProbe(),
          "pressures 50 Pa": AirProbe(airspeed_sd_mps=0.0, total_pressure_sd_pa=50.0,
                                      static_pressure_sd_pa=50.0),
          "airspeed, probe at (0.5, 0.05, -0.02) m": AirProbe(position_m=(0.5, 0.05, -0.02)),
          "the same, position not stated": AirProbe(position_m=(0.5, 0.05, -0.02))}
#: The row whose log is read without its probe position (taken at the c.g.).
UNSTATED = "the same, position not stated"


def reconstruction_winds(seeds: int) -> str:
    """The reconstruction's steady wind on the default suite (IMU errors, default priors)
    with a 100 Hz probe in :data:`REC_WIND`, flown by the truth; seeds 1..``seeds``."""
    s = reference_scenario()
    out = ["| probe | seeds | mean abs err N / E / D [m/s] | mean sd N / E / D [m/s] | "
           "components within 3 sd | largest err/sd | scatter min-max | called steady |",
           "|---|---|---|---|---|---|---|---|"]
    airs = {"steady": Wind(steady_ned_mps=REC_WIND),
            "+ Dryden sd 3": Wind(steady_ned_mps=REC_WIND, turbulence_sd_mps=3.0)}
    for air, wind in airs.items():
        m = dataclasses.replace(s.manoeuvre, wind=wind)
        for label, probe in PROBES.items():
            if air != "steady" and label != "airspeed 0.5 m/s":
                continue
            errs, sds, scatter, steady = [], [], [], 0
            for seed in range(1, seeds + 1):
                log = simulate_suite(s.airframe, s.coefficient_vector, m,
                                     SensorSuite(air_probe=probe), rng=seed).log
                if label == UNSTATED:
                    log = dataclasses.replace(log, groups={**log.groups, "air": dataclasses.replace(
                        log["air"], probe_position_m=None)})
                meta = reconstruct(log).metadata
                errs.append(np.array(meta["wind_ned_mps"]) - REC_WIND)
                sds.append(np.array(meta["wind_stderr_mps"]))
                scatter.append(meta["wind_scatter"])
                steady += bool(meta["wind_steady"])
                print(f"{air} / {label} seed {seed}: err/sd {np.round(errs[-1] / sds[-1], 2)} "
                      f"scatter {scatter[-1]:.2f}", flush=True)
            e, sd = np.abs(np.array(errs)), np.array(sds)
            out.append(f"| {air} / {label} | {seeds} | "
                       f"{' / '.join(f'{v:.3f}' for v in e.mean(axis=0))} | "
                       f"{' / '.join(f'{v:.3f}' for v in sd.mean(axis=0))} | "
                       f"{int(np.sum(e <= 3 * sd))}/{e.size} | {np.max(e / sd):.2f} | "
                       f"{min(scatter):.2f}-{max(scatter):.2f} | {steady}/{seeds} |")
    return "\n".join(out)


def main() -> None:
    """Run, print and (unless ``--no-write``) write the results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--no-oe", action="store_true", help="equation-error only")
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--turbulence", action="store_true",
                        help="the wind plus Dryden sd 3 m/s, equation-error (results_turbulence)")
    parser.add_argument("--reconstruction-seeds", type=int, default=0,
                        help="only the reconstruction's steady wind, over this many seeds")
    args = parser.parse_args()
    if args.reconstruction_seeds:
        text = reconstruction_winds(args.reconstruction_seeds)
        print(text)
        if not args.no_write:
            RECONSTRUCTION_RESULTS.write_text(
                f"# The reconstruction's steady wind on windy suite flights ({dt.date.today()})"
                f"\n\n`nice -n 10 python benchmarks/bench_suite_wind.py --reconstruction-seeds "
                f"{args.reconstruction_seeds}`\n\n{text}\n")
        return
    start = time.perf_counter()
    rows, lines = run(args.seeds, not args.no_oe,
                      turbulent_flights if args.turbulence else flights)
    text = table(rows)
    print(text)
    if not args.no_write:
        where = RESULTS.with_name("suite_wind_turbulence.md") if args.turbulence else RESULTS
        where.write_text(
            f"# A windy suite log against the single file ({dt.date.today()}, "
            f"{time.perf_counter() - start:.0f} s)\n\n`nice -n 10 python "
            f"benchmarks/bench_suite_wind.py --seeds {args.seeds}"
            f"{' --no-oe' if args.no_oe else ''}{' --turbulence' if args.turbulence else ''}`"
            f"\n\n{text}\n\n```\n" + "\n".join(lines) + "\n```\n")


if __name__ == "__main__":
    main()
