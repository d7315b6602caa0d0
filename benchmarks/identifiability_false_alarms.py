"""How often the record check names a coefficient of a normal flight (issue 25).

:func:`aeroid.estimation.record_findings` names coefficients a record cannot determine
(no fin motion, no pitch or yaw rate, a constant roll rate). On the reference scenario's
flights, which determine all nine, every such name is a false alarm. Run by hand from the
repository root (one process, seconds)::

    python benchmarks/identifiability_false_alarms.py --seeds 50

Prints, per noise model, the flights with a finding, and the smallest margin of each
test over the seeds (the statistic divided by its limit: above 1 means not named), then
the same on records that must be named (the fin at zero, and three fits of it with all
nine free; q and r noise alone; p / V constant).
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from aeroid.estimation import make_estimator, record_findings
from aeroid.estimation._identifiability import (
    FIN_MOTION_RAD,
    RATE_SNR,
    ROLL_VARIATION,
)
from aeroid.estimation._signals import estimate_noise_sd
from aeroid.flights import GaussianNoise, NoNoise, PaperNoise, reference_scenario, simulate


def margins(flight) -> tuple[float, float, float]:
    """Return (fin, rates, roll) statistic / limit of the three record tests."""
    fin = float(np.ptp(flight["delta"])) / FIN_MOTION_RAD
    q, r = flight["q"], flight["r"]
    noise = estimate_noise_sd(np.column_stack([q, r]), floor_fraction=0.0)
    rates = float(np.sqrt(np.mean(q * q + r * r))) / (RATE_SNR * float(np.linalg.norm(noise)))
    t = flight.t - flight.t.mean()
    x = flight["p"] / np.sqrt(flight["u"] ** 2 + flight["v"] ** 2 + flight["w"] ** 2)
    trend = np.polyval(np.polyfit(t, x, 3), t)
    roll = float(np.std(trend) / abs(np.mean(trend))) / ROLL_VARIATION
    return fin, rates, roll


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=50)
    args = parser.parse_args()
    scenario = reference_scenario()
    theta = scenario.coefficient_vector
    for label, noise in (("none", NoNoise()), ("gaussian", GaussianNoise()),
                         ("paper", PaperNoise())):
        named, worst = 0, np.full(3, np.inf)
        seeds = 1 if label == "none" else args.seeds
        for seed in range(seeds):
            flight = simulate(scenario.airframe, theta, scenario.manoeuvre, noise, rng=seed)
            named += bool(record_findings(flight))
            worst = np.minimum(worst, margins(flight))
        print(f"reference flight, noise {label}: {named} of {seeds} flights with a finding; "
              f"smallest margins fin {worst[0]:.3g}, rates {worst[1]:.3g}, roll {worst[2]:.3g}")
    # records that must be named: the fin at zero (its terms zero in the truth, so the
    # data are consistent), and a pure roll without fin motion (q = r = 0)
    zero_fin = theta.copy()
    zero_fin[[2, 7]] = 0.0
    flight = simulate(scenario.airframe, zero_fin, scenario.manoeuvre, GaussianNoise(), rng=0)
    meta = {k: v for k, v in flight.metadata.items()
            if k not in ("delta_knots", "command_switches")}
    still = dataclasses.replace(flight, data=flight.data.assign(delta=0.0), metadata=meta,
                                airframe=flight.airframe.replace(fin_law=None))
    print("fin at zero (Gaussian):", [f.names for f in record_findings(still)])
    for name in ("output-error", "equation-error", "ekf"):
        res = make_estimator(name).fit(still, rng=0)
        print(f"  {name}, all nine free: success {res.success}; not identifiable "
              f"{sorted(res.info.get('not_identifiable', {}))}; {res.message[:90]}")
    # the same log with q and r replaced by their noise alone, and with p held constant
    rng = np.random.default_rng(0)
    quiet = flight.data.assign(q=0.005 * rng.standard_normal(flight.n_samples),
                               r=0.005 * rng.standard_normal(flight.n_samples))
    print("q, r noise only:", [f.names for f in record_findings(
        dataclasses.replace(flight, data=quiet))])
    speed = np.sqrt(flight["u"] ** 2 + flight["v"] ** 2 + flight["w"] ** 2)
    steady = flight.data.assign(p=50.0 * speed / speed.mean())
    print("p / V constant:", [f.names for f in record_findings(
        dataclasses.replace(flight, data=steady))])

if __name__ == "__main__":
    main()
