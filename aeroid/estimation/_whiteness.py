"""Is a residual white noise? A portmanteau test per channel, robust to changing variance.

A model that fits leaves the measurement noise as its residual: independent from sample
to sample and unrelated to the input. A model that is wrong by a little (a relay switch
modelled one sample late, a poorer optimum, an actuator delay left out) can keep the
residual's RMS near the noise level yet leave structure: the residual then predicts
itself a few samples later, or follows the relay's switches. Two score tests per channel
find that structure:

- **autocorrelation**: the residual regressed on its own :data:`LAGS` previous values
  (a Ljung-Box-type portmanteau);
- **switches**: the residual regressed on the signed relay switches at the sample of the
  switch and the :data:`SWITCH_LAGS` samples after it.

Each is the heteroscedasticity-robust score (Lagrange multiplier) statistic
``g^T V^-1 g`` with ``g = X^T e`` and ``V = sum_t e_t^2 x_t x_t^T`` (White's form), which
is chi-squared with as many degrees of freedom as regressors when ``e`` is independent
noise, whatever its variance does over time (the paper's noise is proportional to the
signal). The p-value is chi-squared's survival function (``scipy.special.chdtrc``, what
``scipy.stats.chi2.sf`` computes). The residual is not demeaned: a bias is
structure too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import special

#: Lags of the autocorrelation test [samples]: 40 ms at 500 Hz, the span over which a
#: relay switch misplaced by a sample or a 1 ms actuator delay leaves its mark (the
#: relay switches about every 15 samples on the reference flight).
LAGS = 20
#: The switch test regresses on the signed switch at its sample and this many after.
SWITCH_LAGS = 2


@dataclass(frozen=True)
class WhitenessTest:
    """One score test of a residual: statistic, degrees of freedom and p-value."""

    statistic: float
    dof: int
    p_value: float


def _score_test(e: np.ndarray, X: np.ndarray) -> WhitenessTest:
    # the statistic is invariant to the residual's scale: normalised, residuals of 1e150
    # (an EKF on absurd accelerations) do not overflow in e * e
    peak = float(np.max(np.abs(e))) if e.size else 0.0
    if np.isfinite(peak) and peak > 0.0:
        e = e / peak
    g = X.T @ e
    V = (X * (e * e)[:, None]).T @ X
    keep = np.diag(V) > 0.0  # a regressor that is zero wherever e is not: no information
    g, V = g[keep], V[np.ix_(keep, keep)]
    if g.size == 0:
        return WhitenessTest(0.0, 0, 1.0)
    try:
        q = float(g @ np.linalg.solve(V, g))
    except np.linalg.LinAlgError:  # collinear regressors (a lag that repeats another)
        q = float(g @ np.linalg.lstsq(V, g, rcond=None)[0])
    # the chi-squared survival function (scipy.stats.chi2.sf, without its overhead)
    return WhitenessTest(q, int(g.size), float(special.chdtrc(g.size, q)))


def lagged(x: np.ndarray, lags: range) -> np.ndarray:
    """Return the columns ``x[t - k]`` for ``k`` in ``lags`` (zero before the start), (n, K)."""
    x = np.asarray(x, dtype=float)
    out = np.zeros((x.size, len(lags)))
    for j, k in enumerate(lags):
        out[k:, j] = x[:x.size - k] if k else x
    return out


def autocorrelation_test(residual: np.ndarray, lags: int = LAGS) -> WhitenessTest:
    """Test a residual for autocorrelation at lags ``1 .. lags`` (robust score test).

    Parameters
    ----------
    residual : ndarray, shape (n,)
    lags : int

    Returns
    -------
    WhitenessTest
        chi-squared with ``lags`` degrees of freedom under white noise.
    """
    e = np.asarray(residual, dtype=float).reshape(-1)
    lags = min(int(lags), e.size // 4)
    if lags < 1:
        return WhitenessTest(0.0, 0, 1.0)
    peak = float(np.max(np.abs(e)))
    if np.isfinite(peak) and peak > 0.0:  # q is invariant to the scale of e and its lags
        e = e / peak
    return _score_test(e[lags:], lagged(e, range(1, lags + 1))[lags:])


def switch_test(residual: np.ndarray, delta: np.ndarray,
                lags: int = SWITCH_LAGS) -> WhitenessTest:
    """Test a residual for correlation with the relay's switches (robust score test).

    The regressors are the signed changes of the logged deflection,
    ``sign(delta_t - delta_(t-1))``, at the residual's sample and ``1 .. lags`` before
    it. A residual shorter than ``delta`` (a filter's innovations after its start-up)
    belongs to the last ``len(residual)`` samples.

    Returns
    -------
    WhitenessTest
        chi-squared with ``lags + 1`` degrees of freedom (fewer when a lag holds no
        switch) under noise independent of the switches; p = 1 without switches.
    """
    e = np.asarray(residual, dtype=float).reshape(-1)
    delta = np.asarray(delta, dtype=float).reshape(-1)
    if e.size > delta.size:
        raise ValueError(f"switch_test: {e.size} residuals for {delta.size} samples")
    signs = np.sign(np.diff(delta, prepend=delta[:1]))
    X = lagged(signs, range(lags + 1))[delta.size - e.size:]
    return _score_test(e, X)


def family_limit(alpha: float, n_tests: int) -> float:
    """Return the per-test p-value limit for a family error ``alpha`` over ``n_tests``
    (Bonferroni: ``alpha / n_tests``)."""
    return alpha / max(int(n_tests), 1)


__all__ = ["LAGS", "SWITCH_LAGS", "WhitenessTest", "autocorrelation_test", "family_limit",
           "lagged", "switch_test"]
