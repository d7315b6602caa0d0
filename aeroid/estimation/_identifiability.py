"""Can the method's data determine each coefficient? Information and correlation checks.

From what a result carries: its ``covariance`` (inverse information) or, for methods
without one, ``info["information"]`` (the curvature of the method's objective in the
coefficients, any positive scale: EBM-PSO's quadratic form). Three findings:

- **no information**: a coefficient the objective does not depend on. From the
  information: its diagonal, scaled to the coefficient's size, is zero to rounding
  (:data:`ZERO_INFORMATION` of the largest: a regressor column that is zero); from a
  covariance: a variance that is not finite, or a standard error above
  :data:`NO_INFORMATION_SD` times the estimate. Its estimate is wherever the search
  stopped: never part of a success.
- **almost no information** (from a covariance only: an information matrix of unknown
  scale has no absolute yardstick): a standard error above the estimate itself
  (:data:`LITTLE_INFORMATION_SD`): the data do not fix even its sign (a warning).
- **confounded pairs**: two coefficients whose estimates correlate above
  :data:`CORRELATION_LIMIT` in magnitude: the data determine a combination of the two
  much better than either (a warning naming them).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Scaled information at most this fraction of the largest is zero: squares of rounding
#: (1e-16 relative) sum to 1e-32; real differences between coefficients stay far above
#: 1e-24 (EBM-PSO's quadratic form on the reference flight spans 1e-9 between Czq and
#: Cl0 on the noise-free log, where its noise weights are at their floors; measured).
ZERO_INFORMATION = 1e-24
#: A standard error above this many times the estimate: no information (a singular
#: information matrix inverted, or a prior variance the data never reduced).
NO_INFORMATION_SD = 1e6
#: A standard error above the estimate's own size: almost no information (a warning).
LITTLE_INFORMATION_SD = 1.0
#: Correlations above this magnitude are reported (issue 18). Cl0 and Clp correlate
#: 0.9999 in every fit of the reference flight (the roll rate stays near its steady
#: state, which fixes the ratio Cl0 / Clp), so those fits carry this warning.
CORRELATION_LIMIT = 0.98

Pairs = tuple[tuple[str, str, float], ...]


def _from_information(theta_scale: np.ndarray, information: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Return (no-information mask, correlation) from an information matrix."""
    info = np.asarray(information, dtype=float) * np.outer(theta_scale, theta_scale)
    diag = np.diag(info).copy()
    top = np.max(np.abs(diag)) if diag.size else 0.0
    keep = diag > ZERO_INFORMATION * top
    corr = np.full(info.shape, np.nan)
    if np.any(keep):
        d = np.sqrt(diag[keep])
        cov = np.linalg.pinv(info[np.ix_(keep, keep)] / np.outer(d, d))
        s = np.sqrt(np.abs(np.diag(cov)))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr[np.ix_(keep, keep)] = cov / np.outer(s, s)
    return ~keep, corr


def identifiability(names: Sequence[str], theta: np.ndarray, *,
                    covariance: np.ndarray | None = None,
                    information: np.ndarray | None = None,
                    ) -> tuple[tuple[str, ...], tuple[str, ...], Pairs]:
    """Return the coefficients without and with almost no information, and confounded pairs.

    Parameters
    ----------
    names : sequence of str, length k
    theta : ndarray, shape (k,)
    covariance, information : ndarray, shape (k, k)
        One of them (``covariance`` wins when both are given: it has a scale).

    Returns
    -------
    none : tuple of str
        Coefficients with no information.
    little : tuple of str
        Coefficients whose standard error exceeds the estimate (covariance only).
    pairs : tuple of (str, str, float)
        ``(a, b, correlation)`` with ``|correlation| > CORRELATION_LIMIT``.
    """
    theta = np.asarray(theta, dtype=float).reshape(-1)
    k = theta.size
    if len(names) != k:
        raise ValueError(f"identifiability: {len(names)} names for {k} coefficients")
    matrix = covariance if covariance is not None else information
    if matrix is None:
        return (), (), ()
    matrix = np.asarray(matrix, dtype=float)
    if matrix.shape != (k, k):
        raise ValueError(f"identifiability: a {matrix.shape} matrix for {k} coefficients")
    size = np.where(np.isfinite(theta) & (theta != 0.0), np.abs(theta), 1.0)
    little = np.zeros(k, dtype=bool)
    if covariance is not None:
        var = np.diag(matrix).copy()
        with np.errstate(invalid="ignore", divide="ignore"):
            relative = np.sqrt(np.abs(var)) / size
            s = np.sqrt(np.where(var > 0.0, var, np.nan))
            corr = matrix / np.outer(s, s)
        none = ~np.isfinite(var) | (relative > NO_INFORMATION_SD)
        little = ~none & (relative > LITTLE_INFORMATION_SD)
    else:
        bad = ~np.all(np.isfinite(matrix), axis=1)
        clean = np.where(np.isfinite(matrix), matrix, 0.0)
        none, corr = _from_information(size, clean)
        none |= bad
    pick = [names[j] for j in range(k)]
    pairs = tuple((names[i], names[j], float(corr[i, j]))
                  for i in range(k) for j in range(i + 1, k)
                  if not (none[i] or none[j]) and np.isfinite(corr[i, j])
                  and abs(corr[i, j]) > CORRELATION_LIMIT)
    return (tuple(n for n, z in zip(pick, none, strict=True) if z),
            tuple(n for n, z in zip(pick, little, strict=True) if z), pairs)


def identifiability_findings(names: Sequence[str], theta: np.ndarray,
                             covariance: np.ndarray | None, information: np.ndarray | None,
                             ) -> tuple[str | None, tuple[str, ...]]:
    """Return (failure message or None, warnings) of :func:`identifiability`."""
    none, little, pairs = identifiability(names, theta, covariance=covariance,
                                          information=information)
    failure = None
    if none:
        failure = (f"no information on {', '.join(none)} in this method's objective: the "
                   "data cannot determine it; the estimate is where the search stopped "
                   "(fix it, or use a method or flight that carries it)")
    warnings: tuple[str, ...] = ()
    if little:
        warnings += (f"almost no information on {', '.join(little)}: the standard error "
                     "exceeds the estimate (the data do not fix even its sign)",)
    if pairs:
        text = ", ".join(f"{a}-{b} ({r:+.5f})" for a, b, r in pairs)
        warnings += (f"nearly confounded (|correlation| > {CORRELATION_LIMIT:g}): {text}; "
                     "the data determine a combination of each pair better than either",)
    return failure, warnings


def nuisance_findings(names: Sequence[str], theta: np.ndarray, covariance: np.ndarray,
                      nuisance: Sequence[str]) -> tuple[str, ...]:
    """Return warnings on the ``nuisance`` parameters of a fit (e.g. sensor biases).

    :func:`identifiability` over all of a method's parameters (``names``, ``theta`` and
    their ``covariance``), keeping what involves a nuisance parameter: the pairs above
    :data:`CORRELATION_LIMIT` with one of them (which bias trades against which
    coefficient), and nuisance parameters without information. One line each, empty
    when there is nothing to say.
    """
    extra = set(nuisance)
    none, _, pairs = identifiability(names, theta, covariance=covariance)
    out: tuple[str, ...] = ()
    lost = [n for n in none if n in extra]
    if lost:
        out += (f"no information on {', '.join(lost)}: the data cannot determine it "
                "(its estimate is where the search stopped)",)
    mine = [(a, b, r) for a, b, r in pairs if a in extra or b in extra]
    if mine:
        text = ", ".join(f"{a}-{b} ({r:+.5f})" for a, b, r in mine)
        out += (f"nearly confounded (|correlation| > {CORRELATION_LIMIT:g}): {text}; the "
                "data determine a combination of each pair better than either",)
    return out


__all__ = ["CORRELATION_LIMIT", "LITTLE_INFORMATION_SD", "NO_INFORMATION_SD",
           "ZERO_INFORMATION", "identifiability", "identifiability_findings",
           "nuisance_findings"]
