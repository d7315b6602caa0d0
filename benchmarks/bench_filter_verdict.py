"""How often the filters' passes verdict refuses a correct still-air fit (issue 26).

Run by hand from the repository root (one process, the fits in turn)::

    python benchmarks/bench_filter_verdict.py --method ekf --seeds 12
    python benchmarks/bench_filter_verdict.py --method ukf --seeds 6

Per seed ``k`` (``rng = k``): the reference scenario's still-air flight with Gaussian IMU
noise and with the paper's noise (:func:`aeroid.flights.make_noise`), fitted with the
method's defaults (no wind states: the model is right). Prints per fit whether it passed,
the largest |error| / se, the largest move of the last pass in se
(``info['last_pass_moves_se']``, :mod:`baselines._kalman_verdict`), and per noise model
how many fits were refused and how many by the passes' verdict. Nothing is written.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # shared 2-core machine
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402

import numpy as np  # noqa: E402

import aeroid  # noqa: E402
from aeroid.flights import make_noise, reference_scenario, simulate  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", default="ekf")
    parser.add_argument("--seeds", type=int, default=12)
    args = parser.parse_args()
    s = reference_scenario()
    truth = s.coefficient_vector
    for noise in ("gaussian", "paper"):
        refused = by_verdict = 0
        moves = []
        for seed in range(1, args.seeds + 1):
            flight = simulate(s.airframe, truth, s.manoeuvre, make_noise(noise), rng=seed)
            r = aeroid.make_estimator(args.method).fit(flight, rng=seed)
            z = float(np.max(np.abs(r.theta - truth) / r.stderr))
            move = max(r.info.get("last_pass_moves_se", {"": 0.0}).values())
            moves.append(move)
            refused += not r.success
            by_verdict += r.message.startswith("the filter's passes did not settle")
            print(f"{noise} seed {seed} success={r.success} max z={z:.2f} last move "
                  f"{move:.2f} se passes {r.info.get('passes')} {r.message[:70]}", flush=True)
        print(f"{args.method} {noise}: {refused}/{args.seeds} refused, {by_verdict}/"
              f"{args.seeds} by the passes' verdict; largest last move {max(moves):.2f} se",
              flush=True)


if __name__ == "__main__":
    main()
