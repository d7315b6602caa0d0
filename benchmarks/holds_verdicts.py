"""How often a fit with held coefficients is refused, right and wrong (issue 25).

A held value is taken as known; when it is wrong, the model cannot fit the data and the
fit check should refuse the result; when it is right, the result should stand. Run by
hand from the repository root (one process)::

    python benchmarks/holds_verdicts.py --seeds 20 --methods output-error,equation-error,ekf

For each method and seed of the reference scenario (Gaussian tactical IMU noise, and the
paper's noise), fits with Czd and Cmd held at the truth (right) and Cmd held 5 % and 20 %
off (wrong), and prints the share of successes, of results warned that the method's free
fit contradicts a held value (equation-error only), and for the right fits the mean
|error| of the seven free coefficients against the truth in their own standard errors.
"""

from __future__ import annotations

import argparse

import numpy as np

import aeroid
from aeroid.estimation import CoefficientSpec
from aeroid.flights import GaussianNoise, PaperNoise, reference_scenario, simulate
from aeroid.model import NAMES


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--methods", default="output-error,equation-error,ekf")
    args = parser.parse_args()
    scenario = reference_scenario()
    truth = scenario.coefficient_vector
    czd, cmd = NAMES.index("Czd"), NAMES.index("Cmd")
    free = [j for j in range(len(NAMES)) if j not in (czd, cmd)]
    cases = {"right": {"Czd": truth[czd], "Cmd": truth[cmd]},
             "Cmd +5%": {"Czd": truth[czd], "Cmd": 1.05 * truth[cmd]},
             "Cmd +20%": {"Czd": truth[czd], "Cmd": 1.2 * truth[cmd]}}
    for noise_name, noise in (("gaussian", GaussianNoise()), ("paper", PaperNoise())):
        flights = [simulate(scenario.airframe, truth, scenario.manoeuvre, noise, rng=seed)
                   for seed in range(args.seeds)]
        for method in args.methods.split(","):
            est = aeroid.make_estimator(method)
            for label, held in cases.items():
                ok, flagged, z = 0, 0, []
                for seed, flight in enumerate(flights):
                    res = est.fit(flight, rng=seed, holds=CoefficientSpec(held=held))
                    ok += bool(res.success)
                    flagged += any("contradicts the held" in w for w in res.warnings)
                    if label == "right" and res.stderr is not None:
                        z.append(np.abs(res.theta[free] - truth[free]) / res.stderr[free])
                extra = (f", mean |error| / se {np.mean(z):.2f}, 95th pct "
                         f"{np.percentile(z, 95):.2f}" if z else "")
                print(f"{noise_name:8s} {method:15s} {label:9s} success {ok}/{len(flights)}"
                      f", held value flagged {flagged}/{len(flights)}{extra}", flush=True)


if __name__ == "__main__":
    main()
