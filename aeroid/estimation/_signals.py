"""Signal helpers: the Savitzky-Golay smoother of eq. 32, SG derivatives of the rates,
and the one estimator of a channel's noise level from the data.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import savgol_coeffs, savgol_filter

from aeroid.flights import Flight

#: Width of the paper's smoother (eq. 32): 7 points, quadratic.
SMOOTHING_WINDOW = 7
SMOOTHING_POLYORDER = 2
#: Gaussian consistency factor of the median absolute deviation.
MAD_TO_SD = 1.4826
#: Floor of an estimated noise level, relative to the channel RMS (a noise-free channel
#: would otherwise get an infinite weight).
NOISE_FLOOR_FRACTION = 1e-9
#: Default SG window for the rate derivatives [samples]. The roll-rate noise of the
#: paper (+-5 %, about 2.5 rad/s) swamps the roll acceleration (~4 rad/s^2); a wider
#: window lowers the derivative noise as 1/window^1.5 but biases the q, r derivatives
#: (they oscillate at the roll frequency, ~8 Hz = 62 samples per cycle at 500 Hz).
#: 9 samples with a quartic have a gain error of -7e-5 at 62 samples per cycle (its
#: frequency response; a quadratic of the same width: -2 %).
DERIVATIVE_WINDOW = 9
DERIVATIVE_POLYORDER = 4
#: The roll rate is slow (time constant ~3 s, no roll-frequency oscillation), so its
#: derivative takes a wide window: the noise falls as window^-1.5 at no visible bias.
ROLL_DERIVATIVE_WINDOW = 101
ROLL_POLYORDER = 2


def roll_window_samples(n: int, window: int = ROLL_DERIVATIVE_WINDOW) -> int:
    """The roll rate's derivative window [samples] on a record of ``n`` samples: ``window``
    clipped to the longest odd window the record holds."""
    return min(window, n - 1 + n % 2)


def smooth(x: np.ndarray, window: int = SMOOTHING_WINDOW, polyorder: int = SMOOTHING_POLYORDER,
           axis: int = 0) -> np.ndarray:
    """Savitzky-Golay smoother of eq. 32 (``scipy.signal.savgol_filter``).

    With the defaults (width 7, quadratic) the interior weights are the paper's
    ``(-2, 3, 6, 7, 6, 3, -2) / 21``; the ends use scipy's polynomial fit (``mode='interp'``).

    Parameters
    ----------
    x : ndarray, shape (..., n, ...)
        Signal sampled uniformly along ``axis``.
    window : int
        Odd window length [samples], ``polyorder < window <= n``.
    polyorder : int
    axis : int

    Returns
    -------
    ndarray, same shape as ``x``
    """
    x = np.asarray(x, dtype=float)
    _check_window(window, polyorder, x.shape[axis])
    return savgol_filter(x, window, polyorder, axis=axis, mode="interp")


def _check_window(window: int, polyorder: int, n: int) -> None:
    if window % 2 != 1 or window < 1:
        raise ValueError(f"Savitzky-Golay window must be a positive odd integer, got {window}")
    if not 0 <= polyorder < window:
        raise ValueError(f"Savitzky-Golay polyorder must be in [0, window), got {polyorder}")
    if window > n:
        raise ValueError(f"Savitzky-Golay window {window} exceeds the {n} samples")


def estimate_noise_sd(x: np.ndarray, axis: int = 0, *, statistic: str = "mad",
                      use: np.ndarray | None = None,
                      floor_fraction: float = NOISE_FLOOR_FRACTION) -> np.ndarray:
    """Estimate the white-noise standard deviation of sampled signals from the data alone.

    The residual ``e = x - smooth(x)`` of the 7-point quadratic SG smoother (eq. 32)
    removes the smooth signal; for white noise of sd ``s`` its sd is ``s sqrt(1 - h0)``
    with ``h0 = 7/21`` the filter's centre weight, so ``s = spread(e) / sqrt(2/3)``.
    This is the one noise-level estimator of aeroid (the EBM weights, the objectives'
    noise weighting, equation error and the filters' measurement noise use it).

    Parameters
    ----------
    x : ndarray, shape (n, ...) (``axis`` = the time axis)
    axis : int
    statistic : {"mad", "rms"}
        Spread of the residual: ``1.4826 MAD`` (default; robust to the jumps of a
        relay-driven signal) or the RMS (efficient for Gaussian noise when the jumps are
        left out with ``use``).
    use : ndarray of bool, shape (n,), optional
        Samples whose residual enters the spread (default all), e.g.
        :func:`switch_free_samples`.
    floor_fraction : float
        Lower bound as a fraction of each channel's RMS (a noise-free channel would
        otherwise get an infinite weight).

    Returns
    -------
    ndarray, shape of ``x`` without ``axis``
        Noise sd in the units of ``x``.
    """
    if statistic not in ("mad", "rms"):
        raise ValueError(f"statistic must be 'mad' or 'rms', got {statistic!r}")
    x = np.moveaxis(np.asarray(x, dtype=float), axis, 0)
    resid = x - smooth(x, SMOOTHING_WINDOW, SMOOTHING_POLYORDER, axis=0)
    if use is not None:
        resid = resid[np.asarray(use, dtype=bool)]
    h0 = savgol_coeffs(SMOOTHING_WINDOW, SMOOTHING_POLYORDER)[SMOOTHING_WINDOW // 2]
    if statistic == "mad":
        spread = MAD_TO_SD * np.median(np.abs(resid - np.median(resid, axis=0)), axis=0)
    else:
        spread = np.sqrt(np.mean(resid**2, axis=0))
    sd = spread / np.sqrt(1.0 - h0)
    rms = np.sqrt(np.mean(x * x, axis=0))
    return np.maximum(sd, floor_fraction * np.maximum(rms, np.finfo(float).tiny))


def switch_free_samples(delta: np.ndarray, window: int = SMOOTHING_WINDOW) -> np.ndarray:
    """Return the samples whose ``window``-point neighbourhood holds no relay switch, (n,) bool.

    A step in ``delta`` makes the accelerations jump, which the smoother cannot follow.
    When fewer than ``max(10, n / 10)`` samples are switch-free, all are returned.
    """
    delta = np.asarray(delta, dtype=float)
    n = delta.size
    half = window // 2
    clean = np.ones(n, dtype=bool)
    for j in np.flatnonzero(np.diff(delta) != 0.0) + 1:  # delta changes between j-1 and j
        clean[max(j - half - 1, 0): j + half + 1] = False
    if clean.sum() < max(10, n // 10):
        clean[:] = True
    return clean


#: Order of the differences of :func:`difference_noise_sd`: a 4th difference spans 5
#: samples and removes a smooth signal to ``(w dt)^4`` of its size (8 Hz at 500 Hz:
#: 1e-5); on the reference flight's noise-free log its RMS is below 2e-5 of every
#: channel's RMS (measured), against 3e-4 for a 3rd difference.
DIFFERENCE_ORDER = 4
#: Fewest windows clear of a switch for the between-switch estimate; with fewer the
#: differences over all windows are used with a robust spread (MAD).
MIN_CLEAN_WINDOWS = 20


def switch_free_windows(delta: np.ndarray, width: int) -> np.ndarray:
    """Return the first sample of every ``width``-sample window whose deflection is constant.

    A relay switch between two samples (a change of ``delta`` between them) makes the
    accelerations jump and the rates' slopes break there; inside a window of constant
    logged deflection the outputs are smooth.

    Returns
    -------
    ndarray of int, shape (k,)
        Window starts ``i`` (the window is samples ``i .. i + width - 1``).
    """
    delta = np.asarray(delta, dtype=float)
    changes = np.concatenate([[0], np.cumsum(np.diff(delta) != 0.0)])
    starts = np.arange(max(delta.size - width + 1, 0))
    return starts[changes[starts + width - 1] == changes[starts]]


def difference_noise_sd(x: np.ndarray, delta: np.ndarray | None = None, *,
                        order: int = DIFFERENCE_ORDER) -> tuple[np.ndarray, str]:
    """Estimate each channel's white-noise sd from high-order differences between switches.

    The ``order``-th difference of white noise of sd ``s`` has variance ``C(2 order,
    order) s^2``; a smooth signal contributes ``(w dt)^order`` of its size. Only windows
    of ``order + 1`` samples with a constant logged deflection enter
    (:func:`switch_free_windows`), so a relay's jumps do not: on a relay switching 76
    times a second (``studies/scenarios/continuous_relay.toml`` with Cl0 = 0.095) at
    least 150 of 497 windows remain and the estimate is within 20 % (Gaussian noise) or
    30 % (the paper's noise) of the noise actually added (tests/unit/test_fitcheck.py),
    where no 7-point window is clear of a switch (the smoother's residual read az2 46x
    its noise there). With fewer than
    :data:`MIN_CLEAN_WINDOWS` such windows, the differences of all windows enter with a
    robust spread (``1.4826 MAD``, Gaussian consistency) instead of the RMS.

    Parameters
    ----------
    x : ndarray, shape (n,) or (n, m)
        Channels sampled uniformly (time along axis 0).
    delta : ndarray, shape (n,), optional
        The logged deflection (default: no switches).
    order : int

    Returns
    -------
    sd : ndarray, shape (m,) (or () for a 1-D ``x``)
        Noise sd in the units of ``x``.
    how : str
        ``"between switches"`` or ``"robust, all windows"``.
    """
    from scipy.special import comb

    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    if n <= order:
        raise ValueError(f"difference_noise_sd: {n} samples, need more than {order}")
    diffs = np.diff(x, n=order, axis=0)
    gain = np.sqrt(comb(2 * order, order, exact=True))
    starts = (np.arange(n - order) if delta is None
              else switch_free_windows(delta, order + 1))
    if starts.size >= MIN_CLEAN_WINDOWS:
        use = diffs[starts]
        return np.sqrt(np.mean(use * use, axis=0)) / gain, "between switches"
    spread = MAD_TO_SD * np.median(np.abs(diffs - np.median(diffs, axis=0)), axis=0)
    return spread / gain, "robust, all windows"


def rate_derivatives(flight: Flight, window: int = DERIVATIVE_WINDOW,
                     polyorder: int = DERIVATIVE_POLYORDER, *,
                     roll_window: int | None = None, roll_polyorder: int = ROLL_POLYORDER
                     ) -> np.ndarray:
    """Return SG derivatives of the measured p, q, r, shape (n, 3) [rad/s^2].

    ``scipy.signal.savgol_filter(..., deriv=1, delta=dt)``; ends by polynomial fit.
    ``window``/``polyorder`` apply to q and r; p uses ``roll_window`` (default: the
    same as ``window``) and ``roll_polyorder`` when a roll window is given.
    """
    rates = np.column_stack([flight["p"], flight["q"], flight["r"]])
    _check_window(window, polyorder, rates.shape[0])
    out = savgol_filter(rates, window, polyorder, deriv=1, delta=flight.dt, axis=0,
                        mode="interp")
    if roll_window is not None:
        _check_window(roll_window, roll_polyorder, rates.shape[0])
        out[:, 0] = savgol_filter(rates[:, 0], roll_window, roll_polyorder, deriv=1,
                                  delta=flight.dt, mode="interp")
    return out




def fit_noise_law(e2: np.ndarray, s2: np.ndarray, *, known: np.ndarray | None = None,
                  floor: np.ndarray | float = 0.0, passes: int = 2
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Fit the noise law ``var = a + b s^2`` per channel to squared residuals.

    The one regression behind every ``signal`` noise model: ``e2 - known`` on
    ``[1, s2]`` by non-negative least squares weighted by the inverse squared modelled
    variance ``1 / (a + b s2 + known)^2`` (the variance of a squared Gaussian residual is
    ``2 var^2``), reweighted ``passes`` times from one variance per channel.

    Parameters
    ----------
    e2 : ndarray, shape (n, m)
        Squared residuals (smoother residuals, output-error residuals, filter innovations).
    s2 : ndarray, shape (n, m)
        The squared signal each residual belongs to (smoothed measurement, model output,
        predicted measurement).
    known : ndarray, shape (n, m), optional
        A known part of each residual's variance that is not noise (a filter's
        ``H P H^T``); default none.
    floor : float or ndarray, shape (m,)
        Lower bound of ``a`` per channel.
    passes : int
        Reweighting passes (default 2).

    Returns
    -------
    a, b : ndarray, shape (m,)
    """
    from scipy.optimize import nnls

    e2 = np.asarray(e2, dtype=float).reshape(len(e2), -1)
    s2 = np.asarray(s2, dtype=float).reshape(e2.shape)
    known = np.zeros_like(e2) if known is None else np.asarray(known, float).reshape(e2.shape)
    floor = np.broadcast_to(np.asarray(floor, dtype=float), e2.shape[1:])
    a = np.empty(e2.shape[1])
    b = np.empty(e2.shape[1])
    for c in range(e2.shape[1]):
        var = np.full(e2.shape[0], max(float(np.mean(e2[:, c])), np.finfo(float).tiny))
        for _ in range(passes):
            w = 1.0 / var
            (a[c], b[c]), _ = nnls(np.column_stack([w, w * s2[:, c]]),
                                   w * (e2[:, c] - known[:, c]))
            a[c] = max(a[c], floor[c])
            var = a[c] + b[c] * s2[:, c] + known[:, c]
    return a, b


def estimate_noise_law(x: np.ndarray, *, use: np.ndarray | None = None,
                       floor_fraction: float = 1e-4) -> tuple[np.ndarray, np.ndarray]:
    """Estimate a signal-dependent noise law ``var = a + b s^2`` per channel from the data.

    The squared 7-point Savitzky-Golay residual (divided by ``1 - h0``, as in
    :func:`estimate_noise_sd`) is regressed on ``[1, s^2]``, ``s`` the smoothed signal, by
    :func:`fit_noise_law`. Multiplicative noise (the paper's eq. 43) gives ``a ~ 0``;
    additive noise ``b ~ 0``. The smoother residual also holds whatever of the signal a
    7-point quadratic does not follow (the accelerometers' roll-frequency content, a
    relay switch): a first guess, which the model-based estimators refine from their
    own residuals.

    Parameters
    ----------
    x : ndarray, shape (n, m)
    use : ndarray of bool, shape (n,), optional
        Samples that enter (e.g. :func:`switch_free_samples`).
    floor_fraction : float
        ``a`` is at least this fraction of the channel's mean squared residual.

    Returns
    -------
    a, b : ndarray, shape (m,)
        [unit^2] and [dimensionless].
    """
    x = np.asarray(x, dtype=float).reshape(len(x), -1)
    s = smooth(x, SMOOTHING_WINDOW, SMOOTHING_POLYORDER, axis=0)
    h0 = savgol_coeffs(SMOOTHING_WINDOW, SMOOTHING_POLYORDER)[SMOOTHING_WINDOW // 2]
    e2 = (x - s) ** 2 / (1.0 - h0)
    if use is not None:
        e2, s = e2[np.asarray(use, dtype=bool)], s[np.asarray(use, dtype=bool)]
    ms = np.maximum(np.mean(e2, axis=0), np.finfo(float).tiny)
    return fit_noise_law(e2, s * s, floor=floor_fraction * ms)
