"""The gust filters' one-step estimate judged where it is reported (issue 26; private).

With ``gust_stderr = one-step`` (:mod:`baselines._kalman_information`) the EKF/UKF with
gust states report the filter's estimate moved by one Fisher-scoring step of
filter-error's likelihood. Its fit check and verdicts used to be the filter's: the
filter's innovations, its passes' settling and its filtered gust path judged a point the
result did not report. Here the reported point is judged as filter-error judges its own
optimum (:class:`baselines.filter_error.FilterErrorEstimator`), from filter-error's
filter run at it (the centre run of the information there):

- the innovations over the whole record and their variances become
  ``info['fit_residuals']`` and ``info['R']``, so the fit check of
  :meth:`aeroid.estimation.Estimator.fit` (size, whiteness and the noise model's
  standardized residual) reads the moved estimate's innovations;
- the filtered gust path goes to the gust verdict (:mod:`baselines._gust_verdict`) and
  the steady-wind verdict (:func:`baselines._fem_wind.steady_verdict`);
- the passes' verdict in the likelihood's terms (judged after the two above): the next
  scoring step from the reported point must be below :data:`NEXT_STEP_LIMIT_SE` of its
  own standard error (a point that is not near the likelihood's stationary point is not
  filter-error's estimate, and its ``M^-1`` does not describe where the estimate is).

The filter's own verdicts judged the one-step's start; they are kept
(``info['one_step']['filter_success']``, ``filter_message``, ``info['gust_verdict_filtered']``)
and a refusal of theirs is said in one line.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aeroid.model import N_STATE, OUTPUT_CHANNELS, PHI, PSI, THETA, P
from baselines._fem_model import N_WIND
from baselines._fem_wind import steady_verdict
from baselines._gust_verdict import gust_verdict
from baselines._kalman_verdict import SETTLE_LIMIT_SE

#: The next scoring step from the reported one-step point, in its own se, above which
#: the point is refused (the passes' limit, :data:`baselines._kalman_verdict.
#: SETTLE_LIMIT_SE`: a move larger than the se is not covered by it). Measured on the
#: right model (README, "The gust filters' intervals"): the benchmark's lines
#: ``next step``.
NEXT_STEP_LIMIT_SE = SETTLE_LIMIT_SE


@dataclass(frozen=True)
class Judgement:
    """The moved estimate's verdict: ``ok``, one-line ``message`` (empty when ok) and
    the ``info`` entries it reports (``fit_residuals``, ``R``, ``gust_verdict``,
    ``gust_verdict_refusal``, ``one_step``)."""

    ok: bool
    message: str
    info: dict = field(default_factory=dict)


def judge(runs: Any, next_step_se: np.ndarray, names: tuple[str, ...], gust_sd_mps: float,
          tau_s: float, dt: float, who: str) -> Judgement:
    """Judge the one-step point from filter-error's filter run at it.

    Parameters
    ----------
    runs : baselines._fem_fit.FilterRuns
        The filter at the point (one row): ``innovation`` (1, n, m), ``S`` (1, n, m, m),
        ``x`` (1, n, N_STATE + N_WIND) [SI].
    next_step_se : ndarray, shape (n_free + 1,)
        The next Fisher-scoring step's size in its own se (:func:`baselines.
        _kalman_likelihood.scoring_step`; NaN where held).
    names : tuple of str
        The free coefficients' names, then the intensity's.
    gust_sd_mps, tau_s, dt : float
        The intensity [m/s] and the gusts' time constant [s] at the point, the sample
        interval [s].
    who : str
        The estimator's name, for the messages.
    """
    x = runs.x[0]
    gust = x[:, -N_WIND:]  # zero-mean gusts (as filter-error's: no steady wind state)
    state = x[:, :N_STATE]
    verdict = gust_verdict(gust, state[:, [PHI, THETA, PSI]], state[:, P], gust_sd_mps,
                           tau_s, dt, who=who, velocity=state[:, :3])
    steady = steady_verdict(gust, verdict.figures["axial_mean_sd_mps"], gust_sd_mps, dt,
                            who=who, estimated=False)
    moves = dict(zip(names, np.asarray(next_step_se, dtype=float).tolist(), strict=True))
    finite = {k: v for k, v in moves.items() if np.isfinite(v)}
    worst = max(finite, key=finite.__getitem__) if finite else None
    message = verdict.message or steady.message  # the physical finding first
    if not message and (worst is None or not finite[worst] <= NEXT_STEP_LIMIT_SE):
        message = (f"{who}: the one-step estimate is not at the likelihood's optimum: the next "
                   f"Fisher-scoring step would move {worst} by {finite.get(worst, np.nan):.2f} "
                   f"of its standard errors (limit {NEXT_STEP_LIMIT_SE:g}); its se does not "
                   "cover where the estimate is (method filter-error iterates to the optimum)")
    info = {"fit_residuals": {c: runs.innovation[0][:, j]
                              for j, c in enumerate(OUTPUT_CHANNELS)},
            "R": np.diagonal(runs.S[0], axis1=-2, axis2=-1),
            "gust_verdict": verdict.figures | steady.figures,
            "gust_verdict_refusal": verdict.message,
            "one_step": {"next_step_se": moves, "next_step_limit_se": NEXT_STEP_LIMIT_SE,
                         "gust_ned_mps": gust, "state": state, "time_constant_s": tau_s}}
    return Judgement(not message, message, info)
