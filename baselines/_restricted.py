"""Output-error's Gauss-Newton over some of its parameters, the others fixed at a template.

Written once for the two users: held coefficients (:func:`baselines._held.held_fit`: the
free parameters fitted, the held ones at their values) and the staged start
(:func:`baselines._oe_warm.staged_start`: the axial force's coefficients fitted, every
other parameter at the start). The model is untouched: :class:`ReducedModel` maps the
fitted parameters into the full vector; the fit is mapped back (the fixed parameters'
Jacobian columns zero).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from baselines._gauss_newton import Fit, Problem, SmoothRegion

__all__ = ["ReducedModel", "restricted_fit", "restricted_problem"]


class ReducedModel:
    """An output model over the fitted parameters: ``y(p_kept) = model.y(full(p_kept))``.

    ``keep``: indices (or a bool mask) of the fitted parameters among the model's;
    ``template`` (n_p,): the full scaled vector whose other entries are the fixed values.
    """

    def __init__(self, model: Any, keep: np.ndarray, template: np.ndarray) -> None:
        self.model, self.keep, self.template = model, keep, template
        if hasattr(model, "smooth_region"):
            self.smooth_region = self._smooth_region
            self.edge_note = getattr(model, "edge_note", "at an edge of a smooth region")

    def full(self, p: np.ndarray) -> np.ndarray:
        """The full scaled vector (n_p,) of fitted parameters ``p``."""
        out = self.template.copy()
        out[self.keep] = p
        return out

    def outputs(self, p: np.ndarray) -> np.ndarray:
        return self.model.outputs(self.full(p))

    def outputs_jacobian(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        y, J = self.model.outputs_jacobian(self.full(p))
        return y, J[:, :, self.keep]

    def _smooth_region(self, p: np.ndarray) -> SmoothRegion:
        region = self.model.smooth_region(self.full(p))
        return SmoothRegion(*(np.asarray(a)[self.keep] for a in region))


def restricted_problem(prob: Problem, keep: np.ndarray, template: np.ndarray) -> Problem:
    """Return ``prob`` over the parameters ``keep``, the others at ``template`` (scaled);
    the priors' terms of the kept parameters kept."""
    return dataclasses.replace(
        prob, model=ReducedModel(prob.model, keep, template),
        prior_mean=None if prob.prior_mean is None else prob.prior_mean[keep],
        prior_weight=None if prob.prior_weight is None else prob.prior_weight[keep])


def restricted_fit(est: Any, prob: Problem, keep: np.ndarray, template: np.ndarray,
                   stop: Any = None) -> Fit:
    """Run ``est.gauss_newton`` over the parameters ``keep`` from ``template`` (full scaled
    vector, the others fixed there); return the fit in the full parameters (``p``,
    ``history_p``; the fixed parameters' Jacobian columns zero). ``stop``: Gauss-Newton's,
    None for none."""
    reduced = restricted_problem(prob, keep, template)
    model: ReducedModel = reduced.model  # type: ignore[assignment]
    fit = est.gauss_newton(reduced, np.asarray(template, dtype=float)[keep],
                           *(() if stop is None else (stop,)))
    J = np.zeros((*fit.J.shape[:2], template.size))
    J[:, :, keep] = fit.J
    return dataclasses.replace(fit, p=model.full(fit.p), J=J,
                               history_p=[model.full(p) for p in fit.history_p])
