"""Output-error's estimate of an aiding group's time skew against the IMU (private).

``estimate_skew = "gnss" | "ins" | "gnss+ins"`` frees one parameter per named clock group
(the GNSS's skew moves its velocity and its position samples alike):
its samples were taken at ``t_logged + skew`` [s] (the suite log's ``offset_s`` convention:
true time = logged time + offset), so the source's prediction is wanted between the
record's samples. It is the cubic Hermite interpolant of the source's predictions at the
record's samples (:func:`hermite_weights`: Catmull-Rom tangents, C1 in the skew, exact for
a parabola; beyond the record's ends the line of its end tangent), so:

- the prediction at a skewed time is ``sum_c w_c(skew) y(x_{k_c})`` over four samples, its
  sensitivity to the other parameters the same weights on theirs (exact), and to the skew
  ``sum_c dw_c/dskew y(x_{k_c})`` (exact for the interpolant);
- the interpolation's own error is third order in the sample interval (the tangents'
  error is ``dt^2 y''' / 6``): on a 1 kHz record a roll angle turning at 50 rad/s with
  its rate swinging by 5 rad/s at 10 Hz is interpolated to 3.2e-7 rad, 2.3e-5 rad in the
  record's first and last intervals (one-sided tangents) (tested:
  tests/unit/test_output_error_skew.py), far below the INS's 3 mrad;
- the skews come after the record model's parameters (its IMU errors last) and before
  the GNSS position's origin, scaled by the flight's sample interval, started at 0, no
  prior.

Nothing is resampled: the samples stay at their logged times' rows; only their
predictions move.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from baselines._gauss_newton import posterior_information
from baselines._oe_aiding_samples import LABELS, aiding_sources

#: The option's values: none, or the aiding sources whose skew is estimated.
SKEWS = ("none", "gnss", "ins", "gnss+ins")
#: The skew parameters' names in ``info["parameter_names"]``.
SKEW_NAMES = {"gnss": "gnss_skew_s", "ins": "ins_skew_s"}
#: :func:`skew_search`: restarts from the end's skew moved this many standard errors
#: either way, at most this many rounds; an end must be likelier by this much [nats].
SEARCH_STEP_SE = 2.0
SEARCH_ROUNDS = 4
SEARCH_NLL_TOL = 1e-2


def skew_sources(option: str) -> tuple[str, ...]:
    """The sources of an ``estimate_skew`` value: ``"gnss+ins"`` -> gnss, ins."""
    return () if option == "none" else tuple(option.split("+"))


def skew_names(option: str) -> list[str]:
    """The parameter names of ``option``'s skews, in parameter order."""
    return [SKEW_NAMES[s] for s in skew_sources(option)]


def check_skew_option(aiding: str, option: str) -> None:
    """Raise ValueError (one line) for an ``estimate_skew`` that is unknown or names a
    source ``aiding`` leaves out."""
    if option not in SKEWS:
        raise ValueError(f"estimate_skew must be one of {', '.join(SKEWS)}, got {option!r}")
    sources = aiding_sources(aiding)
    missing = [s for s in skew_sources(option)
               if s not in sources and not (s == "gnss" and "gnss_position" in sources)]
    if missing:
        what = "GNSS velocity or position" if missing[0] == "gnss" else LABELS[missing[0]]
        raise ValueError(f"estimate_skew = {option} needs the {what} in the likelihood "
                         f"(aiding = {aiding}): a skew is estimated from its samples")


def hermite_weights(t_query: np.ndarray, t0: float, dt: float, n: int
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weights of the record's samples in the cubic Hermite interpolant at ``t_query``.

    Parameters
    ----------
    t_query : ndarray, shape (k,)
        Times [s] at which the interpolant is wanted.
    t0, dt : float
        The record's first time and sample interval [s].
    n : int
        The record's number of samples (>= 3).

    Returns
    -------
    index, weight, dweight : ndarray, shape (k, 4)
        Sample indices, their weights (``y(t) = sum weight y[index]``) and the weights'
        derivatives in ``t`` [1/s]. Inside: Catmull-Rom (tangent ``(y[j+1] - y[j-1]) /
        (2 dt)``, one-sided at the ends, i.e. a linear ghost sample); outside the record:
        the end interval's line ``(1 - u) y[j] + u y[j+1]``.
    """
    x = (np.asarray(t_query, dtype=float) - t0) / dt
    j = np.clip(np.floor(x).astype(int), 0, n - 2)
    u = (x - j)[:, None]
    index = j[:, None] + np.arange(-1, 3)
    w = np.hstack([(-u ** 3 + 2 * u ** 2 - u) / 2, (3 * u ** 3 - 5 * u ** 2 + 2) / 2,
                   (-3 * u ** 3 + 4 * u ** 2 + u) / 2, (u ** 3 - u ** 2) / 2])
    dw = np.hstack([(-3 * u ** 2 + 4 * u - 1) / 2, (9 * u ** 2 - 10 * u) / 2,
                    (-9 * u ** 2 + 8 * u + 1) / 2, (3 * u ** 2 - 2 * u) / 2])
    for a in (w, dw):  # ghost samples y[-1] = 2 y[0] - y[1], y[n] = 2 y[n-1] - y[n-2]
        first, last = j == 0, j == n - 2
        a[first, 1] += 2 * a[first, 0]
        a[first, 2] -= a[first, 0]
        a[first, 0] = 0.0
        a[last, 2] += 2 * a[last, 3]
        a[last, 1] -= a[last, 3]
        a[last, 3] = 0.0
    out = (u[:, 0] < 0) | (u[:, 0] > 1)
    w[out] = np.column_stack([np.zeros(out.sum()), 1 - u[out, 0], u[out, 0],
                              np.zeros(out.sum())])
    dw[out] = np.array([0.0, -1.0, 1.0, 0.0])
    return np.clip(index, 0, n - 1), w, dw / dt


def skew_report(option: str, info: dict[str, Any], model: Any, p: np.ndarray,
                phys: np.ndarray, cov: np.ndarray, search: dict[str, Any]) -> list[str]:
    """Put the estimated skews in ``info``; return the notes to print.

    ``info["aiding_skew_s"]`` and ``info["aiding_skew_stderr_s"]`` per source;
    ``info["aiding_skew_correlation"]``: each skew's largest correlation with another
    parameter, as (that parameter's name, the correlation) (a skew the free initial
    velocity can absorb shows here). A note per source with samples whose skewed time
    left the record (their prediction the end interval's line: :func:`outside_counts`).
    ``info["aiding_skew_search"]``: :func:`skew_search`'s trials.
    ``model``: the :class:`~baselines._oe_aiding.AidedModel`; ``p`` its scaled
    parameters, ``phys`` and ``cov`` in physical units (``info["parameter_names"]``).
    """
    if option == "none":
        return []
    names = tuple(info["parameter_names"])
    sd = np.sqrt(np.abs(np.diag(cov)))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    skew, skew_sd, partner = {}, {}, {}
    for source in skew_sources(option):
        i = names.index(SKEW_NAMES[source])
        skew[source], skew_sd[source] = float(phys[i]), float(sd[i])
        row = np.where(np.arange(len(names)) == i, 0.0, np.nan_to_num(corr[i]))
        k = int(np.argmax(np.abs(row)))
        partner[source] = (names[k], float(row[k]))
    info.update({"aiding_skew_s": skew, "aiding_skew_stderr_s": skew_sd,
                 "aiding_skew_correlation": partner, "aiding_skew_search": search["trials"]})
    return [f"output-error: {k} {LABELS[s]} sample(s) predicted beyond the record's end "
            "(skewed time outside it: the end interval's line)"
            for s, k in outside_counts(model, p).items() if k]


def outside_counts(model: Any, p: np.ndarray) -> dict[str, int]:
    """Per source with a free skew, its samples whose skewed time is outside the record
    (``model``: an :class:`~baselines._oe_aiding.AidedModel`; ``p`` scaled parameters)."""
    counts = {}
    t = model.base.t
    for s in model.samples:
        i = model.skew_index(s.source)
        if i is not None:
            times = t[s.index] + p[i] * model.scale[i]
            counts[s.source] = int(np.sum((times < t[0]) | (times > t[-1])))
    return counts


def skew_search(option: str, prob: Any, fit: Any, refit: Callable[[np.ndarray], Any]
                ) -> tuple[Any, dict[str, Any]]:
    """Restart the fit from each free skew moved by :data:`SEARCH_STEP_SE` of its standard
    error either way, and keep a likelier converged end, until none is (at most
    :data:`SEARCH_ROUNDS` rounds).

    Why: a GNSS skew is nearly a constant NED velocity offset, which the free initial
    velocity and attitude absorb, so its likelihood is flat and not one-humped: on seed 1
    of the default suite with the GNSS 50 ms late, Gauss-Newton from 0 stopped at
    2.3 ms (se 12 ms); restarted from 20, 50 or 80 ms it ended at 47.5 ms with a
    log-likelihood higher by 2.86. ``refit(p0)`` runs the solver from scaled ``p0``.
    An end that stopped on its iteration limit (the skew crawls along its flat valley:
    seeds 2 and 3 of ``bench_aiding.py --skew``) is first run once more from where it
    stopped. Returns the kept end and ``{"n_evaluations", "trials"}``, the trials as
    ``(source, start skew [s], end skew [s], end's nll, converged)`` (``"restart"``, NaN,
    NaN for the run from the stopped end).
    """
    out: dict[str, Any] = {"n_evaluations": 0, "trials": []}
    if option == "none":
        return fit, out
    model = prob.model
    if not fit.converged:  # crawling along the flat skew: once more from where it stopped
        end = refit(fit.p)
        out["n_evaluations"] += end.n_evaluations
        out["trials"].append(("restart", math.nan, math.nan, float(end.nll),
                              bool(end.converged)))
        fit = end if end.converged or end.nll < fit.nll else fit
    for _ in range(SEARCH_ROUNDS):
        M, _ = posterior_information(prob, fit.J, fit.e, fit.r_diag, fit.p)
        sd = np.sqrt(np.abs(np.diag(np.linalg.pinv(M))))
        better = None
        for source in skew_sources(option):
            i = model.n_base + model.skew_free.index(source)
            if not np.isfinite(sd[i]) or sd[i] == 0.0:
                continue
            for sign in (1.0, -1.0):
                p0 = fit.p.copy()
                p0[i] += sign * SEARCH_STEP_SE * sd[i]
                try:
                    end = refit(p0)
                except FloatingPointError:
                    continue
                out["n_evaluations"] += end.n_evaluations
                out["trials"].append((source, float(p0[i] * model.scale[i]),
                                      float(end.p[i] * model.scale[i]), float(end.nll),
                                      bool(end.converged)))
                kept = fit if better is None else better
                if end.converged and end.nll < kept.nll - SEARCH_NLL_TOL:
                    better = end
        if better is None:
            break
        fit = better
    return fit, out
