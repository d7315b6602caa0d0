"""Equation-error's roll row collected in the fit's own pass, against the extra pass before.

Run by hand from the repository root::

    nice -n 10 python benchmarks/bench_ee_roll_pass.py               # 7 rounds, prints
    nice -n 10 python benchmarks/bench_ee_roll_pass.py --write       # and writes the results

Before (``baselines._ee_roll.roll_window_blocks`` until this change): every fit made one
full pass over the regressor blocks to collect the roll-moment row, windowed or not. Now
(:class:`baselines._ee_roll.RollBlocks`) the fit's own first pass collects it where the row
is not windowed (no air-data wind). Both are timed in one session, alternating (before,
after) in each round, on one flight of the reference scenario (the paper's noise, seed 1)
with equation-error's defaults, and on its ``smoothing="both"`` form; the results must be
bit-identical (asserted: estimate, standard errors, covariance, cost). Reported: the
median fit time of each and the time of one pass over the blocks alone.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from unittest import mock

import numpy as np
from _before_after import assert_same_result, measured, timed_fit

import baselines.equation_error as ee
from aeroid import estimation as rc
from aeroid.flights import PaperNoise, load_scenario, simulate_scenario
from baselines._ee_roll import ROLL_ROW, through_roll_window

RESULTS = Path(__file__).parent / "results" / "ee_roll_pass.md"
#: The forms timed: equation-error's defaults (per-sample loads, ``smoothing="none"``), and
#: its smoothed regressors (``smoothing="both"``: each block with its neighbours' halo).
FORMS = (("defaults (smoothing none)", {}), ("smoothing both", {"smoothing": "both"}))


def before(flight, wind, blocks: Callable) -> Callable[[], Iterator]:
    """``roll_window_blocks`` as it was: one pass to collect the roll row, on every fit."""
    windowed = wind is not None and bool(np.any(np.ptp(wind, axis=0) > 0))
    row = np.concatenate([part[:, ROLL_ROW, :] for _, _, part in blocks()], axis=0)
    seen = through_roll_window(flight, row) if windowed else row

    def replaced() -> Iterator:
        for start, stop, part in blocks():
            if windowed:
                part = np.array(part, dtype=float)
                part[:, ROLL_ROW, :] = seen[start:stop]
            yield start, stop, part

    replaced.roll_row = seen  # type: ignore[attr-defined]
    return replaced


def _fit(flight, options: dict, old: bool):
    patch = mock.patch.object(ee, "roll_window_blocks", before) if old else None
    return timed_fit(ee.EquationErrorEstimator(**options), flight, patch)


def measure(rounds: int) -> list[str]:
    flight = simulate_scenario(load_scenario(None), PaperNoise(), rng=1)
    lines = ["| form | before [s] | after [s] | saved [s] | one pass over the blocks [s] |",
             "|---|---:|---:|---:|---:|"]
    for label, options in FORMS:
        # and warms up
        assert_same_result(_fit(flight, options, True)[0], _fit(flight, options, False)[0])
        times: dict[bool, list[float]] = {True: [], False: []}
        for _ in range(rounds):
            for old in (True, False):
                result, seconds = _fit(flight, options, old)
                times[old].append(seconds)
        assert_same_result(_fit(flight, options, True)[0], result)
        smoothing = options.get("smoothing", ee.EquationErrorEstimator().smoothing)
        window = rc.reconstruct(flight).smoothing_window
        passes = []
        for _ in range(rounds):
            start = time.perf_counter()
            for _ in rc.regressor_blocks(flight, smoothing=smoothing, window=window,
                                         block=ee.BLOCK_SAMPLES):
                pass
            passes.append(time.perf_counter() - start)
        old, new = statistics.median(times[True]), statistics.median(times[False])
        lines.append(f"| {label} | {old:.3f} | {new:.3f} | {old - new:.3f} | "
                     f"{statistics.median(passes):.4f} |")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--write", action="store_true", help=f"write {RESULTS.name}")
    args = parser.parse_args(argv)
    measured("Equation-error: the roll row in the fit's own pass",
             lambda: measure(args.rounds), RESULTS, args.write,
             f"Reference scenario, paper's noise, seed 1; median of {args.rounds} fits each, "
             "before and after alternating; results bit-identical (asserted).")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
