"""The per-sample noise law of the output-error solver (private; split from
:mod:`baselines._gauss_newton`, which re-exports these names).

``var_kc = a_c + b_c yhat_kc^2`` per channel, its likelihood and its maximum.
"""

from __future__ import annotations

import numpy as np

#: Floor of the signal-independent part ``a_c`` of the ``signal`` noise model, as a
#: fraction of the channel's mean squared residual: a sample whose modelled variance
#: would be ~0 (a zero crossing under multiplicative noise) gets at most 1/A_FLOOR_REL
#: times the channel's typical weight. The floor is a numerical guard, not a belief about
#: the noise, and the Fisher covariance takes the floored variance as the true one: at
#: 1e-4 (the former value) output-error's intervals were 1.1-1.4x its actual spread under
#: the paper's noise, coverage 0.989 and 0.489 % mean error; at 1e-6 coverage 0.964 and
#: 0.468 % (``aeroid study studies/paper_table5_prior.toml``, 50 runs, at commits
#: b008e8f and 9d489cc; data with additive noise have a_c well above either floor).
A_FLOOR_REL = 1e-6
#: The noise law's likelihood maximisation (:func:`most_likely_law`) ends when no
#: channel's negative log-likelihood falls by more than this in an iteration (a law
#: that much less likely moves no coefficient visibly), or after LAW_MAX_ITERATIONS.
LAW_NLL_TOL = 1e-6
LAW_MAX_ITERATIONS = 100
#: Smallest fraction of a scoring step tried before that channel's law stays put.
LAW_MIN_STEP = 1e-9


def _law_nll(e2: np.ndarray, s2: np.ndarray, a: np.ndarray | float,
             b: np.ndarray | float) -> np.ndarray:
    """Negative log-likelihood per channel of the law ``a + b s2``, shape (m,)."""
    var = a + b * s2
    return 0.5 * np.sum(e2 / var + np.log(var), axis=0)


def most_likely_law(e2: np.ndarray, s2: np.ndarray, a: np.ndarray, b: np.ndarray, *,
                    floor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the maximum-likelihood noise law ``var = a + b s2`` per channel from a start.

    Newton's method on the Gaussian likelihood of the residuals where its curvature is
    positive, else Fisher scoring (whose full step is the reweighted regression of
    :func:`aeroid.estimation.fit_noise_law`), each step halved until the likelihood
    does not fall, within ``a >= floor``, ``b >= 0``. The regression alone makes a fixed
    number of unguarded steps and can oscillate: on the residuals of a poor iterate (a
    paper-noise flight, ay1) it alternated between ``b = 0`` with a variance 50 times
    below the residuals' and ``a`` at its floor, a likelihood 1.2e4 worse than one
    variance per channel, and Gauss-Newton then fitted those weights into a poorer
    optimum (issue 18: 2 of 200 paper-condition runs from a prior 10-25 % off).

    Parameters
    ----------
    e2, s2 : ndarray, shape (n, m)
        Squared residuals and squared model outputs.
    a, b : ndarray, shape (m,)
        The start.
    floor : ndarray, shape (m,)
        Lower bound of ``a``.
    """
    floor = np.broadcast_to(np.asarray(floor, dtype=float), np.shape(a))
    a, b = np.maximum(a, floor), np.maximum(b, 0.0)
    active = np.arange(a.size)  # channels still moving
    for _ in range(LAW_MAX_ITERATIONS):
        if active.size == 0:
            break
        ca, cb, fl, e2c, s2c = a[active], b[active], floor[active], e2[:, active], s2[:, active]
        nll = _law_nll(e2c, s2c, ca, cb)
        var = ca + cb * s2c
        w = 1.0 / (var * var)
        r = w * (e2c - var)
        u0, u1 = np.sum(r, 0), np.sum(r * s2c, 0)
        # Newton where the likelihood's curvature is positive, else Fisher scoring
        h = w * (2.0 * e2c / var - 1.0)
        i00, i01, i11 = np.sum(h, 0), np.sum(h * s2c, 0), np.sum(h * s2c * s2c, 0)
        convex = (i00 > 0) & (i00 * i11 - i01 * i01 > 0)
        i00 = np.where(convex, i00, np.sum(w, 0))
        i01 = np.where(convex, i01, np.sum(w * s2c, 0))
        i11 = np.where(convex, i11, np.sum(w * s2c * s2c, 0))
        with np.errstate(all="ignore"):
            det = i00 * i11 - i01 * i01
            da, db = (i11 * u0 - i01 * u1) / det, (i00 * u1 - i01 * u0) / det
            # a step out of a bound it sits on: along the other parameter alone
            on_b = (cb <= 0.0) & (db < 0.0)
            da, db = np.where(on_b, u0 / i00, da), np.where(on_b, 0.0, db)
            on_a = (ca <= fl) & (da < 0.0) & ~on_b
            da, db = np.where(on_a, 0.0, da), np.where(on_a, u1 / i11, db)
        finite = np.isfinite(da) & np.isfinite(db)
        da, db = np.where(finite, da, 0.0), np.where(finite, db, 0.0)
        gain = np.zeros(active.size)
        todo = finite.copy()
        step = 1.0
        while np.any(todo) and step > LAW_MIN_STEP:
            ta, tb = np.maximum(ca + step * da, fl), np.maximum(cb + step * db, 0.0)
            trial = _law_nll(e2c[:, todo], s2c[:, todo], ta[todo], tb[todo])
            ok = np.zeros(active.size, dtype=bool)
            ok[todo] = trial <= nll[todo]
            idx = active[ok]
            a[idx], b[idx] = ta[ok], tb[ok]
            gain[ok] = nll[ok] - trial[ok[todo]]
            todo &= ~ok
            step *= 0.5
        active = active[gain > LAW_NLL_TOL]
    return a, b
