"""Measure a sounding rocket's flight-computer log, start to finish (issue 25).

Run by hand from the repository root (one process; ~1 min per seed)::

    python benchmarks/bench_rocket.py --seeds 5

Per seed (0..N-1): ``examples/make_rocket_log.py`` writes the coast of
``studies/scenarios/rocket_coast.toml`` logged by the flight computer (board long axis
along the sensor's -y, 100 Hz IMU with biases and scale factors, barometer pressure with
the board's temperature, GNSS positions only, the flight computer's attitude at 10 Hz, no
fin channel); the files are read back (``read_suite_log``), reconstructed, and the raw-IMU
flight is fitted by output-error with ``imu_errors = "bias+scale"`` and the initial
velocity estimated with the reconstruction's prior (the fin terms held at 0 by the passive
fin, every other coefficient free). Reported: the reconstruction's residual check, the
fit's success and ``|estimate - truth| / se`` of Cx, Cl0 and Clp. Then the same log
(the same readings) with a wrong but proper mounting, two signs flipped
(``x=y, y=-x, z=z``): whether the reconstruction refuses it (its residual check, or a
one-line error) and whether the fit is a success (it must not be). Results are printed
as a Markdown table.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
for path in (ROOT, ROOT / "examples"):
    if str(path) not in sys.path:
        sys.path.insert(0, str(path))

from make_rocket_log import SCENARIO, make_log  # noqa: E402

from aeroid.errors import AeroidError  # noqa: E402
from aeroid.flights import load_scenario, read_suite_log  # noqa: E402
from aeroid.model import NAMES  # noqa: E402
from aeroid.reconstruction import reconstruct  # noqa: E402
from baselines.output_error import OutputErrorEstimator  # noqa: E402

#: The coefficients the issue measures.
WATCHED = ("Cx", "Cl0", "Clp")
ESTIMATOR = OutputErrorEstimator(imu_errors="bias+scale", estimate_initial_velocity=True,
                                 initial_velocity_prior="flight")


def fit_log(path: Path) -> tuple[bool, Any]:
    """Reconstruct the log at ``path`` and fit its raw-IMU flight: (consistent, result).

    A reconstruction that stops with a one-line error (the wrong mounting can drive the
    attitude to the Euler singularity) is (False, None): refused, no fit.
    """
    try:
        rec = reconstruct(read_suite_log(path))
    except AeroidError as exc:
        print(f"  {path.parent.name}: reconstruction refused: {exc}", flush=True)
        return False, None
    consistent = all(c["consistent"] for c in rec.nis.values())
    return consistent, ESTIMATOR.fit(rec.to_flight(imu="raw"), rng=0)


def one(seed: int, folder: Path) -> dict[str, float]:
    """Run one seed (module docstring)."""
    truth = dict(zip(NAMES, load_scenario(SCENARIO).coefficient_vector, strict=True))
    consistent, res = fit_log(make_log(folder / f"right-{seed}", seed, verbose=False))
    out: dict[str, float] = {"right_consistent": float(consistent),
                             "success": float(res.success)}
    names = list(res.names)
    for name in WATCHED:
        j = names.index(name)
        out[f"z_{name}"] = float(abs(res.theta[j] - truth[name]) / res.stderr[j])
    held = sorted(res.held) if getattr(res, "held", None) else []
    out["held_fin_terms"] = float(held == ["Cmd", "Czd"])
    wrong_consistent, wrong = fit_log(make_log(folder / f"wrong-{seed}", seed,
                                               wrong_mounting=True, verbose=False))
    out.update(wrong_refused=float(not wrong_consistent),
               wrong_success=float(wrong is not None and wrong.success))
    return out


def main() -> None:
    """Run the seeds and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.seeds):
            rows.append(one(seed, Path(tmp)))
            print(f"seed {seed}: {rows[-1]}", flush=True)
    n = len(rows)

    def total(key: str) -> int:
        return int(sum(r[key] for r in rows))

    print(f"\n| {n} seeds | result |\n|---|---|")
    print(f"| right mounting: reconstruction's residual check consistent | "
          f"{total('right_consistent')} of {n} |")
    print(f"| output-error: success | {total('success')} of {n} |")
    print(f"| fin terms Czd, Cmd reported as held | {total('held_fin_terms')} of {n} |")
    for name in WATCHED:
        z = np.array([r[f"z_{name}"] for r in rows])
        print(f"| {name}: within 3 se | {int(np.sum(z < 3.0))} of {n} (largest "
              f"|error|/se {z.max():.2f}) |")
    print(f"| wrong mounting (x=y, y=-x): reconstruction refuses | {total('wrong_refused')} "
          f"of {n} |")
    print(f"| wrong mounting: output-error success | {total('wrong_success')} of {n} |")


if __name__ == "__main__":
    main()
