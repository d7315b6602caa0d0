"""The EKF/UKF with gust states in Dryden turbulence (issue 26), against output-error and still air.

Run by hand from the repository root (one process, the fits in turn: ``--jobs 1``)::

    python benchmarks/bench_gust_filters.py --seeds 4            # writes results/gust_filters.md
    python benchmarks/bench_gust_filters.py --seeds 1 --no-write --fits ekf-gust-given
    python benchmarks/bench_gust_filters.py --seeds 3 --no-write --fits ekf-gustonly-est \
        --holds Cx=1.1 Clp=1.1 Cma=1.3       # the gust verdict on known-wrong models
    python benchmarks/bench_gust_filters.py --seeds 8 --steady 0 0 0 --fits fe \
        ekf-gustonly-est ekf-gustonly-given --write-to gust_vs_fe_still.md  # the same flights

Per seed ``k`` (``rng = k``): the reference scenario's flight with Gaussian IMU noise
(:class:`aeroid.flights.GaussianNoise` defaults) in still air, and the same manoeuvre in a
steady wind of 5 m/s (north 3 along the path, east 4) with Dryden turbulence of sd
``--turbulence`` m/s (default 3, the issue's moderate turbulence; MIL-F-8785C's scale
length 533.4 m); ``--steady N E D`` replaces the steady wind (``0 0 0``: turbulence
alone, filter-error's study). Fits (``--fits``, default all):

* ``ekf-still``: the EKF (defaults) on the still-air flight: the yardstick;
* ``oe-wind``: output-error with ``estimate_wind`` on the turbulent flight;
* ``ekf-wind``: the EKF with ``estimate_wind`` (no gust states) on the turbulent flight;
* ``ekf-gust-given``: the EKF with ``estimate_wind`` and gust states of the true intensity;
* ``ekf-gust-est``: the same with the intensity estimated (``estimate_gust_sd``);
* ``ekf-gust-still``: gust states with the intensity estimated on the still-air flight
  (the option's cost where there is no turbulence; ``estimate_wind`` off);
* ``ekf-gustonly-given``, ``ekf-gustonly-est``, ``ukf-gustonly-est``: gust states
  without the steady wind's states (the gusts carry the steady wind too) on the
  turbulent flight, the intensity given or estimated;
* ``ekf-gustonly-onestep``, ``ukf-gustonly-onestep``: ``ekf-gustonly-est`` with
  ``gust_stderr = one-step`` (one Fisher-scoring step of filter-error's likelihood from the
  filter's estimate, :mod:`baselines._kalman_information`; the default since it was
  measured against ``innovations``); ``ekf-gustonly-innov``: with ``gust_stderr =
  innovations`` (the filter's estimate, the information's se); ``ekf-gustonly-filtered``:
  with ``gust_stderr = filtered`` (the filtered covariance, as before ``gust_stderr``);
  ``ekf-gust-still-onestep``: ``ekf-gust-still`` with ``one-step``;
* ``fe``: the filter-error method (defaults) on the same turbulent flight, so the EKF's
  gust states and filter-error are compared on the SAME flights (issue 26's "within 1.5x");
* ``ekf-gustonly-air``, ``ekf-gust-air``, ``ukf-gustonly-air``: the gust fits with
  ``air_data = measured`` on the same turbulent flight with a probe's readings (alpha,
  beta, airspeed from the simulator's true states and wind per sample, gusts included,
  at the c.g.; ``bench_air_data_outputs.py``'s miscalibration and noise: factor +2 %,
  offsets +2 / -1 mrad, 0.1 deg, 0.5 m/s; probe noise ``rng = [k, 26]``).

Reported per fit: successes (after the fit check and the passes' verdict), the mean over
seeds of the mean |relative error| of the nine coefficients [%], its ratio to
``ekf-still``'s and to ``oe-wind``'s, the largest |error| / se and how many runs have
every coefficient within 3 se, the coverage of the 95 % intervals (``|error| <= 1.96 se``
over all coefficient-runs; a held coefficient, sd 0, is left out) with its exact
(Clopper-Pearson) 95 % interval, which takes the coefficient-runs as independent (the nine
of one run are correlated: the interval is too narrow by an unknown factor; the runs'
"all within 3 se" count is the independent figure), the same two figures with the filter's
own estimate and filtered covariance (``info['theta_filtered']``,
``info['stderr_filtered']``, where ``gust_stderr`` replaced them), and the ratio of the
mean error to ``fe``'s, the median wall time and this process's median CPU time per fit
(the machine is shared: the CPU time carries less of the others' load). With ``--holds
NAME=FACTOR ...`` every chosen fit is also run
with that coefficient held at FACTOR x its truth (a known-wrong model; FACTOR 1: a right
hold), and each run's line shows the gust verdict's figures (:mod:`baselines._gust_verdict`:
axial z, roll ratio), the likelihood-ratio hold test's ``LR`` and ``p``
(:mod:`baselines._kalman_holds`) and what refused it; the table counts the fits the
hold test refused and the range of ``LR``. One-step fits' lines show the next scoring
step's size in se (their settle verdict, :mod:`baselines._kalman_onestep`).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # shared 2-core machine
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import datetime as dt  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy.stats import binomtest  # noqa: E402

import aeroid  # noqa: E402
from aeroid.flights import (  # noqa: E402
    Wind,
    make_noise,
    record_flight,
    reference_scenario,
    simulate,
    simulate_truth,
)
from aeroid.model import NAMES, as_state, constants, equations  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
from bench_air_data_outputs import AIRSPEED_SD, CALIBRATION, VANE_SD  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "gust_filters.md"
WITHIN_SE = 3.0
Z95 = 1.959964
STEADY = (3.0, 4.0, 0.0)


def fits(sd: float, given_sd: float | None = None) -> dict[str, tuple[str, str, dict]]:
    """name -> (method, flight, options); ``given_sd``: the intensity the ``-given`` fits
    are told (default the true ``sd``)."""
    given = sd if given_sd is None else given_sd
    return {
        "ekf-still": ("ekf", "still", {}),
        "oe-wind": ("output-error", "turbulent", {"estimate_wind": True}),
        "ekf-wind": ("ekf", "turbulent", {"estimate_wind": True}),
        "ekf-gust-given": ("ekf", "turbulent", {"estimate_wind": True, "gust_sd_mps": given}),
        "ekf-gust-est": ("ekf", "turbulent", {"estimate_wind": True, "estimate_gust_sd": True}),
        "ekf-gust-still": ("ekf", "still", {"estimate_gust_sd": True}),
        "ekf-gustonly-given": ("ekf", "turbulent", {"gust_sd_mps": given}),
        "ekf-gustonly-est": ("ekf", "turbulent", {"estimate_gust_sd": True}),
        "ukf-gustonly-est": ("ukf", "turbulent", {"estimate_gust_sd": True}),
        "ekf-gustonly-onestep": ("ekf", "turbulent", {"estimate_gust_sd": True,
                                                      "gust_stderr": "one-step"}),
        "ekf-gustonly-filtered": ("ekf", "turbulent", {"estimate_gust_sd": True,
                                                       "gust_stderr": "filtered"}),
        "ekf-gustonly-innov": ("ekf", "turbulent", {"estimate_gust_sd": True,
                                                    "gust_stderr": "innovations"}),
        "ukf-gustonly-onestep": ("ukf", "turbulent", {"estimate_gust_sd": True,
                                                      "gust_stderr": "one-step"}),
        "ekf-gust-still-onestep": ("ekf", "still", {"estimate_gust_sd": True,
                                                    "gust_stderr": "one-step"}),
        "fe": ("filter-error", "turbulent", {}),
        "ekf-gustonly-air": ("ekf", "turbulent-probe", {"estimate_gust_sd": True,
                                                        "air_data": "measured"}),
        "ekf-gust-air": ("ekf", "turbulent-probe", {"estimate_wind": True,
                                                    "estimate_gust_sd": True,
                                                    "air_data": "measured"}),
        "ukf-gustonly-air": ("ukf", "turbulent-probe", {"estimate_gust_sd": True,
                                                        "air_data": "measured"}),
    }


def turbulent_flights(s, manoeuvre, noise, seed: int) -> tuple:
    """``simulate(..., rng=seed)``'s flight (its own steps: the gusts, then the sensor
    noise from one generator) and the same flight with a probe's alpha, beta, airspeed
    in the true wind per sample (miscalibrated, noisy: ``rng = [seed, 26]``)."""
    generator = np.random.default_rng(seed)
    truth = simulate_truth(s.airframe, s.coefficient_vector, manoeuvre, rng=generator)
    flight = record_flight(s.airframe, s.coefficient_vector, manoeuvre, truth, noise,
                           rng=generator)
    k0 = int(round(manoeuvre.window_s[0] / manoeuvre.dt))
    wind = truth.wind[k0:]
    const = constants(s.airframe)._replace(wind_n=wind[:, 0], wind_e=wind[:, 1],
                                           wind_d=wind[:, 2])
    speed, alpha, beta = equations.air_data(*equations.air_velocity(
        as_state(flight.states()), const))
    gen, n, c = np.random.default_rng([seed, 26]), flight.n_samples, CALIBRATION
    probe = dataclasses.replace(flight, data=flight.data.assign(
        alpha=(1 + c["alpha_factor"]) * alpha + c["alpha_offset_rad"]
        + VANE_SD * gen.standard_normal(n),
        beta=(1 + c["beta_factor"]) * beta + c["beta_offset_rad"]
        + VANE_SD * gen.standard_normal(n),
        airspeed=speed + AIRSPEED_SD * gen.standard_normal(n)))
    return flight, probe


def _estimator(method: str, options: dict):
    if method == "filter-error":  # by class: the entry point may not be installed yet
        from baselines.filter_error import FilterErrorEstimator
        return FilterErrorEstimator(**options)
    return aeroid.make_estimator(method, options)


def run(seeds: int, sd: float, chosen: tuple[str, ...], holds: tuple[str, ...] = (),
        steady: tuple[float, float, float] = STEADY, given_sd: float | None = None
        ) -> tuple[dict, list[str]]:
    """Fit every chosen kind on every seed (and with each of ``holds``, ``NAME=FACTOR``:
    that coefficient held at FACTOR x its truth); return per-kind rows and the lines."""
    s = reference_scenario()
    truth = s.coefficient_vector
    turbulent = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=steady,
                                                           turbulence_sd_mps=sd))
    noise = make_noise("gaussian")
    held = [(None, None)] + [(h.split("=")[0], float(h.split("=")[1])) for h in holds]
    kinds = {(name if h is None else f"{name} {h} {f:g}x"): [] for name in chosen
             for h, f in held}
    table = fits(sd, given_sd)
    lines = []
    for seed in range(1, seeds + 1):
        flights = {"still": simulate(s.airframe, truth, s.manoeuvre, noise, rng=seed)}
        flights["turbulent"], flights["turbulent-probe"] = turbulent_flights(
            s, turbulent, noise, seed)
        for name in chosen:
            for hold, factor in held:
                method, air, options = table[name]
                label = name if hold is None else f"{name} {hold} {factor:g}x"
                hold_arg = None if hold is None else {"hold": {hold: factor * float(
                    truth[NAMES.index(hold)])}}
                start, cpu_start = time.perf_counter(), time.process_time()
                r = _estimator(method, options).fit(flights[air], rng=seed, holds=hold_arg)
                wall = time.perf_counter() - start
                cpu = time.process_time() - cpu_start  # this process's: less of the load
                z = np.abs(r.theta - truth) / r.stderr
                rel = 100.0 * np.mean(np.abs(r.theta / truth - 1.0))
                extra = ""
                if "wind_ned_mps" in r.info:
                    extra += f" wind {np.round(r.info['wind_ned_mps'], 2).tolist()}"
                if "gust_sd_mps" in r.info:
                    extra += f" gust sd {r.info['gust_sd_mps']:.2f}"
                if "gust_verdict" in r.info:
                    fig = r.info["gust_verdict"]
                    extra += f" axial z {fig['axial_z']:.2f} roll ratio {fig['roll_ratio']:.2f}"
                free = r.stderr > 0  # held coefficients (sd 0) cover nothing: left out
                sd_f = r.info.get("stderr_filtered", r.stderr)  # gust_stderr's other se
                z_f = np.abs(r.info.get("theta_filtered", r.theta) - truth) / sd_f
                if any("intervals are not calibrated" in w for w in r.warnings):
                    extra += " [said: not calibrated]"
                if "gust_information" in r.info:
                    extra += f" likelihood sd {r.info['gust_information']['gust_sd_mps']:.2f}"
                moves = r.info.get("one_step", {}).get("next_step_se")
                if moves:
                    extra += f" next step {np.nanmax(list(moves.values())):.2f} se"
                    if not r.info["one_step"]["filter_success"]:
                        extra += " [the filter's own refused]"
                test = r.info.get("hold_test", {})
                if test.get("done"):
                    extra += f" hold LR {test['lr']:.2f} p {test['p_value']:.2g}"
                if "intervals" in r.info:
                    extra += f" calibrated={r.info['intervals']['calibrated']}"
                if "stderr_filtered" in r.info:
                    extra += (f" z(filtered se) {np.nanmax(z_f):.2f} se/filtered "
                              f"{np.nanmin(r.stderr[free] / sd_f[free]):.2f}-"
                              f"{np.nanmax(r.stderr[free] / sd_f[free]):.2f}")
                kinds[label].append({"success": r.success, "rel": rel,
                                     "covered": int(np.sum(z[free] <= Z95)),
                                     "covered_filtered": int(np.sum(z_f[free] <= Z95)),
                                     "within_filtered": bool(np.all(z_f[free] < WITHIN_SE)),
                                     "n_cover": int(np.sum(free)),
                                     "zmax": float(np.nanmax(z)),
                                     "within": bool(np.all(z[np.isfinite(z)] < WITHIN_SE)),
                                     "hold_refused": bool(test.get("done") and test["p_value"]
                                                          < test["alpha"]),
                                     "hold_lr": test.get("lr", np.nan),
                                     "wall": wall, "cpu": cpu})
                lines.append(f"seed {seed} {label:15s} success={r.success} "
                             f"mean|err|={rel:.3f}% max z={np.nanmax(z):.2f} {wall:.1f}s "
                             f"cpu {cpu:.1f}s{extra}"
                             + ("" if r.success else f" [{r.message[:110]}]"))
                print(lines[-1], flush=True)
    return kinds, lines


def summary(kinds: dict) -> str:
    """The summary table (markdown)."""
    def mean_rel(name: str) -> float:
        return float(np.mean([row["rel"] for row in kinds[name]])) if name in kinds else np.nan

    def coverage(rows: list[dict], key: str = "covered") -> str:
        k, n = sum(r[key] for r in rows), sum(r["n_cover"] for r in rows)
        if n == 0:
            return "-"
        ci = binomtest(k, n).proportion_ci(0.95)  # exact (Clopper-Pearson)
        return f"{k / n:.3f} ({ci.low:.2f}-{ci.high:.2f})"

    def lr_range(rows: list[dict]) -> str:
        lr = np.array([row["hold_lr"] for row in rows], dtype=float)
        lr = lr[np.isfinite(lr)]
        return "-" if lr.size == 0 else " / ".join(f"{v:.2f}" for v in (
            lr.min(), np.median(lr), lr.max()))

    out = ["| fit | success | mean abs rel error [%] | x ekf-still | x oe-wind | x fe "
           "| max err/se | all within 3 se | coverage 95 % (exact 95 % CI) "
           "| the filtered se: within 3 se, coverage | refused by the hold test "
           "| hold LR (min / median / max) | wall [s] (median) | cpu [s] (median) |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, rows in kinds.items():
        rel = mean_rel(name)
        out.append(f"| {name} | {sum(row['success'] for row in rows)}/{len(rows)} | "
                   f"{rel:.3f} | {rel / mean_rel('ekf-still'):.2f} | "
                   f"{rel / mean_rel('oe-wind'):.2f} | {rel / mean_rel('fe'):.2f} | "
                   f"{max(row['zmax'] for row in rows):.2f} | "
                   f"{sum(row['within'] for row in rows)}/{len(rows)} | "
                   f"{coverage(rows)} | {sum(row['within_filtered'] for row in rows)}/"
                   f"{len(rows)}, {coverage(rows, 'covered_filtered')} | "
                   f"{sum(row['hold_refused'] for row in rows)}/{len(rows)} | "
                   f"{lr_range(rows)} | "
                   f"{np.median([row['wall'] for row in rows]):.1f} | "
                   f"{np.median([row['cpu'] for row in rows]):.1f} |")
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--turbulence", type=float, default=3.0)
    parser.add_argument("--fits", nargs="+", default=list(fits(3.0)))
    parser.add_argument("--holds", nargs="*", default=[],
                        help="NAME=FACTOR: also fit with NAME held at FACTOR x its truth")
    parser.add_argument("--steady", type=float, nargs=3, default=list(STEADY),
                        metavar=("N", "E", "D"), help="the steady wind [m/s] (0 0 0: none)")
    parser.add_argument("--given-sd", type=float, default=None,
                        help="the intensity the -given fits are told (default: the true one)")
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--write-to", default=None,
                        help="file name under benchmarks/results (default gust_filters.md)")
    args = parser.parse_args()
    kinds, lines = run(args.seeds, args.turbulence, tuple(args.fits), tuple(args.holds),
                       tuple(args.steady), args.given_sd)
    text = summary(kinds)
    print(text)
    if not args.no_write:
        out = RESULTS if args.write_to is None else RESULTS.parent / args.write_to
        out.parent.mkdir(exist_ok=True)
        out.write_text(
            f"# The EKF with gust states in Dryden turbulence ({dt.date.today()})\n\n"
            f"`python benchmarks/bench_gust_filters.py --seeds {args.seeds} --turbulence "
            f"{args.turbulence:g} --steady {' '.join(f'{v:g}' for v in args.steady)} --fits "
            f"{' '.join(args.fits)}"
            + (f" --write-to {args.write_to}" if args.write_to else "")
            + "` (one process, fits in turn)"
            f"\n\n{text}\n\nPer run:\n\n```\n" + "\n".join(lines) + "\n```\n")
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
