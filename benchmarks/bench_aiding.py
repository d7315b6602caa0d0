"""Benchmark GNSS velocity in output-error's likelihood (``aiding = "gnss-velocity"``).

Run by hand from the repository root (one process)::

    python benchmarks/bench_aiding.py --seeds 10

For each seed: the reference window (5-6 s) logged by the default
:class:`~aeroid.flights.SensorSuite` (1000 Hz IMU with biases and scale factors, GNSS 10 Hz
with 0.1 m/s velocity sd, barometer, wrapped INS), reconstructed, and its
``to_flight(imu="raw", aiding=True)`` fitted by output-error with ``imu_errors =
"bias+scale"`` and ``estimate_initial_velocity``:

- ``IMU only, velocity prior``: ``initial_velocity_prior = "flight"`` (README's route);
- ``GNSS in, velocity prior``: the same with ``aiding = "gnss-velocity"`` (the prior and
  the GNSS share information: the reconstruction used the same GNSS samples);
- ``GNSS in, velocity free``: ``aiding`` without the prior (no information counted twice);
- ``GNSS 50 ms late, undeclared`` and ``GNSS 200 ms late, undeclared``: the last fit with
  the GNSS times moved (known-wrong inputs: how often the fit check refuses them).

With ``--ins``, instead: GNSS velocity alone against GNSS velocity and the INS attitude
(``aiding = "gnss-velocity+ins-attitude"``, velocity free), and the INS 50 ms late,
undeclared (written to ``benchmarks/results/aiding_ins.md``)::

    python benchmarks/bench_aiding.py --seeds 5 --ins

(``--filters --ins``: the same comparison for the EKF and UKF, written to
``benchmarks/results/aiding_filters_ins.md``.)

With ``--filters``, instead: the EKF and the UKF (``imu_errors = "bias+scale"``, their
initial sd from the reconstruction) without and with ``aiding``, and the EKF with the GNSS
50 and 200 ms late (written to ``benchmarks/results/aiding_filters.md``)::

    python benchmarks/bench_aiding.py --seeds 20 --filters

With ``--skew``, instead: output-error estimating the aiding groups' time skew
(``estimate_skew``, velocity free): the GNSS 50 ms late (undeclared) with its skew free, the
INS 50 ms late with its skew free and the INS and GNSS as logged with both free (the
correct fit's refusal rate with the option on; written to
``benchmarks/results/aiding_skew.md``)::

    python benchmarks/bench_aiding.py --seeds 10 --skew

Figures per fit: successes, mean |relative error| of the coefficients, Cx's relative
error and standard error, the correlation of Cx with the axial biases ``bax1``, ``bax2``,
the largest ``|error| / se`` over the coefficients, biases and scale factors, the
median se of the accelerometer and gyro biases. Printed and written to
``benchmarks/results/aiding.md``.
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from aeroid.flights import (  # noqa: E402
    Flight,
    SensorSuite,
    make_flight,
    reference_scenario,
    simulate_suite,
)
from aeroid.model import OUTPUT_CHANNELS  # noqa: E402
from aeroid.reconstruction import reconstruct  # noqa: E402
from baselines.output_error import OutputErrorEstimator  # noqa: E402

BASE = {"imu_errors": "bias+scale", "estimate_initial_velocity": True}
FITS = {
    "IMU only, velocity prior": ({**BASE, "initial_velocity_prior": "flight"}, 0.0),
    "GNSS in, velocity prior": ({**BASE, "initial_velocity_prior": "flight",
                                 "aiding": "gnss-velocity"}, 0.0),
    "GNSS in, velocity free": ({**BASE, "aiding": "gnss-velocity"}, 0.0),
    "GNSS 50 ms late, undeclared": ({**BASE, "aiding": "gnss-velocity"}, 0.05),
    "GNSS 200 ms late, undeclared": ({**BASE, "aiding": "gnss-velocity"}, 0.2),
}

BOTH = {**BASE, "aiding": "gnss-velocity+ins-attitude"}
INS_FITS = {
    "GNSS in, velocity free": ({**BASE, "aiding": "gnss-velocity"}, 0.0),
    "GNSS + INS in, velocity free": (BOTH, 0.0),
    "GNSS + INS, INS 50 ms late, undeclared": (BOTH, ("ins", 0.05)),
}


SKEW_FITS = {
    "GNSS 50 ms late, GNSS skew free": ({**BASE, "aiding": "gnss-velocity",
                                         "estimate_skew": "gnss"}, 0.05),
    "INS 50 ms late, INS skew free": ({**BOTH, "estimate_skew": "ins"}, ("ins", 0.05)),
    "both as logged, both skews free": ({**BOTH, "estimate_skew": "gnss+ins"}, 0.0),
}


FILTER_BASE = {"imu_errors": "bias+scale"}
FILTERS = {
    "EKF, IMU only": ("ekf", FILTER_BASE, 0.0),
    "EKF, GNSS in": ("ekf", {**FILTER_BASE, "aiding": "gnss-velocity"}, 0.0),
    "UKF, IMU only": ("ukf", FILTER_BASE, 0.0),
    "UKF, GNSS in": ("ukf", {**FILTER_BASE, "aiding": "gnss-velocity"}, 0.0),
    "EKF, GNSS 50 ms late, undeclared": ("ekf", {**FILTER_BASE, "aiding": "gnss-velocity"},
                                         0.05),
    "EKF, GNSS 200 ms late, undeclared": ("ekf", {**FILTER_BASE, "aiding": "gnss-velocity"},
                                          0.2),
}


FILTER_BOTH = {**FILTER_BASE, "aiding": "gnss-velocity+ins-attitude"}
INS_FILTERS = {
    "EKF, GNSS in": ("ekf", {**FILTER_BASE, "aiding": "gnss-velocity"}, 0.0),
    "EKF, GNSS + INS in": ("ekf", FILTER_BOTH, 0.0),
    "UKF, GNSS in": ("ukf", {**FILTER_BASE, "aiding": "gnss-velocity"}, 0.0),
    "UKF, GNSS + INS in": ("ukf", FILTER_BOTH, 0.0),
    "EKF, GNSS + INS, INS 50 ms late, undeclared": ("ekf", FILTER_BOTH, ("ins", 0.05)),
}


def skewed(flight: Flight, late: float | tuple[str, float]) -> Flight:
    """``flight`` whose GNSS (or ``(source, late_s)``: that source's) samples are labelled
    ``late_s`` earlier than they were taken (an undeclared skew), those outside the flight
    left out."""
    source, late_s = late if isinstance(late, tuple) else ("gnss", late)
    if not late_s:
        return flight
    group = flight.metadata["aiding"][source]
    t = np.asarray(group["t"]) - late_s
    keep = t >= flight.t[0] - 1e-9
    moved = {**group, "t": t[keep], **{c: np.asarray(v)[keep] for c, v in group.items()
                                       if c not in ("t", "sd", "source")}}
    return make_flight({c: flight[c] for c in flight.channels}, flight.airframe,
                       {**flight.metadata,
                        "aiding": {**flight.metadata["aiding"], source: moved}})


def _errors_truth(errors: dict[str, np.ndarray]) -> dict[str, float]:
    values = np.concatenate([errors["accel_bias"].ravel(), errors["gyro_bias"],
                             errors["accel_scale"].ravel(), errors["gyro_scale"]])
    names = [f"{p}{c}" for p in ("b", "s") for c in OUTPUT_CHANNELS]
    return dict(zip(names, values.tolist(), strict=True))


def one_seed(seed: int, filters: bool = False, ins: bool = False, skew: bool = False
             ) -> dict[str, dict[str, float]]:
    """All fits of one seed (output-error's, or with ``filters`` the EKF's and UKF's, with
    ``ins`` output-error's with and without the INS)."""
    from aeroid.estimation import make_estimator

    scenario = reference_scenario()
    truth = scenario.coefficient_vector
    sim = simulate_suite(scenario.airframe, truth, scenario.manoeuvre, SensorSuite(), rng=seed)
    raw = reconstruct(sim.log).to_flight(imu="raw", aiding=True)
    errors = _errors_truth(sim.errors)
    out = {}
    fits = ({k: (make_estimator(m, o), late)
             for k, (m, o, late) in (INS_FILTERS if ins else FILTERS).items()}
            if filters else {k: (OutputErrorEstimator(**o), late) for k, (o, late) in (
                SKEW_FITS if skew else INS_FITS if ins else FITS).items()})
    for label, (est, late) in fits.items():
        start = time.perf_counter()
        res = est.fit(skewed(raw, late), rng=seed)
        corr = {"bax1": np.nan, "bax2": np.nan}
        if "parameter_covariance" in res.info:  # output-error's (the filters' P: not kept)
            names = list(res.info["parameter_names"])
            cov = res.info["parameter_covariance"]
            sd = np.sqrt(np.diag(cov))
            corr = {b: cov[0, names.index(b)] / (sd[0] * sd[names.index(b)])
                    for b in ("bax1", "bax2")}
        bias_se = res.info["imu_error_stderr"]
        z = {n: abs(v - errors[n]) / bias_se[n] for n, v in res.info["imu_errors"].items()}
        out[label] = {"success": float(res.success), "wall_s": time.perf_counter() - start,
                      "mean_rel": float(np.mean(np.abs(res.theta / truth - 1.0))),
                      "cx_rel": float(res.theta[0] / truth[0] - 1.0),
                      "cx_se": float(res.stderr[0] / abs(truth[0])),
                      "corr1": corr["bax1"], "corr2": corr["bax2"],
                      "max_z": float(np.max(np.abs(res.theta - truth) / res.stderr)),
                      "bias_z": max(v for n, v in z.items() if n[0] == "b"),
                      "scale_z": max(v for n, v in z.items() if n[0] == "s"),
                      "accel_bias_se": float(np.median([v for n, v in bias_se.items()
                                                        if n[0] == "b" and n[1] == "a"])),
                      "gyro_bias_se": float(np.median([v for n, v in bias_se.items()
                                                       if n in ("bp", "bq", "br")])),
                      "message": res.message}
        if skew:
            truth_skew = dict([late if isinstance(late, tuple) else ("gnss", late)])
            for source, value in res.info["aiding_skew_s"].items():
                se = res.info["aiding_skew_stderr_s"][source]
                out[label][f"{source}_skew"] = value
                out[label][f"{source}_skew_se"] = se
                out[label][f"{source}_skew_z"] = (value - truth_skew.get(source, 0.0)) / se
    return out


def main() -> None:
    """Run the seeds, print and write the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="seeds 0..N-1")
    parser.add_argument("--filters", action="store_true",
                        help="the EKF and UKF instead of output-error")
    parser.add_argument("--ins", action="store_true",
                        help="output-error with GNSS velocity alone and with the INS attitude")
    parser.add_argument("--skew", action="store_true",
                        help="output-error estimating the GNSS and INS time skews")
    args = parser.parse_args()
    if args.skew:
        return skew_main(args.seeds)
    labels = ((INS_FILTERS if args.ins else FILTERS) if args.filters
              else INS_FITS if args.ins else FITS)
    runs = []
    for seed in range(args.seeds):
        runs.append(one_seed(seed, args.filters, args.ins))
        print(f"seed {seed}: " + "; ".join(
            f"{k}: {'ok' if r['success'] else 'refused'} Cx se {100 * r['cx_se']:.3f} % corr "
            f"{r['corr2']:+.4f} max z {r['max_z']:.2f}/{r['bias_z']:.2f}/{r['scale_z']:.2f}"
            for k, r in runs[-1].items()), flush=True)
    flag = (" --filters" if args.filters else "") + (" --ins" if args.ins else "")
    lines = [f"# GNSS velocity{' and INS attitude' if args.ins else ''} in "
             f"{'the filters' if args.filters else 'output-error'}"
             f"{chr(39) if args.filters else chr(39) + 's'} likelihood", "",
             f"`python benchmarks/bench_aiding.py --seeds {args.seeds}{flag}` on "
             f"{platform.processor() or platform.machine()}, Python "
             f"{platform.python_version()}, numpy {np.__version__}; reference window 5-6 s, "
             f"default suite, seeds 0-{args.seeds - 1}.", "",
             "| fit | succeeded | mean rel. error | Cx RMS rel. error | Cx rel. se (median) | "
             "corr(Cx, bax1) (median) | corr(Cx, bax2) (median) | max coefficient \\|z\\| | "
             "max bias \\|z\\| | max scale \\|z\\| | accel bias se [m/s²] (median) | "
             "gyro bias se [rad/s] (median) | wall time per fit [s] (median) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for label in labels:
        rows = [r[label] for r in runs]
        lines.append(
            f"| {label} | {int(sum(r['success'] for r in rows))} of {len(rows)} | "
            f"{100 * np.mean([r['mean_rel'] for r in rows]):.3f} % | "
            f"{100 * np.sqrt(np.mean([r['cx_rel'] ** 2 for r in rows])):.3f} % | "
            f"{100 * np.median([r['cx_se'] for r in rows]):.3f} % | "
            f"{np.median([r['corr1'] for r in rows]):+.4f} | "
            f"{np.median([r['corr2'] for r in rows]):+.4f} | "
            f"{max(r['max_z'] for r in rows):.2f} | {max(r['bias_z'] for r in rows):.2f} | "
            f"{max(r['scale_z'] for r in rows):.2f} | "
            f"{np.median([r['accel_bias_se'] for r in rows]):.3g} | "
            f"{np.median([r['gyro_bias_se'] for r in rows]):.3g} | "
            f"{np.median([r['wall_s'] for r in rows]):.1f} |")
    refused = [f"seed {s} {k}: {r[k]['message']}" for s, r in enumerate(runs) for k in labels
               if not r[k]["success"]]
    lines += ["", "Refusals:", ""] + [f"- {line}" for line in refused or ["none"]]
    print("\n".join(lines))
    out = ROOT / "benchmarks" / "results" / (
        "aiding" + ("_filters" if args.filters else "") + ("_ins" if args.ins else "") + ".md")
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}")


def skew_main(seeds: int) -> None:
    """``--skew``: each fit's successes, skews against the truth, coefficients' worst z."""
    runs: list[dict[str, dict[str, float]]] = []
    for seed in range(seeds):
        runs.append(one_seed(seed, skew=True))
        skew_table(runs)
        print(f"seed {seed}: " + "; ".join(
            f"{k}: {'ok' if r['success'] else 'refused'} " + " ".join(
                f"{s} {1e3 * r[s + '_skew']:+.2f}+-{1e3 * r[s + '_skew_se']:.2f} ms"
                for s in ("gnss", "ins") if s + "_skew" in r) + f" max z {r['max_z']:.2f}"
            for k, r in runs[-1].items()), flush=True)


def skew_table(runs: list[dict[str, dict[str, float]]]) -> None:
    """Write ``benchmarks/results/aiding_skew.md`` from the seeds run so far."""
    seeds = len(runs)
    lines = ["# Output-error estimating the aiding groups' time skew", "",
             f"`python benchmarks/bench_aiding.py --seeds {seeds} --skew` on "
             f"{platform.processor() or platform.machine()}, Python "
             f"{platform.python_version()}, numpy {np.__version__}; reference window 5-6 s, "
             f"default suite, raw IMU with imu_errors=bias+scale, initial velocity free, "
             f"seeds 0-{seeds - 1}.", "",
             "| fit | succeeded | skew | skew estimate [ms] (mean) | skew se [ms] (median) | "
             r"\|skew - truth\| / se (max) | within 3 se | mean rel. error | "
             r"max coefficient \|z\| | wall time per fit [s] (median) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for label in SKEW_FITS:
        rows = [r[label] for r in runs]
        for source in ("gnss", "ins"):
            if source + "_skew" not in rows[0]:
                continue
            z = np.abs([r[source + "_skew_z"] for r in rows])
            lines.append(
                f"| {label} | {int(sum(r['success'] for r in rows))} of {len(rows)} | "
                f"{source} | {1e3 * np.mean([r[source + '_skew'] for r in rows]):+.2f} | "
                f"{1e3 * np.median([r[source + '_skew_se'] for r in rows]):.3g} | "
                f"{np.max(z):.2f} | {int(np.sum(z < 3))} of {len(rows)} | "
                f"{100 * np.mean([r['mean_rel'] for r in rows]):.3f} % | "
                f"{max(r['max_z'] for r in rows):.2f} | "
                f"{np.median([r['wall_s'] for r in rows]):.1f} |")
    refused = [f"seed {s} {k}: {r[k]['message']}" for s, r in enumerate(runs) for k in SKEW_FITS
               if not r[k]["success"]]
    lines += ["", "Refusals:", ""] + [f"- {line}" for line in refused or ["none"]]
    print("\n".join(lines))
    out = ROOT / "benchmarks" / "results" / "aiding_skew.md"
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
