"""Newey-West (HAC) covariance of least-squares estimates in O(n L).

For the equation-error baseline (:mod:`baselines.equation_error`), whose residuals are
coloured by the Savitzky-Golay smoothing and derivatives and by the EBM reconstruction.
The bandwidth ``L`` is twice the residuals' correlation length (FFT autocorrelation,
capped at :data:`MAX_CORRELATION_LENGTH`); the lagged cross-products of the scores for
lags ``0..L`` are summed through a FIR filter of the scores. Cost ``O(n L p)`` for n time
samples and p coefficients, memory ``O(n p)``.
"""

from __future__ import annotations

import numpy as np
import scipy.fft
import scipy.signal

__all__ = ["MAX_CORRELATION_LENGTH", "bartlett_meat", "hac_covariance",
           "residual_correlation_length"]

#: Cap on the residual correlation length [samples] that sets the Newey-West bandwidth
#: (twice it): 2.5x the widest filter applied to the data (the 101-point roll-rate
#: derivative), 4x the longest length measured on equation-error fits whose residuals
#: decorrelate (<= 57 samples on 40 s flights, <= 41 on the 1 s reference flight).
#: Residuals still correlated beyond it carry model misfit, not filter colouring; a
#: bandwidth growing with n would make the Newey-West cost O(n^2) (equation-error
#: one-step, paper noise, 40 s at 500 Hz: 9532 lags, 12 s of a 13 s fit;
#: benchmarks/results/newey_west.md) and its estimate inconsistent. Hitting the cap is a
#: warning in the result (there, against the uncapped bandwidth, the one-step standard
#: errors change by factors 0.54-1.73 and the two-step Cl0/Clp ones by 0.56: neither is
#: a trustworthy interval). Short records keep the cap n // 4.
MAX_CORRELATION_LENGTH = 250


def residual_correlation_length(e: np.ndarray, cap: int) -> int:
    """Return the first lag at which the residuals' autocorrelation is insignificant.

    ``e`` has shape (n,) or (n, k) (k channels); the lag is the largest over the
    channels of the first ``l`` with ``|acf(l)| < 2 / sqrt(n)`` (the white-noise 95 %
    band), capped at ``cap``. The autocorrelation of lags ``0..cap`` comes from one
    zero-padded FFT per channel, ``O(n log n)`` whatever the lag (a lag-by-lag search
    costs ``O(n)`` per lag, ``O(n^2)`` when the correlation is long); it equals the
    direct sums ``x[l:] @ x[:-l]`` to rounding (~1e-15 of ``acf(0)``).
    """
    e = np.asarray(e, dtype=float).reshape(len(e), -1)
    n = e.shape[0]
    cap = max(int(cap), 1)
    x = e - e.mean(axis=0)
    nfft = scipy.fft.next_fast_len(n + cap, real=True)  # no wrap-around up to lag cap
    spectrum = scipy.fft.rfft(x, nfft, axis=0)
    acov = scipy.fft.irfft(spectrum.real**2 + spectrum.imag**2, nfft, axis=0)[:cap]
    length = 1
    for j in range(x.shape[1]):
        var = float(x[:, j] @ x[:, j])
        if var == 0.0:
            continue
        small = np.flatnonzero(np.abs(acov[1:, j]) / var < 2.0 / np.sqrt(n))
        length = max(length, int(small[0]) + 1 if small.size else cap)
    return length


def hac_covariance(A: np.ndarray, e: np.ndarray, n_time: int, lags: int) -> np.ndarray:
    """Newey-West (Bartlett-kernel) covariance of least-squares estimates.

    ``cov = (A^T A)^-1 S (A^T A)^-1`` with ``S = G_0 + sum_l w_l (G_l + G_l^T)``,
    ``G_l = sum_t g_t g_{t-l}^T``, ``g_t`` the score of time sample ``t`` (its rows of
    ``A`` times their residuals) and ``w_l = 1 - l / (lags + 1)``, ``l = 1..lags``.

    The weighted sum of the lagged cross-products is ``g^T h + h^T g`` with
    ``h_t = sum_l w_l g_{t-l}``, a causal FIR filter of the scores
    (:func:`scipy.signal.lfilter`, direct sums): ``O(n_time * lags * p)`` time and
    ``O(n_time * p)`` memory, with only lags ``0..lags`` ever formed.

    Parameters
    ----------
    A : ndarray, shape (n_time * k, p)
        Regressors, time-major: the k rows of each time sample are consecutive.
    e : ndarray, shape (n_time * k,)
        Residuals.
    n_time : int
    lags : int
        Bandwidth ``L`` (lags beyond ``n_time - 1`` have no pairs and add nothing).
    """
    g = (A * e[:, None]).reshape(n_time, -1, A.shape[1]).sum(axis=1)
    bread = np.linalg.pinv(A.T @ A)
    return bread @ bartlett_meat(g, lags) @ bread


def bartlett_meat(g: np.ndarray, lags: int) -> np.ndarray:
    """Return ``S = G_0 + sum_{l=1}^{lags} (1 - l / (lags + 1)) (G_l + G_l^T)``.

    ``G_l = sum_t g_t g_{t-l}^T`` over the scores ``g`` (shape (n, p)), computed as
    ``g^T h + h^T g`` with ``h`` the FIR-filtered scores (:func:`hac_covariance`).
    """
    n = g.shape[0]
    S = g.T @ g
    top = min(int(lags), n - 1)
    if top >= 1:
        fir = np.concatenate([[0.0], 1.0 - np.arange(1, top + 1) / (lags + 1.0)])
        h = scipy.signal.lfilter(fir, [1.0], g, axis=0)  # h_t = sum_l w_l g_{t-l}
        cross = g.T @ h
        S += cross + cross.T
    return S
