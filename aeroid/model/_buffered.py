"""CasADi functions evaluated on numpy buffers bound once (output-error and the filters)."""

from __future__ import annotations

from collections.abc import Sequence

import casadi as ca
import numpy as np


class Buffered:
    """Evaluate a CasADi function on numpy buffers bound once (``Function.buffer``).

    Converting CasADi's DM outputs to numpy cost as much as the evaluation itself
    (measured: 40 % of an output-error fit); here inputs and outputs are numpy arrays
    shared with CasADi, read and written in place. Every output must be dense.
    """

    def __init__(self, fun: ca.Function, inputs: Sequence[np.ndarray]) -> None:
        self.fun = fun
        # column-major nonzeros in a copy (``flatten`` always copies): ``set`` writes into
        # these buffers, and one that aliased the caller's array (``ravel`` of a
        # contiguous slice is a view) overwrote it - the filters' deflection at sample 0
        # became the last observed sample's after one pass
        self.inputs = [np.asarray(a, dtype=float).flatten(order="F") for a in inputs]
        self.outputs = [np.empty(fun.nnz_out(i)) for i in range(fun.n_out())]
        for i in range(fun.n_out()):
            if fun.nnz_out(i) != fun.numel_out(i):
                raise ValueError(f"{fun.name()}: output {i} is not dense")
        self.buffer, self.evaluate = fun.buffer()
        for i, a in enumerate(self.inputs):
            self.buffer.set_arg(i, memoryview(a))
        for i, r in enumerate(self.outputs):
            self.buffer.set_res(i, memoryview(r))

    def set(self, i: int, value: np.ndarray) -> None:
        """Replace input ``i`` (same shape as given at construction) in place."""
        self.inputs[i][:] = np.asarray(value, dtype=float).T.ravel()

    def __call__(self, p: np.ndarray) -> list[np.ndarray]:
        """Evaluate with input 0 set to ``p``; returns the output buffers (reused)."""
        self.inputs[0][:] = p
        self.evaluate()
        if self.buffer.ret() != 0:
            raise RuntimeError(f"{self.fun.name()}: evaluation failed")
        return self.outputs


__all__ = ["Buffered"]
