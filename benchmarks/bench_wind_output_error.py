"""Output-error (and the filters) in a steady wind (issue 26): the wind estimated against still air.

Run by hand from the repository root (one process, the fits in turn: ``--jobs 1``)::

    python benchmarks/bench_wind_output_error.py                 # 6 seeds, writes results
    python benchmarks/bench_wind_output_error.py --seeds 2 --no-write
    python benchmarks/bench_wind_output_error.py --seeds 40 --airspeed 0.5   # + airspeed
    python benchmarks/bench_wind_output_error.py --methods output-error ekf --seeds 6

``--methods``: the estimators to run (default output-error; ``ekf`` and ``ukf`` carry the
wind as three constant states, :mod:`baselines._kalman_wind`); with any other than
output-error alone the results go to ``results/wind_filters.md``.

Per seed ``k`` (``rng = k``): the reference scenario's flight with Gaussian IMU noise
(:class:`aeroid.flights.GaussianNoise` defaults: 0.05 m/s^2, 0.005 rad/s) in still air,
and the same manoeuvre in a steady wind of 5 m/s (default north 3, east 4, down 0 m/s:
3 m/s along the reference flight's path, 4 across it), no turbulence. Fits:

* ``still / off``: output-error (defaults) on the still-air flight: the yardstick;
* ``still / on``: with ``estimate_wind`` on the still-air flight (the option's cost; the
  second reading of "its still-air error");
* ``wind / off``: defaults on the windy flight: the known-wrong model, which the fit
  check must refuse;
* ``wind / on``: ``estimate_wind`` on the windy flight.

With ``--airspeed SD`` the same flights also log a probe's ``airspeed`` (the noise
model's ``airspeed_sd_mps = SD``, drawn after the IMU's noise, so the IMU channels are the
same to the bit) and two more fits use it as a measured output (``estimate_wind``,
``air_data = measured``): ``still / on + airspeed`` and ``wind / on + airspeed``. The
logged ``alpha`` and ``beta`` of those flights are set to the inertial angles
(``atan(w/u)``, ``asin(v/V)``: no vanes), so the airspeed is the only air-data channel.

Reported per fit kind: successes, the mean over seeds of the mean |relative error| of
the nine coefficients [%] and of their mean relative standard error, the largest |error|
/ se over coefficients (and wind components), and how many runs have every coefficient,
and every wind component, within 3 se. Then the ratios of the issue's target, each windy
fit against each still-air yardstick: the ratio of the mean errors over seeds with a
paired BCa bootstrap 95 % interval (:func:`scipy.stats.bootstrap`, resampling seeds), the
ratio of the mean relative se, and the ratio of the Cramér-Rao floors (:func:`floor_sd`:
output-error's own information at the truth with the true noise, on a noise-free
flight; checked against :func:`aeroid.estimation.cramer_rao_sd` for still / off).
Targets (issue 26): ``wind / on`` mean error <= 1.2x its still-air error, every
coefficient and wind component within 3 se; ``wind / off`` refused.
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

import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

import aeroid  # noqa: E402
from aeroid.estimation import cramer_rao_sd  # noqa: E402
from aeroid.flights import Wind, make_noise, reference_scenario, simulate  # noqa: E402
from aeroid.model import OUTPUT_CHANNELS, as_state, constants, equations  # noqa: E402
from baselines.output_error import OutputErrorEstimator  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "wind_output_error.md"
RESULTS_FILTERS = Path(__file__).parent / "results" / "wind_filters.md"
WITHIN_SE = 3.0
#: The fits: label -> (flight, options). ``+ airspeed`` only with ``--airspeed``.
FITS = {"still / off": ("still", {"estimate_wind": False}),  # off: said, not the default
        "still / on": ("still", {"estimate_wind": True}),
        "wind / off": ("wind", {"estimate_wind": False}),
        "wind / on": ("wind", {"estimate_wind": True})}
AIRSPEED_FITS = {
    "still / on + airspeed": ("still", {"estimate_wind": True, "air_data": "measured"}),
    "wind / on + airspeed": ("wind", {"estimate_wind": True, "air_data": "measured"})}
#: The issue's ratios: windy fit against still-air yardstick.
RATIOS = (("wind / on", "still / off"), ("wind / on", "still / on"),
          ("wind / on + airspeed", "still / off"),
          ("wind / on + airspeed", "still / on + airspeed"))
BOOTSTRAP_RESAMPLES = 9999


def inertial_angles(flight: aeroid.flights.Flight) -> aeroid.flights.Flight:
    """``flight`` with ``alpha, beta`` the inertial angles (what a log without vanes has)."""
    _, alpha, beta = equations.air_data(flight["u"], flight["v"], flight["w"])
    return dataclasses.replace(flight, data=flight.data.assign(alpha=alpha, beta=beta))


def flights(seed: int, wind: tuple[float, float, float], airspeed_sd: float) -> dict:
    """The still and windy flights of ``seed`` (with an airspeed channel when asked)."""
    s = reference_scenario()
    noise = make_noise("gaussian", airspeed_sd_mps=airspeed_sd)
    windy = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=wind))
    out = {air: simulate(s.airframe, s.coefficient_vector, m, noise, rng=seed)
           for air, m in (("still", s.manoeuvre), ("wind", windy))}
    return {air: inertial_angles(f) if airspeed_sd > 0 else f for air, f in out.items()}


def floor_sd(options: dict, wind: tuple[float, float, float], airspeed_sd: float
             ) -> tuple[np.ndarray, np.ndarray | None]:
    """Cramér-Rao sd of the coefficients (9,) and of the wind (3,) or None, at the truth.

    Output-error's own model and exact Jacobian (its :meth:`OutputErrorEstimator.problem`,
    the initial p, q, r free as in its fits) on the noise-free flight in ``wind``, each
    output weighted by the true noise: ``F = sum_k J_k' W J_k``, ``sd = sqrt(diag F^-1)``.
    """
    s = reference_scenario()
    m = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=wind))
    flight = simulate(s.airframe, s.coefficient_vector, m, make_noise("none"), rng=0)
    if airspeed_sd > 0:
        const = constants(flight.airframe)._replace(wind_n=wind[0], wind_e=wind[1],
                                                    wind_d=wind[2])
        speed = equations.air_data(*equations.air_velocity(as_state(flight.states()),
                                                           const))[0]
        flight = inertial_angles(dataclasses.replace(
            flight, data=flight.data.assign(airspeed=speed)))
    est = OutputErrorEstimator(**options)
    prob = est.problem(flight)
    model = prob.model
    names = list(est.parameter_names(model.position_free)) + list(
        getattr(model, "calibration", ()))
    p = np.zeros(model.scale.size)
    n_c = len(aeroid.NAMES)
    p[:n_c] = s.coefficient_vector / model.scale[:n_c]
    if options.get("estimate_wind"):
        i = names.index("wind_n")
        p[i:i + 3] = np.asarray(wind) / model.scale[i:i + 3]
    _, J = prob.residuals_jacobian(p)  # (m, n, n_p)
    noise = make_noise("gaussian")
    sd = np.concatenate([noise.output_sd(np.ones((1, len(OUTPUT_CHANNELS))))[0],
                         np.full(J.shape[0] - len(OUTPUT_CHANNELS), airspeed_sd)])
    fisher = np.einsum("jka,jkb,j->ab", J, J, 1.0 / sd**2)
    phys = np.sqrt(np.diag(np.linalg.inv(fisher))) * np.abs(model.scale)
    wind_sd = phys[names.index("wind_n"):names.index("wind_n") + 3] if options.get(
        "estimate_wind") else None
    return phys[:n_c], wind_sd


def run(seeds: int, wind: tuple[float, float, float], methods: tuple[str, ...] = (
        "output-error",), airspeed_sd: float = 0.0) -> tuple[dict, list[str]]:
    """Fit every kind on every seed; return per-kind rows and the per-run lines."""
    truth = reference_scenario().coefficient_vector
    fits = FITS | (AIRSPEED_FITS if airspeed_sd > 0 else {})
    kinds: dict = {(m, label): [] for m in methods for label in fits}
    lines = []
    for seed in range(1, seeds + 1):
        pair = flights(seed, wind, airspeed_sd)
        for (method, label), rows in kinds.items():
            air, options = fits[label]
            est = aeroid.make_estimator(method, options)
            start = time.perf_counter()
            r = est.fit(pair[air], rng=seed)
            wall = time.perf_counter() - start
            z = np.abs(r.theta - truth) / r.stderr
            rel = 100.0 * np.mean(np.abs(r.theta / truth - 1.0))
            zw, extra = np.zeros(0), ""
            if options.get("estimate_wind"):
                w_true = np.array(wind if air == "wind" else (0.0, 0.0, 0.0))
                w, w_sd = np.array(r.info["wind_ned_mps"]), np.array(r.info["wind_stderr_mps"])
                zw = np.abs(w - w_true) / w_sd
                extra = (f" wind {np.round(w, 2).tolist()} +- {np.round(w_sd, 3).tolist()}")
            zall = np.concatenate([z, zw])
            rows.append({"success": r.success, "rel": rel, "zmax": float(np.max(zall)),
                         "se": 100.0 * float(np.mean(r.stderr / np.abs(truth))),
                         "within": bool(np.all(zall < WITHIN_SE)),
                         "within_c": bool(np.all(z < WITHIN_SE)),
                         "within_w": bool(np.all(zw < WITHIN_SE)), "wall": wall})
            lines.append(f"seed {seed} {method} {label:22s} success={r.success} "
                         f"mean|err|={rel:.3f}% max z={np.max(zall):.2f} {wall:.1f}s{extra}"
                         + ("" if r.success else f" [{r.message[:90]}]"))
            print(lines[-1], flush=True)
    return kinds, lines


def table(kinds: dict) -> str:
    """The summary table (markdown)."""
    out = ["| method: flight / estimate_wind | success | mean abs rel error [%] | x still/off "
           "| mean rel se [%] | x still/off | max err/se | coefficients within 3 se "
           "| wind within 3 se | all within 3 se | wall [s] (median) |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for (method, label), rows in kinds.items():
        base = np.mean([row["rel"] for row in kinds[(method, "still / off")]])
        base_se = np.mean([row["se"] for row in kinds[(method, "still / off")]])
        rel = np.mean([row["rel"] for row in rows])
        se = np.mean([row["se"] for row in rows])
        wind_col = (f"{sum(row['within_w'] for row in rows)}/{len(rows)}"
                    if "/ on" in label else "-")
        out.append(f"| {method}: {label} | "
                   f"{sum(row['success'] for row in rows)}/{len(rows)} | {rel:.3f} | "
                   f"{rel / base:.2f} | {se:.3f} | {se / base_se:.2f} | "
                   f"{max(row['zmax'] for row in rows):.2f} | "
                   f"{sum(row['within_c'] for row in rows)}/{len(rows)} | {wind_col} | "
                   f"{sum(row['within'] for row in rows)}/{len(rows)} | "
                   f"{np.median([row['wall'] for row in rows]):.1f} |")
    return "\n".join(out)


def ratio_interval(num: np.ndarray, den: np.ndarray) -> tuple[float, float, float]:
    """``mean(num) / mean(den)`` over seeds and its paired BCa bootstrap 95 % interval."""
    def statistic(a: np.ndarray, b: np.ndarray, axis: int = -1) -> np.ndarray:
        return np.mean(a, axis=axis) / np.mean(b, axis=axis)

    res = stats.bootstrap((num, den), statistic, paired=True, vectorized=True,
                          n_resamples=BOOTSTRAP_RESAMPLES, method="BCa",
                          rng=np.random.default_rng(26))
    ci = res.confidence_interval
    return float(statistic(num, den)), float(ci.low), float(ci.high)


def floors(wind: tuple[float, float, float], airspeed_sd: float) -> dict:
    """The Cramér-Rao floors of every fit kind that estimates the model right (truth)."""
    fits = FITS | (AIRSPEED_FITS if airspeed_sd > 0 else {})
    out = {}
    for label, (air, options) in fits.items():
        if label == "wind / off":
            continue  # the wrong model: no floor at the truth
        w = wind if air == "wind" else (0.0, 0.0, 0.0)
        out[label] = floor_sd(options, w, airspeed_sd if "airspeed" in label else 0.0)
    return out


def ratio_table(kinds: dict, floor: dict, method: str = "output-error") -> str:
    """The issue's ratios: errors (bootstrap interval), se and Cramér-Rao floors."""
    truth = np.abs(reference_scenario().coefficient_vector)
    out = ["| windy fit / still-air yardstick | mean error ratio | 95 % interval (BCa, seeds) "
           "| mean rel se ratio | Cramér-Rao floor ratio |", "|---|---|---|---|---|"]
    for num, den in RATIOS:
        if (method, num) not in kinds or (method, den) not in kinds:
            continue
        a = np.array([row["rel"] for row in kinds[(method, num)]])
        b = np.array([row["rel"] for row in kinds[(method, den)]])
        r, lo, hi = ratio_interval(a, b)
        se = (np.mean([row["se"] for row in kinds[(method, num)]])
              / np.mean([row["se"] for row in kinds[(method, den)]]))
        fl = np.mean(floor[num][0] / truth) / np.mean(floor[den][0] / truth)
        out.append(f"| {num} / {den} | {r:.2f} | {lo:.2f}-{hi:.2f} | {se:.2f} | {fl:.2f} |")
    out += ["", "| fit (at the truth) | mean rel floor [%] | wind floor sd N, E, D [m/s] |",
            "|---|---|---|"]
    for label, (sd, wsd) in floor.items():
        wtxt = "-" if wsd is None else ", ".join(f"{v:.3g}" for v in wsd)
        out.append(f"| {label} | {100 * np.mean(sd / truth):.3f} | {wtxt} |")
    return "\n".join(out)


def floor_check() -> str:
    """The still / off floor against :func:`aeroid.estimation.cramer_rao_sd` (its numpy
    central-difference sensitivities, initial p, q, r free)."""
    mine = floor_sd({}, (0.0, 0.0, 0.0), 0.0)[0]
    ref = cramer_rao_sd(reference_scenario(), make_noise("gaussian"),
                        estimate_initial=("p", "q", "r")).to_numpy()
    return (f"Floor check (still / off against aeroid.estimation.cramer_rao_sd, initial p, q, r "
            f"free): largest relative difference {np.max(np.abs(mine / ref - 1.0)):.2e}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=6)
    parser.add_argument("--wind", type=float, nargs=3, default=(3.0, 4.0, 0.0),
                        metavar=("NORTH", "EAST", "DOWN"))
    parser.add_argument("--methods", nargs="+", default=["output-error"])
    parser.add_argument("--airspeed", type=float, default=0.0, metavar="SD_MPS",
                        help="also log an airspeed channel of this noise sd [m/s] and fit "
                             "it as a measured output (default 0: no airspeed channel)")
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    if args.airspeed < 0:
        parser.error(f"--airspeed must be >= 0 [m/s], got {args.airspeed}")
    if args.seeds < 2:
        parser.error(f"--seeds must be at least 2 (the bootstrap over seeds), got {args.seeds}")
    kinds, lines = run(args.seeds, tuple(args.wind), tuple(args.methods), args.airspeed)
    results = RESULTS if args.methods == ["output-error"] else RESULTS_FILTERS
    text = table(kinds)
    if "output-error" in args.methods:
        text += "\n\n" + ratio_table(kinds, floors(tuple(args.wind), args.airspeed))
        text += "\n\n" + floor_check()
    print(text)
    if not args.no_write:
        results.parent.mkdir(exist_ok=True)
        airspeed = f" --airspeed {args.airspeed:g}" if args.airspeed > 0 else ""
        results.write_text(
            f"# {', '.join(args.methods)} in a steady wind ({dt.date.today()})\n\n"
            f"`python benchmarks/bench_wind_output_error.py --methods {' '.join(args.methods)}"
            f" --seeds {args.seeds} --wind "
            f"{' '.join(f'{w:g}' for w in args.wind)}{airspeed}` (one process, fits in turn)"
            f"\n\n{text}\n\nPer run:\n\n```\n" + "\n".join(lines) + "\n```\n")
        print(f"wrote {results}")


if __name__ == "__main__":
    main()
