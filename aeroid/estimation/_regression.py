"""The EBM step-2 regression a block of time at a time (bounded memory on long logs).

:func:`regressor_blocks` yields the regressors of :func:`aeroid.estimation.ebm_regression`
in time blocks, so a fit never holds the ``n x 6 x 9`` array (432 B per sample, most
of it structural zeros); :func:`regression_target` is its ``y``. Equation-error copies
each block's entries into its sub-problems' columns (:mod:`baselines.equation_error`).
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from aeroid.estimation._reconstruct import SMOOTHING_CHOICES, Reconstruction
from aeroid.estimation._signals import (
    SMOOTHING_POLYORDER,
    SMOOTHING_WINDOW,
    _check_window,
    smooth,
)
from aeroid.flights import STATE_CHANNELS, Flight, sample_constants
from aeroid.model import Constants, regressors

__all__ = ["REGRESSION_BLOCK", "regression_target", "regressor_blocks"]

#: Time samples per block of :func:`regressor_blocks`: the regressors of one block and
#: their temporaries take ~1 kB per sample (8192 samples: ~8 MB), whatever the log's
#: length; a block also pays one pass of Python over the model (~0.1 ms), so much smaller
#: blocks cost time on long logs.
REGRESSION_BLOCK = 8192

def regression_target(rec: Reconstruction, *, smoothing: str = "both",
                      window: int | None = None) -> np.ndarray:
    """Return the ``y`` of :func:`ebm_regression` (n, 6) [N, N m], read-only and without a
    copy when it is ``rec.fm`` or ``rec.fm_smooth`` (the regressors' companion of
    :func:`regressor_blocks`)."""
    if smoothing not in SMOOTHING_CHOICES:
        raise ValueError(f"smoothing must be one of {', '.join(SMOOTHING_CHOICES)}, "
                         f"got {smoothing!r}")
    window = rec.smoothing_window if window is None else int(window)
    if smoothing == "none" or window == 1:
        y = rec.fm.view()
    elif window == rec.smoothing_window:
        y = rec.fm_smooth.view()
    else:
        y = smooth(rec.fm, window, min(SMOOTHING_POLYORDER, window - 1))
    y.flags.writeable = False
    return y


def regressor_blocks(flight: Flight, *, smoothing: str = "both", window: int = SMOOTHING_WINDOW,
                     block: int | None = None, wind: np.ndarray | None = None
                     ) -> Iterator[tuple[int, int, np.ndarray]]:
    """Yield the ``X`` of :func:`ebm_regression` a block of time samples at a time.

    Yields ``(start, stop, X[start:stop])``, ``X`` of shape (stop - start, 6, 9), blocks of
    ``block`` samples (default :data:`REGRESSION_BLOCK`) in time order; their
    concatenation is :func:`ebm_regression`'s ``X`` (same ``smoothing`` and ``window``,
    the reconstruction's ``smoothing_window`` there). Memory is that of one block, not of
    the ``n x 6 x 9`` array. ``wind`` (n, 3) [m/s], north-east-down per sample, replaces
    the model constants' wind (:func:`aeroid.estimation.air_data_wind`: the logged
    air-data angles as the aerodynamic angles). With ``smoothing="both"`` each block is
    computed with ``window // 2`` samples of its neighbours on both sides and smoothed, so
    every kept sample has the same SG window (interior) or the same end fit as the one-shot
    smoother.
    """
    if smoothing not in SMOOTHING_CHOICES:
        raise ValueError(f"smoothing must be one of {', '.join(SMOOTHING_CHOICES)}, "
                         f"got {smoothing!r}")
    block = REGRESSION_BLOCK if block is None else int(block)
    if block < 1:
        raise ValueError(f"block must be a positive number of samples, got {block}")
    n = flight.n_samples
    window = int(window)
    smoothed = smoothing == "both" and window > 1
    if smoothed:
        _check_window(window, min(SMOOTHING_POLYORDER, window - 1), n)
    halo = window // 2 if smoothed else 0
    const = sample_constants(flight)
    if wind is not None:
        wind = np.asarray(wind, dtype=float)
        if wind.shape != (n, 3):
            raise ValueError(f"wind must have shape ({n}, 3), got {wind.shape}")
    delta = flight.data["delta"].to_numpy(dtype=float)
    for start in range(0, n, block):
        stop = min(start + block, n)
        lo = max(0, min(start - halo, n - window)) if smoothed else start
        hi = min(n, max(stop + halo, lo + window)) if smoothed else stop
        states = flight.data.iloc[lo:hi][list(STATE_CHANNELS)].to_numpy(dtype=float)
        part = Constants(*(v[lo:hi] if np.ndim(v) else v for v in const))
        if wind is not None:
            part = part._replace(wind_n=wind[lo:hi, 0], wind_e=wind[lo:hi, 1],
                                 wind_d=wind[lo:hi, 2])
        X = regressors(states, delta[lo:hi], part)
        if smoothed:
            X = smooth(X, window, min(SMOOTHING_POLYORDER, window - 1), axis=0)
        yield start, stop, X[start - lo:stop - lo]
