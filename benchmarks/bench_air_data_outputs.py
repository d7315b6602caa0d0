"""Output-error with air data as measured outputs, on the 5 m/s windy flight (issue 26).

Run by hand from the repository root (one process, the fits in turn: ``--jobs 1``)::

    python benchmarks/bench_air_data_outputs.py                    # 8 seeds, writes results
    python benchmarks/bench_air_data_outputs.py --seeds 2 --no-write
    python benchmarks/bench_air_data_outputs.py --verdict-seeds 6  # also the verdict's rates
    python benchmarks/bench_air_data_outputs.py --reconstruction-seeds 8  # and the
        # reconstruction's steady wind (aeroid/reconstruction/_wind.py)

Per seed ``k`` (``rng = k`` for the flight, ``[k, 26]`` for the probe): the reference
scenario with Gaussian IMU noise, in still air and in a steady wind of 5 m/s (north 3,
along the path; east 4, across). The probe's readings are computed from the simulator's
true states and wind at the c.g.: alpha and beta with a miscalibration (factor +2 %,
offsets +2 and -1 mrad) and white noise of 0.1 deg, the airspeed with white noise of
0.5 m/s. Fits (output-error, defaults otherwise):

* ``off``: still air assumed, air data ignored (the yardstick on the still flight);
* ``wind``: ``estimate_wind = true`` (no air data: the along-path wind nearly
  unobservable);
* ``wind + air data``: ``estimate_wind = true, air_data = measured`` (factor and offset
  estimated).

Reported: successes (the fit check's verdict), mean |relative error| of the nine
coefficients [%] and its ratio to still air / off, the mean relative standard error, the
largest |error| / se over coefficients and wind components, how many runs have every
coefficient and wind component within 3 se, the north (along-path) wind's mean |error|
and mean se, and the calibration parameters within 3 se. With ``--verdict-seeds``: the
log-only verdict (:func:`aeroid.estimation.air_data_verdict`, vane angles only, no
airspeed) on the steady wind and on Dryden turbulence of sd 0.3, 1 and 3 m/s. With
``--reconstruction-seeds``: the reconstruction's steady wind from a 100 Hz probe added to
the default suite's log (:func:`reconstruction_winds`). With ``--pso-seeds``: EBM-PSO
and SEBM-PSO (polished) with the logged angles in a 5 m/s crosswind (:func:`pso_rows`).
"""

from __future__ import annotations

from _air_flights import AIRSPEED_SD_MPS, VANE_RAD, WIND  # first: one BLAS thread

# isort: split
import argparse
import dataclasses
import datetime as dt
import time
from pathlib import Path

import numpy as np

import aeroid
from aeroid.estimation import air_data_verdict
from aeroid.flights import Wind, make_noise, reference_scenario, simulate
from aeroid.model import as_state, constants, equations
from baselines.output_error import OutputErrorEstimator

RESULTS = Path(__file__).parent / "results" / "air_data_outputs.md"
CALIBRATION = {"alpha_factor": 0.02, "beta_factor": 0.02, "alpha_offset_rad": 0.002,
               "beta_offset_rad": -0.001}
FITS = {"off": {"estimate_wind": False}, "wind": {"estimate_wind": True},
        "wind + air data": {"estimate_wind": True, "air_data": "measured"}}


def with_probe(flight: aeroid.flights.Flight, wind: tuple[float, float, float],
               rng: np.random.Generator) -> aeroid.flights.Flight:
    """``flight`` with a miscalibrated probe's alpha, beta, airspeed at the c.g. in ``wind``."""
    x = as_state(flight.states())
    const = constants(flight.airframe)._replace(wind_n=wind[0], wind_e=wind[1],
                                                wind_d=wind[2])
    speed, alpha, beta = equations.air_data(*equations.air_velocity(x, const))
    n, c = flight.n_samples, CALIBRATION
    return dataclasses.replace(flight, data=flight.data.assign(
        alpha=(1 + c["alpha_factor"]) * alpha + c["alpha_offset_rad"]
        + VANE_RAD * rng.standard_normal(n),
        beta=(1 + c["beta_factor"]) * beta + c["beta_offset_rad"]
        + VANE_RAD * rng.standard_normal(n),
        airspeed=speed + AIRSPEED_SD_MPS * rng.standard_normal(n)))


def run(seeds: int) -> tuple[dict, list[str]]:
    """Fit every kind on every seed; return per-kind rows and the log lines."""
    s = reference_scenario()
    truth = s.coefficient_vector
    kinds: dict[str, list] = {}
    lines = []
    for seed in range(1, seeds + 1):
        for air, wind in (("still", (0.0, 0.0, 0.0)), ("wind 5 m/s", WIND)):
            m = s.manoeuvre if air == "still" else dataclasses.replace(
                s.manoeuvre, wind=Wind(steady_ned_mps=wind))
            flight = with_probe(simulate(s.airframe, truth, m, make_noise("gaussian"),
                                         rng=seed), wind, np.random.default_rng([seed, 26]))
            for fit, options in FITS.items():
                start = time.perf_counter()
                r = OutputErrorEstimator(**options).fit(flight)
                took = time.perf_counter() - start
                err = np.abs(r.theta / truth - 1.0) * 100.0
                z = list(np.abs(r.theta - truth) / r.stderr)
                north = (np.nan, np.nan)
                if "wind_ned_mps" in r.info:
                    w, sd = np.array(r.info["wind_ned_mps"]), np.array(r.info["wind_stderr_mps"])
                    z += list(np.abs(w - wind) / sd)
                    north = (abs(w[0] - wind[0]), sd[0])
                cal = r.info.get("air_data", {})
                cal_ok = sum(abs(cal["calibration"][k] - v) <= 3 * cal["calibration_stderr"][k]
                             for k, v in CALIBRATION.items()) if cal else np.nan
                kinds.setdefault(f"{air} / {fit}", []).append(
                    (r.success, err.mean(), np.mean(r.stderr / np.abs(truth)) * 100, max(z),
                     north, cal_ok, took))
                lines.append(f"seed {seed} {air} / {fit}: success={r.success} mean |err| "
                             f"{err.mean():.3f} % max |err|/se {max(z):.2f} north |err| "
                             f"{north[0]:.3f} +- {north[1]:.3f} m/s calibration within 3 se "
                             f"{cal_ok}/4 {took:.1f} s {r.message[:80]}")
                print(lines[-1], flush=True)
    return kinds, lines


def verdicts(seeds: int) -> list[str]:
    """The log-only verdict's kinds over seeds, per air (vane angles, no airspeed)."""
    s = reference_scenario()
    out = ["| air | still air | steady wind | turbulence | gusts [m/s] min-max | limit [m/s] |",
           "|---|---|---|---|---|---|"]
    for label, sd in (("steady 5 m/s", 0.0), ("+ Dryden sd 0.3", 0.3),
                      ("+ Dryden sd 1", 1.0), ("+ Dryden sd 3", 3.0)):
        found = []
        for seed in range(1, seeds + 1):
            wind = Wind(steady_ned_mps=WIND, turbulence_sd_mps=sd, scale_length_m=533.4)
            f = simulate(s.airframe, s.coefficient_vector,
                         dataclasses.replace(s.manoeuvre, wind=wind), make_noise("gaussian"),
                         rng=seed)
            gen = np.random.default_rng([seed, 26])
            f = dataclasses.replace(f, data=f.data.assign(
                alpha=f["alpha"] + VANE_RAD * gen.standard_normal(f.n_samples),
                beta=f["beta"] + VANE_RAD * gen.standard_normal(f.n_samples)))
            found.append(air_data_verdict(f, "verdict"))
        kinds = [v.kind for v in found]
        gusts = [v.gust_rms_mps for v in found]
        out.append(f"| {label} | {kinds.count('still air')} | {kinds.count('steady wind')} | "
                   f"{kinds.count('turbulence')} | {min(gusts):.2f}-{max(gusts):.2f} | "
                   f"{np.mean([v.gust_limit_mps for v in found]):.2f} |")
        print(out[-1], flush=True)
    return out


def reconstruction_winds(seeds: int) -> list[str]:
    """The reconstruction's steady wind over seeds: a 100 Hz probe (0.1 deg, 0.5 m/s) in
    a 3 / 4 / -0.5 m/s wind added to the default suite's log (rng ``k``; probe
    ``[k, 22]``)."""
    from aeroid.flights import SensorGroup, body_to_ned, simulate_suite
    from aeroid.reconstruction import reconstruct

    s = reference_scenario()
    wind = np.array([3.0, 4.0, -0.5])
    sd = {"alpha": float(VANE_RAD), "beta": float(VANE_RAD), "airspeed": AIRSPEED_SD_MPS}
    rows = []
    for seed in range(1, seeds + 1):
        sim = simulate_suite(s.airframe, s.coefficient_vector, s.manoeuvre,
                             rng=np.random.default_rng(seed))
        gen = np.random.default_rng([seed, 22])
        t = sim.log["imu"].t
        k = np.arange(0, t.size, 10)
        v = np.column_stack([sim.truth[c][k] for c in ("u", "v", "w")])
        c_nb = body_to_ned(*(sim.truth[c][k] for c in ("phi", "theta", "psi")))
        true = dict(zip(("airspeed", "alpha", "beta"), equations.air_data(
            *(v - np.einsum("kji,j->ki", c_nb, wind)).T), strict=True))
        group = SensorGroup("air", t[k], {c: true[c] + sd[c] * gen.standard_normal(k.size)
                                          for c in sd}, sd)
        start = time.perf_counter()
        rec = reconstruct(dataclasses.replace(sim.log, groups={**sim.log.groups, "air": group}))
        m = rec.metadata
        w, e = np.array(m["wind_ned_mps"]), np.array(m["wind_stderr_mps"])
        rows.append((np.abs(w - wind), e, np.abs(w - wind) / e, m["wind_scatter"],
                     time.perf_counter() - start))
        print(f"reconstruction seed {seed}: wind {np.round(w, 3)} sd {np.round(e, 3)} "
              f"scatter {m['wind_scatter']:.2f}", flush=True)
    err, sds, z = (np.array([r[j] for r in rows]) for j in range(3))
    return ["| reconstruction, seeds | mean abs err N / E / D [m/s] | mean sd N / E / D [m/s] "
            "| components within 3 sd | largest err/sd | scatter min-max | mean time [s] |",
            "|---|---|---|---|---|---|---|",
            f"| {seeds} | {' / '.join(f'{x:.3f}' for x in err.mean(axis=0))} | "
            f"{' / '.join(f'{x:.3f}' for x in sds.mean(axis=0))} | {int(np.sum(z <= 3))}/"
            f"{z.size} | {z.max():.2f} | {min(r[3] for r in rows):.2f}-"
            f"{max(r[3] for r in rows):.2f} | {np.mean([r[4] for r in rows]):.1f} |"]


def pso_rows(seeds: int) -> list[str]:
    """EBM-PSO and SEBM-PSO (polished) with the logged angles on noisy flights: still air
    (inertial angles) and a 5 m/s crosswind (vane 0.1 deg; logged / inertial angles)."""
    from aeroid.estimation import get_estimator

    s = reference_scenario()
    truth = s.coefficient_vector
    out = ["| method: air / angles | success | mean abs rel error [%] | x still |",
           "|---|---|---|---|"]
    for name in ("ebm-pso", "sebm-pso"):
        rows: dict[str, list] = {}
        for seed in range(1, seeds + 1):
            for air, wind in (("still", None), ("crosswind 5 m/s", (0.0, 5.0, 0.0))):
                m = s.manoeuvre if wind is None else dataclasses.replace(
                    s.manoeuvre, wind=Wind(steady_ned_mps=wind))
                f = simulate(s.airframe, truth, m, make_noise("gaussian"), rng=seed)
                if wind is not None:
                    gen = np.random.default_rng([seed, 26])
                    f = dataclasses.replace(f, data=f.data.assign(
                        alpha=f["alpha"] + VANE_RAD * gen.standard_normal(f.n_samples),
                        beta=f["beta"] + VANE_RAD * gen.standard_normal(f.n_samples)))
                for angles in (("inertial",) if wind is None else ("measured", "inertial")):
                    r = get_estimator(name)(air_data=angles, polish=True).fit(f, rng=seed)
                    err = float(np.mean(np.abs(r.theta / truth - 1.0)) * 100.0)
                    rows.setdefault(f"{air} / {angles}", []).append((r.success, err))
                    print(f"{name} seed {seed} {air} / {angles}: success={r.success} mean "
                          f"|err| {err:.3f} %", flush=True)
        still = np.mean([e for _, e in rows["still / inertial"]])
        out += [f"| {name}: {k} | {sum(ok for ok, _ in v)}/{len(v)} | "
                f"{np.mean([e for _, e in v]):.3f} | {np.mean([e for _, e in v]) / still:.2f} |"
                for k, v in rows.items()]
    return out


def table(kinds: dict) -> str:
    """Return the markdown table of the kinds."""
    still = np.mean([r[1] for r in kinds["still / off"]])
    out = ["| flight / fit | success | mean abs rel error [%] | x still/off | mean rel se [%] "
           "| max err/se | all within 3 se | north wind mean abs err / se [m/s] "
           "| calibration within 3 se | mean time [s] |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for kind, rows in kinds.items():
        e = np.mean([r[1] for r in rows])
        north = np.array([r[4] for r in rows])
        cal = [r[5] for r in rows]
        out.append(
            f"| {kind} | {sum(r[0] for r in rows)}/{len(rows)} | {e:.3f} | {e / still:.2f} | "
            f"{np.mean([r[2] for r in rows]):.3f} | {max(r[3] for r in rows):.2f} | "
            f"{sum(r[3] <= 3 for r in rows)}/{len(rows)} | "
            + ("- |" if np.all(np.isnan(north)) else
               f"{np.nanmean(north[:, 0]):.3f} / {np.nanmean(north[:, 1]):.3f} |")
            + (" - |" if np.all(np.isnan(cal)) else f" {int(np.nansum(cal))}/{4 * len(rows)} |")
            + f" {np.mean([r[6] for r in rows]):.1f} |")
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--verdict-seeds", type=int, default=0)
    parser.add_argument("--reconstruction-seeds", type=int, default=0)
    parser.add_argument("--pso-seeds", type=int, default=0)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    kinds, lines = run(args.seeds)
    text = table(kinds)
    print(text)
    verdict = verdicts(args.verdict_seeds) if args.verdict_seeds else []
    if args.reconstruction_seeds:
        verdict += [""] + reconstruction_winds(args.reconstruction_seeds)
        print("\n".join(verdict[-3:]))
    if args.pso_seeds:
        verdict += [""] + pso_rows(args.pso_seeds)
        print("\n".join(verdict[-8:]))
    if not args.no_write:
        RESULTS.parent.mkdir(exist_ok=True)
        command = (f"python benchmarks/bench_air_data_outputs.py --seeds {args.seeds}"
                   + (f" --verdict-seeds {args.verdict_seeds}" if args.verdict_seeds else "")
                   + (f" --reconstruction-seeds {args.reconstruction_seeds}"
                      if args.reconstruction_seeds else "")
                   + (f" --pso-seeds {args.pso_seeds}" if args.pso_seeds else ""))
        RESULTS.write_text(f"# Output-error with air data as outputs\n\n{dt.date.today()}, "
                           f"`{command}`\n\n{text}\n\n" + ("\n".join(verdict) + "\n\n"
                                                           if verdict else "")
                           + "Per run:\n\n" + "\n".join(f"    {x}" for x in lines) + "\n")


if __name__ == "__main__":
    main()
