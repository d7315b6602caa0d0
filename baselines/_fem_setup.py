"""The filter-error method's start: measurement noise, initial state, gust time constant.

Measurement noise (``measurement_noise``): ``metadata`` takes each channel's sd from the
flight's noise model (``metadata['noise']``, :func:`aeroid.flights.noise_from_dict`; a
signal-proportional model such as the paper's eq. 43 by its per-channel, homoscedastic
form); ``innovations`` starts from the data's smoother residuals
(:func:`aeroid.estimation.estimate_noise_sd`) and re-estimates the variances from the
innovations after every iteration (``R_c = mean(nu_c^2 - (H P^- H^T)_cc)``, FVSysID's
relaxation, taken only as far as it lowers the likelihood's cost:
:func:`baselines._fem_fit.noise_step`); ``auto`` is ``metadata`` when the flight has a
noise model with noise, else ``innovations``, and says which in one line.
"""

from __future__ import annotations

import logging
import math
from typing import Any, NamedTuple

import numpy as np

from aeroid import estimation
from aeroid.errors import AeroidError, EstimatorError
from aeroid.flights import Flight, noise_from_dict
from aeroid.model import NAMES, OUTPUT_CHANNELS, PSI, U, W
from baselines import _common

#: Floor of each channel's noise variance as a fraction of its mean square (output-error's
#: R_FLOOR_REL is the same idea): keeps S positive definite on noise-free channels.
R_FLOOR_REL = 1e-10


class Noise(NamedTuple):
    """The measurement noise the filter starts with (module docstring)."""

    R: np.ndarray  # (m,) variances
    floor: np.ndarray  # (m,)
    update: bool | np.ndarray  # re-estimated from the innovations (or per channel)
    source: str  # "metadata" or "innovations"
    note: str


def measurement_noise(flight: Flight, zs: np.ndarray, mode: str, owner: str) -> Noise:
    """Return the measurement-noise variances per output channel (module docstring).

    Raises
    ------
    EstimatorError
        ``metadata`` on a flight without a noise model, or whose model has no noise.
    """
    floor = R_FLOOR_REL * np.mean(zs * zs, axis=0) + 1e-300
    given = flight.metadata.get("noise")
    sd = None
    if isinstance(given, dict) and mode in ("auto", "metadata"):
        try:
            model = noise_from_dict(dict(given))
            sd = np.sqrt(np.mean(model.output_sd(zs, form="homoscedastic") ** 2, axis=0))
        except (AeroidError, ValueError, TypeError) as exc:
            if mode == "metadata":
                raise EstimatorError(f"{owner}: the flight's noise metadata cannot be read "
                                     f"({' '.join(str(exc).split())}); use "
                                     "measurement_noise = innovations") from None
        if sd is not None and not np.all(sd > 0):
            if mode == "metadata":
                raise EstimatorError(f"{owner}: the flight's noise model ({given.get('model')}) "
                                     "has no noise on some output; the filter needs a "
                                     "measurement noise: use measurement_noise = innovations")
            sd = None
    elif mode == "metadata":
        raise EstimatorError(f"{owner}: measurement_noise = metadata, but the flight has no "
                             "noise metadata (metadata['noise']); use measurement_noise = "
                             "innovations")
    if sd is not None:
        shown = ", ".join(f"{c} {s:.3g}" for c, s in zip(OUTPUT_CHANNELS, sd, strict=True))
        note = (f"{owner}: measurement noise from the flight's noise metadata "
                f"({given.get('model')}, per channel): sd {shown}")
        return Noise(np.maximum(sd**2, floor), floor, False, "metadata", note)
    sd = _common.measurement_sd(flight, zs, "data", 1e-5)
    note = (f"{owner}: measurement noise estimated from the innovations (started from the "
            "data's smoother residuals; the flight "
            f"{'has no usable' if mode == 'auto' else 'was not asked for its'} noise metadata)")
    return Noise(np.maximum(sd**2, floor), floor, True, "innovations", note)


def initial_state(flight: Flight, zs: np.ndarray, R: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The state at the first sample and its covariance (N_STATE,), (N_STATE, N_STATE).

    The logged state with the rates smoothed (as output-error's start); sd: a
    reconstruction's (``metadata['initial_state_sd']``) where given, else each state
    channel's noise level from the data, floored at a logger's resolution (the EKF's
    :meth:`baselines._common.AugmentedFilterOptions.setup`), the rates at the gyros' noise.
    """
    states = flight.states()
    x0 = states[0].copy()
    x0[_common.RATES] = _common.smoothed_start(zs[:, _common.GYROS])
    rms = np.sqrt(np.mean(states * states, axis=0))
    sd = np.maximum(estimation.estimate_noise_sd(states),
                    np.maximum(_common.INITIAL_SD_FLOOR_REL * rms, _common.INITIAL_SD_FLOOR))
    given = _common.reconstruction_sd(flight)
    if given is not None:
        sd[np.r_[U:W + 1, _common.ANGLES.start:PSI + 1]] = given  # u v w, the angles
    sd[_common.RATES] = np.sqrt(R[_common.GYROS])
    return x0, np.diag(sd**2)


def gust_decay(flight: Flight, scale_length_m: float) -> tuple[float, float, float]:
    """``(a, tau, V)``: the gusts' one-step decay ``exp(-dt / tau)``, ``tau = L / V`` [s], and
    the speed ``V`` [m/s] (mean of ``|u, v, w|`` over the record: the airspeed up to the
    wind, a few m/s in hundreds)."""
    speed = float(np.mean(np.linalg.norm(flight.states()[:, :3], axis=1)))
    if not speed > 0:
        raise EstimatorError("filter-error: the flight's speed is zero; the gusts' time "
                             "constant L / V needs an airspeed")
    tau = scale_length_m / speed
    return math.exp(-flight.dt / tau), tau, speed


def say(note: str) -> None:
    """Log a one-line notice (logger ``aeroid``, INFO)."""
    logging.getLogger("aeroid").info(note)


def free_parameters(prior: np.ndarray, holds: Any = None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The fitted coefficients' indices, their scale (the prior's value, 1 where it is 0)
    and their Gaussian priors' means and information (zero without ``holds``, an
    :class:`aeroid.estimation.Holds`): what filter-error's :class:`_fem_fit.Problem` takes,
    written once for the fit and for the gust filters' information."""
    free = np.arange(len(NAMES)) if holds is None else holds.free_index
    scale = np.where(prior[free] != 0.0, prior[free], 1.0)
    mean, info_prior = np.zeros(free.size), np.zeros(free.size)
    if holds is not None:
        all_mean, _ = holds.prior_mean_sd()
        info_prior = holds.prior_information()[free]
        mean = np.where(info_prior > 0, all_mean[free], 0.0)
    return free, scale, mean, info_prior
