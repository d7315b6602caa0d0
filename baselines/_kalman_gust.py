"""Gust states of the augmented-state EKF and UKF (issue 26; private).

``gust_sd_mps > 0`` or ``estimate_gust_sd`` (:class:`baselines._imu_states.
ImuFilterOptions`): three more states ``g``, the gust's north, east and down components
[m/s], each a first-order Gauss-Markov process (Dryden's first-order approximation)::

    g_{k+1} = phi g_k + n_k,   phi = exp(-dt V / L),   var(n_k) = sigma^2 (1 - phi^2)

with ``L`` the scale length (``gust_scale_length_m``), ``V`` the mean measured speed of
the record and ``sigma`` the gust intensity, started stationary (0 with sd ``sigma``).
The loads see the air-relative velocity of the wind ``w + g`` (``w`` the steady wind's
states with ``estimate_wind``, else 0): the model is :func:`baselines._kalman_wind.
wind_model`'s, evaluated at that sum, so its Jacobian in ``g`` is its Jacobian in the
wind (exact, CasADi AD), and the gust's own rows are ``phi I``.

The intensity, when estimated, maximises the innovations' Gaussian likelihood
(:attr:`baselines._kalman.FilterOutput.neg_log_likelihood`) of the first pass over
``log sigma`` in :data:`GUST_SD_BOUNDS_MPS` (:func:`scipy.optimize.minimize_scalar`,
bounded), each trial one filter pass.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
from scipy.optimize import minimize_scalar

from aeroid.errors import EstimatorError
from aeroid.model import P
from baselines import _common, _kalman
from baselines._gust_verdict import AXIAL_LIMIT, gust_verdict

#: Names of the gust states (north, east, down [m/s]).
GUST_NAMES = ("gust_n", "gust_e", "gust_d")
#: The search interval of an estimated gust intensity [m/s]: light to severe turbulence
#: (MIL-F-8785C's intensities at low altitude run ~0.5-7 m/s), a decade either side of 1.
GUST_SD_BOUNDS_MPS = (0.1, 10.0)
#: The search stops when the bracket in log(sigma) is this narrow (5 %: the intensity's
#: own uncertainty from one 1 s record is larger).
GUST_SD_LOG_TOL = 0.05
#: At most this many trial passes in the search.
GUST_SD_MAX_TRIALS = 12
#: Said with ``estimate_wind`` and gust states together (measured,
#: ``benchmarks/results/gust_filters.md``: Dryden sd 3 m/s, seeds 1-4).
BOTH_WARNING = ("gust states with estimate_wind: the passes walk along the along-path wind "
                "(measured in Dryden sd 3 m/s: 7/8 fits refused, 23-37 % mean error, the "
                "one passed 32 % off); gust states alone also carry a steady wind (12 % "
                "mean error over 8 seeds, all passed)")


def gust_phi(dt: float, speed_mps: float, scale_length_m: float) -> float:
    """The Gauss-Markov transition ``exp(-dt V / L)`` of one sample interval."""
    return math.exp(-dt * speed_mps / scale_length_m)


def gust_setup(setup: _common.FilterSetup, sd_mps: float, phi: float) -> _common.FilterSetup:
    """``setup`` with the gust states appended: stationary start (0, ``sd_mps``), process
    noise ``sd_mps^2 (1 - phi^2)`` per interval."""
    n, k = setup.x0.size, len(GUST_NAMES)
    P0, Q = np.zeros((n + k, n + k)), np.zeros((n + k, n + k))
    P0[:n, :n], Q[:n, :n] = setup.P0, setup.Q
    P0[n:, n:] = sd_mps**2 * np.eye(k)
    Q[n:, n:] = sd_mps**2 * (1.0 - phi**2) * np.eye(k)
    return setup._replace(x0=np.concatenate([setup.x0, np.zeros(k)]), P0=P0, Q=Q)


def with_gusts(wind: _kalman.DiscreteModel, phi: float, steady: bool) -> _kalman.DiscreteModel:
    """Return the model with gust states from ``wind`` (:func:`baselines._kalman_wind.
    wind_model`: state ``[x, theta, d, w]``, the wind ``w`` its last three entries).

    ``steady``: the state is ``[x, theta, d, w, g]`` and the loads see ``w + g``;
    otherwise ``[x, theta, d, g]`` and they see ``g``. Jacobians: the wind model's, its
    wind columns for both ``w`` and ``g``; ``g``'s rows of the transition ``phi I``.
    """
    k = len(GUST_NAMES)
    n_in = wind.dim_x
    n = n_in + (k if steady else 0)
    gust = slice(n - k, n)
    wind_cols = slice(n_in - k, n_in)

    def inner(z: np.ndarray) -> np.ndarray:
        if not steady:
            return z
        z_in = z[..., :n_in].copy()
        z_in[..., wind_cols] += z[..., gust]
        return z_in

    def outer_jacobian(J: np.ndarray) -> np.ndarray:  # columns: d/dw and d/dg alike
        return J if not steady else np.concatenate([J, J[:, wind_cols]], axis=1)

    def transition(z: np.ndarray, k_: int) -> tuple[np.ndarray, np.ndarray]:
        z_next_in, F_in = wind.transition(inner(z), k_)
        z_next = np.array(z, dtype=float)
        z_next[:n_in - k] = z_next_in[:n_in - k]  # the airframe's states and the constants
        z_next[gust] = phi * z[gust]
        F = np.zeros((n, n))
        F[:n_in - k] = outer_jacobian(F_in)[:n_in - k]
        if steady:
            F[wind_cols, wind_cols] = np.eye(k)
        F[gust, gust] = phi * np.eye(k)
        return z_next, F

    def observe(z: np.ndarray, k_: int) -> tuple[np.ndarray, np.ndarray]:
        y, H = wind.observe(inner(z), k_)
        return y, outer_jacobian(np.asarray(H))

    def transition_batch(Z: np.ndarray, k_: int) -> np.ndarray:
        assert wind.transition_batch is not None
        out = np.array(Z, dtype=float)
        out[:, :n_in - k] = wind.transition_batch(inner(Z), k_)[:, :n_in - k]
        out[:, gust] = phi * Z[:, gust]
        return out

    def observe_batch(Z: np.ndarray, k_: int) -> np.ndarray:
        assert wind.observe_batch is not None
        return wind.observe_batch(inner(Z), k_)

    return _kalman.DiscreteModel(n, wind.dim_z, transition, observe, transition_batch,
                                 observe_batch)


@dataclasses.dataclass(frozen=True)
class GustSearch:
    """The estimated intensity: ``sd_mps``, the trials' ``(sd, nll)`` and their count."""

    sd_mps: float
    trials: tuple[tuple[float, float], ...]

    def describe(self) -> str:
        """One line: the estimate and how it was found."""
        at_bound = min(abs(math.log(self.sd_mps / b)) for b in GUST_SD_BOUNDS_MPS) < (
            2 * GUST_SD_LOG_TOL)
        return (f"estimated: the maximum of the first pass's innovation likelihood over "
                f"{len(self.trials)} trial passes, bounded to "
                f"{GUST_SD_BOUNDS_MPS[0]:g}-{GUST_SD_BOUNDS_MPS[1]:g} m/s"
                + ("; at the search's bound" if at_bound else ""))


def search_gust_sd(nll_of: Callable[[float], float]) -> GustSearch:
    """Maximise the likelihood ``-nll_of(sd)`` over ``log sd`` (bounded Brent)."""
    trials: list[tuple[float, float]] = []

    def cost(log_sd: float) -> float:
        sd = math.exp(log_sd)
        value = float(nll_of(sd))
        trials.append((sd, value))
        return value if math.isfinite(value) else 1e300

    lo, hi = (math.log(b) for b in GUST_SD_BOUNDS_MPS)
    found = minimize_scalar(cost, bounds=(lo, hi), method="bounded",
                            options={"xatol": GUST_SD_LOG_TOL, "maxiter": GUST_SD_MAX_TRIALS})
    best = min(trials, key=lambda t: t[1] if math.isfinite(t[1]) else math.inf)
    sd = best[0] if math.isfinite(best[1]) else math.exp(float(found.x))
    return GustSearch(sd, tuple(trials))


def gust_report(out: _kalman.FilterOutput, first: int, sd_mps: float, scale_length_m: float,
                speed_mps: float, how: str, dt: float, who: str) -> tuple[dict, str]:
    """``info['gust_*']`` (the intensity, the time constant, the filtered gust path and
    its sd, the gust verdict's figures and its one-line refusal, empty when it passed:
    :mod:`baselines._gust_verdict`) and the fit's one-line notice."""
    k = len(GUST_NAMES)
    path, sd = out.x[:, first:first + k], out.sd[:, first:first + k]
    tau = scale_length_m / speed_mps
    state = out.x[:, _common.STATES]
    verdict = gust_verdict(path, state[:, _common.ANGLES], state[:, P], sd_mps, tau, dt,
                           who=who, velocity=state[:, :3])
    info = {"gust_sd_mps": sd_mps, "gust_scale_length_m": scale_length_m,
            "gust_time_constant_s": tau, "gust_ned_mps": path, "gust_stderr_mps": sd,
            "gust_verdict": verdict.figures, "gust_verdict_refusal": verdict.message}
    rms = np.sqrt(np.nanmean(path * path, axis=0))
    return info, (f"gusts: three Gauss-Markov gust states (north, east, down), intensity "
                  f"{sd_mps:.3g} m/s ({how}), time constant L/V = {scale_length_m:g} m / "
                  f"{speed_mps:.1f} m/s = {tau:.3g} s; filtered gust RMS "
                  + ", ".join(f"{r:.2f}" for r in rms) + " m/s"
                  + ("" if verdict.message else
                     f"; gust verdict passed (axial z {verdict.figures['axial_z']:.2f}, limit "
                     f"{AXIAL_LIMIT:g}): in turbulence weak evidence of a right model, as "
                     "pitch and normal-force errors hide in the gusts unseen"))


def refuse_with(est: object, what: str) -> None:
    """Raise the one-line error for gust states combined with ``what`` (not done)."""
    if getattr(est, "gust_sd_mps", 0.0) > 0 or getattr(est, "estimate_gust_sd", False):
        raise EstimatorError(f"{getattr(est, 'name', '?')}: gust states with {what} are not "
                             "available (built for one flight without GNSS aiding); set "
                             "gust_sd_mps = 0 and estimate_gust_sd = false")
