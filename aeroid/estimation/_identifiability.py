"""Can the method's data determine each coefficient? Information and correlation checks.

From what a result carries: its ``covariance`` (inverse information) or, for methods
without one, ``info["information"]`` (the curvature of the method's objective in the
coefficients, any positive scale: EBM-PSO's quadratic form). Two findings:

- **zero information**: a coefficient the objective does not depend on: its diagonal of
  the information, scaled to the coefficient's size, at most :data:`ZERO_INFORMATION`
  of the largest (from a covariance: also a standard error above the estimate's size;
  a non-finite variance has none). Its estimate is whatever
  the search left it at: never part of a success.
- **confounded pairs**: two coefficients whose estimates correlate above
  :data:`CORRELATION_LIMIT` in magnitude: the data determine a combination of the two
  much better than either (a warning naming them).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: A coefficient whose scaled information is at most this fraction of the largest has
#: none: 1e-12 is far below any real difference in how well the data determine two
#: coefficients (the reference flight's scaled information spans 1e-5 between Cl0 and
#: Cx under output-error, measured) and far above rounding (1e-16).
ZERO_INFORMATION = 1e-12
#: Correlations above this magnitude are reported (issue 18). Cl0 and Clp correlate
#: 0.9999 in every fit of the reference flight (the roll rate stays near its steady
#: state, which fixes Cl0 / Clp), so those fits carry this warning.
CORRELATION_LIMIT = 0.98


def _scaled_information(theta: np.ndarray, covariance: np.ndarray | None,
                        information: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Return (scaled information diagonal, correlation) from either matrix."""
    scale = np.where(np.isfinite(theta) & (theta != 0.0), np.abs(theta), 1.0)
    if information is not None:
        info = np.asarray(information, dtype=float) * np.outer(scale, scale)
        diag = np.diag(info).copy()
        top = np.max(np.abs(diag)) if diag.size else 0.0
        keep = diag > ZERO_INFORMATION * top
        corr = np.full(info.shape, np.nan)
        if np.any(keep):
            sub = info[np.ix_(keep, keep)]
            d = np.sqrt(np.diag(sub))
            cov = np.linalg.pinv(sub / np.outer(d, d))
            s = np.sqrt(np.abs(np.diag(cov)))
            with np.errstate(invalid="ignore", divide="ignore"):
                corr[np.ix_(keep, keep)] = cov / np.outer(s, s)
        return diag, corr
    cov = np.asarray(covariance, dtype=float)
    var = np.diag(cov).copy()
    with np.errstate(invalid="ignore", divide="ignore"):
        # a zero variance is a perfectly determined coefficient (noise-free data)
        diag = np.where(var > 0.0, scale**2 / var, np.inf)
        s = np.sqrt(np.where(var > 0.0, var, np.nan))
        corr = cov / np.outer(s, s)
    return diag, corr


def identifiability(names: Sequence[str], theta: np.ndarray, *,
                    covariance: np.ndarray | None = None,
                    information: np.ndarray | None = None,
                    ) -> tuple[tuple[str, ...], tuple[tuple[str, str, float], ...]]:
    """Return the coefficients without information and the pairs correlated above the limit.

    Parameters
    ----------
    names : sequence of str, length k
    theta : ndarray, shape (k,)
    covariance, information : ndarray, shape (k, k)
        One of them (``information`` wins when both are given).

    Returns
    -------
    zero : tuple of str
        Coefficients with no information (:data:`ZERO_INFORMATION`).
    pairs : tuple of (str, str, float)
        ``(a, b, correlation)`` with ``|correlation| > CORRELATION_LIMIT``.
    """
    theta = np.asarray(theta, dtype=float).reshape(-1)
    k = theta.size
    if len(names) != k:
        raise ValueError(f"identifiability: {len(names)} names for {k} coefficients")
    matrix = information if information is not None else covariance
    if matrix is None:
        return (), ()
    if np.shape(matrix) != (k, k):
        raise ValueError(f"identifiability: a {np.shape(matrix)} matrix for {k} coefficients")
    bad = ~np.all(np.isfinite(matrix), axis=1)
    if np.any(bad):  # a row that is not a number: nothing is known of that coefficient
        return tuple(n for n, b in zip(names, bad, strict=True) if b), ()
    diag, corr = _scaled_information(theta, covariance, information)
    finite = diag[np.isfinite(diag)]
    top = np.max(finite) if finite.size else np.inf
    # from a covariance, also the estimate's own size: on noise-free data the variances
    # are rounding and span 1e15 between coefficients (equation-error, measured), while
    # a coefficient without information has a standard error beyond its estimate
    absolute = 1.0 if information is None else np.inf
    zero = tuple(n for n, d in zip(names, diag, strict=True)
                 if np.isnan(d) or (d <= ZERO_INFORMATION * top and d < absolute))
    pairs = tuple((names[i], names[j], float(corr[i, j]))
                  for i in range(k) for j in range(i + 1, k)
                  if np.isfinite(corr[i, j]) and abs(corr[i, j]) > CORRELATION_LIMIT)
    return zero, pairs


def identifiability_findings(names: Sequence[str], theta: np.ndarray,
                             covariance: np.ndarray | None, information: np.ndarray | None,
                             ) -> tuple[str | None, tuple[str, ...]]:
    """Return (failure message or None, warnings) of :func:`identifiability`."""
    zero, pairs = identifiability(names, theta, covariance=covariance,
                                  information=information)
    failure = None
    if zero:
        failure = (f"no information on {', '.join(zero)} in this method's objective: the "
                   "data cannot determine it; the estimate is where the search stopped "
                   "(fix it, or use a method or flight that carries it)")
    warnings: tuple[str, ...] = ()
    if pairs:
        text = ", ".join(f"{a}-{b} ({r:+.5f})" for a, b, r in pairs)
        warnings = (f"nearly confounded (|correlation| > {CORRELATION_LIMIT:g}): {text}; the "
                    "data determine a combination of each pair better than either",)
    return failure, warnings


__all__ = ["CORRELATION_LIMIT", "ZERO_INFORMATION", "identifiability",
           "identifiability_findings"]
