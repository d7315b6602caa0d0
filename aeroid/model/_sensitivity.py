"""Central-difference sensitivities of a forward model's outputs, in blocks of time.

For parameters ``(theta_j for j in coefficients, x0_i for i in free_states)`` the
sensitivities ``d y_kc / d param`` are central differences of the model's outputs: two
perturbed trajectories per parameter (``+step``, ``-step``), integrated once over the
record. A long record is cut into blocks of consecutive samples; each block integrates
the perturbed trajectories on from the previous block's last state with the same inputs
(the deflection's pieces and the exogenous table of those intervals), so the numbers
equal those of one pass over the record, bit for bit (tests/unit/test_sensitivity_blocks.py),
and memory is that of one block whatever the record's length. The methods
:meth:`aeroid.model.ForwardModel.sensitivities` (the whole matrix) and
:meth:`~aeroid.model.ForwardModel.sensitivity_blocks` (the blocks, for a sum over the
samples such as the Fisher information) are the faces of this module.

The relative step (:data:`DEFAULT_REL_STEP`, 1e-5, the Cramér-Rao floor's decision):
Measured against a 4-point stencil (steps 1e-4 and 3e-4 agree to 6e-8) on the reference
flight, the error is at most 4e-7 of each column's largest entry (Czq's column; 1e-8 or
less for the others); relative steps of 1e-6 and 1e-7 are worse (rounding: 2e-6, 1e-5),
1e-4 and 1e-3 too (truncation on Cl0, Clp, Cma). The resulting standard deviations
change by < 1e-6 relative between steps 1e-6 and 1e-4. Tests compare J with a closed
form at k = 0 and with a second stencil computed on the numpy backend.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from aeroid.model._coefficients import N_COEFFICIENTS, as_vector
from aeroid.model._dynamics import N_STATE, STATE_NAMES
from aeroid.model._inputs import Pieces, Record

#: Default relative step of the central-difference sensitivities (the floor's decision:
#: measured error <= 4e-7 of each column's largest entry on the reference flight).
DEFAULT_REL_STEP = 1e-5
#: Memory for the perturbed trajectories of one block in time [bytes]: 2400 samples of
#: the 24 trajectories of 9 coefficients and 3 free initial rates (the reference
#: flight's 501 samples: one block).
SENSITIVITY_BLOCK_BYTES = 32 * 2**20
#: Arrays of a trajectory's size (states and outputs) counted per trajectory of a block:
#: a margin for the accelerometer equations' temporaries (an allowance, not a
#: measurement; benchmarks/bench_memory.py measures the whole fit).
SENSITIVITY_TEMPORARIES = 4


def whole(model: Any, state0: np.ndarray, theta: np.ndarray, free_states: Sequence[str],
          rel_step: float, coefficients: Sequence[int] | None) -> np.ndarray:
    """Return the sensitivities of every sample, shape (n, m, n_par) (the blocks joined)."""
    parts = blocks(model, state0, theta, free_states, rel_step, coefficients, None)
    rows, first = next(parts)
    jac = np.empty((model.n_samples, *first.shape[1:]))
    jac[rows] = first
    for rows, part in parts:
        jac[rows] = part
    return jac


def blocks(model: Any, state0: np.ndarray, theta: np.ndarray, free_states: Sequence[str],
           rel_step: float, coefficients: Sequence[int] | None, block_samples: int | None
           ) -> Iterator[tuple[slice, np.ndarray]]:
    """Yield ``(samples, d y / d params)`` block by block: consecutive slices covering the
    record, arrays of shape (slice length, m, n_par); every block holds >= 2 samples (a
    record has two or more: a last block of one sample is merged into the one before).

    ``model`` is a :class:`aeroid.model.ForwardModel`; a block is the same model over
    its samples (``type(model)`` over the sliced record).
    """
    step, thetas, states = perturbed(state0, theta, free_states, rel_step, coefficients)
    n_par = step.size
    per_sample = 2 * n_par * 8 * SENSITIVITY_TEMPORARIES * (N_STATE + len(model.output_names))
    size = (max(2, SENSITIVITY_BLOCK_BYTES // per_sample) if block_samples is None
            else int(block_samples))
    if size < 2:
        raise ValueError(f"forward model: block_samples must be >= 2, got {block_samples}")
    return _blocks(model, step, thetas, states, size)


def _blocks(model: Any, step: np.ndarray, thetas: np.ndarray, states: np.ndarray,
            size: int) -> Iterator[tuple[slice, np.ndarray]]:
    record, n, n_par = model.record, model.n_samples, step.size
    lo = 0
    while lo < n:
        hi = n if n - (lo + size) < 2 else lo + size  # no last block of one sample
        stop = min(hi, n - 1)  # integrated to sample `stop`: the next block's start
        exo = None if record.exogenous is None else record.exogenous[lo:stop + 1]
        part = type(model)(model.const, Record(
            record.dt, record.delta[lo:stop + 1], Pieces(*(a[lo:stop] for a in record.pieces)),
            exo), model.positions, substeps=model.substeps, backend=model.backend)
        trajectories = part.states(states, thetas)
        y = part.outputs_of(trajectories, thetas)[:, :hi - lo]
        states = trajectories[:, -1]
        yield slice(lo, hi), np.moveaxis((y[:n_par] - y[n_par:]) / (2.0 * step[:, None, None]),
                                         0, -1)
        lo = hi


def perturbed(state0: np.ndarray, theta: np.ndarray, free_states: Sequence[str],
              rel_step: float, coefficients: Sequence[int] | None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the steps (n_par,), and the perturbed coefficients and initial states,
    (2 n_par, 9) each: rows ``j`` and ``n_par + j`` are parameter j's +/- step.

    The step of coefficient j is ``rel_step |theta_j|`` (``rel_step`` when theta_j = 0),
    that of a state component ``rel_step max(|x0_i|, 1)``.
    """
    theta = as_vector(np.asarray(theta, dtype=float))
    state0 = np.asarray(state0, dtype=float)
    if theta.shape != (N_COEFFICIENTS,) or state0.shape != (N_STATE,):
        raise ValueError(f"forward model: sensitivities need theta ({N_COEFFICIENTS},) and "
                         f"state0 ({N_STATE},), got {theta.shape} and {state0.shape}")
    if not (math.isfinite(rel_step) and 0 < rel_step < 1):
        raise ValueError(f"forward model: rel_step must be in (0, 1), got {rel_step}")
    unknown = [name for name in free_states if name not in STATE_NAMES]
    if unknown:
        raise ValueError(f"forward model: unknown state name(s) {unknown} "
                         f"(expected some of {', '.join(STATE_NAMES)})")
    idx = [STATE_NAMES.index(name) for name in free_states]
    coefs = list(range(N_COEFFICIENTS)) if coefficients is None else list(coefficients)
    n_coef = len(coefs)
    n_par = n_coef + len(idx)
    step = np.concatenate([rel_step * np.where(theta != 0, np.abs(theta), 1.0)[coefs],
                           rel_step * np.maximum(np.abs(state0[idx]), 1.0)])
    thetas = np.tile(theta, (2 * n_par, 1))
    states = np.tile(state0, (2 * n_par, 1))
    for j in range(n_par):
        for sign, row in ((1.0, j), (-1.0, n_par + j)):
            if j < n_coef:
                thetas[row, coefs[j]] += sign * step[j]
            else:
                states[row, idx[j - n_coef]] += sign * step[j]
    return step, thetas, states
