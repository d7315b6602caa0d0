"""Equation-error with air data: the steady wind's uncertainty in the standard errors.

The regressors take the wind the air data imply, Kalman-smoothed
(:mod:`aeroid.estimation._air_smoother`). Its fast errors vary with the gusts and leave
correlated residuals, which the Newey-West covariance sees; its error averaged over the
record is a constant offset of the wind, which moves every coefficient and which no
residual shows (as an accelerometer position error: :mod:`baselines.equation_error`).
So it is added as a consider term: ``G S G^T``, ``G`` (n_coefficients, 3) the central
difference of the estimate over +-:data:`WIND_STEP_MPS` of a constant NED wind offset
(six more solves), ``S`` the smoother's covariance of the record-mean error.

Without an airspeed channel the wind along the path is not in the data at all (the
angles do not see it; it scales the dynamic pressure, which every coefficient absorbs:
the fit check cannot see it, ``benchmarks/bench_air_verdict.py``). Its share is then
considered as an airspeed error: ``g g^T sd^2``, ``g`` the central difference of the
estimate over an implied wind moved by +-:data:`WIND_STEP_MPS` along the logged air
velocity's direction per sample (what a steady along-path wind does to the implied wind
when the airspeed is taken as ``|u, v, w|``: along the path and, with the angle of attack,
a little across it, which the damping terms feel), ``sd`` the option
``along_path_wind_sd_mps`` or, by default, the steady wind the air data measure across
the path (a wind of that size may blow along it as well); the warning says which.
Gusts along the path are not a constant: a fit whose air data show turbulence without an
airspeed channel is refused (:func:`refuse_unseen_gusts`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from aeroid import estimation as rc
from aeroid.estimation import EstimationResult
from aeroid.flights import Flight
from aeroid.model import equations

#: The constant wind offset of the central differences [m/s] (the estimate is smooth in
#: it: the loads' dependence on a 1 m/s change at ~500 m/s is linear to ~2e-3).
WIND_STEP_MPS = 1.0


def _to_ned(flight: Flight, body: np.ndarray) -> np.ndarray:
    """Body-axis vectors (n, 3) in NED axes (the transpose of the model's ``ned_to_body``)."""
    phi, theta, psi = (flight[c] for c in ("phi", "theta", "psi"))
    return np.stack([np.einsum("nb,nb->n", body, np.stack(
        equations.ned_to_body(phi, theta, psi, *e), axis=1)) for e in np.eye(3)], axis=1)


def flight_direction(flight: Flight) -> np.ndarray:
    """The mean inertial flight direction, a NED unit vector (3,)."""
    mean = _to_ned(flight, np.stack([flight[c] for c in ("u", "v", "w")], axis=1)).mean(axis=0)
    return mean / np.linalg.norm(mean)


def air_direction(flight: Flight) -> np.ndarray:
    """The logged air velocity's direction per sample, NED unit vectors (n, 3): an airspeed
    taken ``dv`` too high moves the implied wind by ``-dv`` along it."""
    a, b = flight["alpha"], flight["beta"]
    return _to_ned(flight, np.stack([np.cos(a) * np.cos(b), np.sin(b),
                                     np.sin(a) * np.cos(b)], axis=1))


def with_wind_consider(result: EstimationResult, flight: Flight, air: rc.AirData,
                       solve: Callable[[np.ndarray], np.ndarray], owner: str,
                       along_path_sd_mps: float | None = None) -> EstimationResult:
    """``result`` with the smoothed wind's record-mean uncertainty (and, without an
    airspeed channel, the unseen along-path wind's) in its covariance (module docstring).

    ``solve(wind)`` returns the estimate (n_coefficients,) with ``wind`` (n, 3) NED.
    """
    if air.smoothed is None or result.covariance is None or not np.all(np.isfinite(result.theta)):
        return result
    s = np.array(air.smoothed.mean_covariance, dtype=float)
    warnings = list(result.warnings)
    direction = flight_direction(flight)
    along = None
    if not rc.has_airspeed(flight):
        steady = air.smoothed.wind.mean(axis=0)
        across = float(np.linalg.norm(steady - (steady @ direction) * direction))
        along = across if along_path_sd_mps is None else float(along_path_sd_mps)
        why = ("the steady wind the air data measure across the path; give an airspeed "
               "channel, or the option along_path_wind_sd_mps" if along_path_sd_mps is None
               else "the option along_path_wind_sd_mps")
        warnings = [w for w in warnings if w != air.warning]
        warnings.append(air.warning.split(", which the")[0] + ", which the logged angles "
                        f"cannot see; the standard errors consider {along:.3g} m/s of it "
                        f"({why})" if air.warning else
                        f"{owner}: the standard errors consider a wind along the path of "
                        f"{along:.3g} m/s ({why})")
    g = np.empty((result.theta.size, 3))
    for i, e in enumerate(np.eye(3)):
        plus = solve(air.wind + WIND_STEP_MPS * e)
        minus = solve(air.wind - WIND_STEP_MPS * e)
        g[:, i] = (plus - minus) / (2 * WIND_STEP_MPS)
    share = g @ s @ g.T
    g_along = None
    if along is not None:  # an airspeed off by a constant: the wind along the air velocity
        step = WIND_STEP_MPS * air_direction(flight)
        g_along = (solve(air.wind - step) - solve(air.wind + step)) / (2 * WIND_STEP_MPS)
        share = share + along**2 * np.outer(g_along, g_along)
    cov = np.asarray(result.covariance, dtype=float) + share
    info = {**result.info, "air_data_wind_consider": {
        "covariance_mps2": s, "sensitivity": g, "direction_ned": direction,
        "along_path_sd_mps": along, "along_path_sensitivity": g_along,
        "mean_sd_mps": np.sqrt(np.diag(s))},
        "air_data_smoother": {"model": air.smoothed.model, **(air.smoothed.dryden or {})}}
    return dataclasses.replace(result, covariance=cov, stderr=np.sqrt(np.abs(np.diag(cov))),
                               info=info, warnings=tuple(warnings))


def refuse_unseen_gusts(result: EstimationResult, flight: Flight, owner: str
                        ) -> EstimationResult:
    """``result`` refused (``success = False``) when its air data show turbulence and the
    log has no airspeed channel; unchanged otherwise. Written once, for EBM-PSO and
    SEBM-PSO too: :func:`aeroid.estimation.refuse_unseen_gusts`."""
    return rc.refuse_unseen_gusts(result, flight, owner)


__all__ = ["WIND_STEP_MPS", "flight_direction", "refuse_unseen_gusts", "with_wind_consider"]
