"""A steady wind as three constant states of the augmented-state EKF and UKF (issue 26).

``estimate_wind`` (:class:`baselines._imu_states.ImuFilterOptions`): the filter's state
becomes ``[x, theta, d, w]``, ``w`` the wind's north, east and down components [m/s] (the
air's velocity over the ground), constant in the transition, started at 0 (still air)
with :data:`WIND_SD_MPS` as sd; later carried passes start it where the last ended, with
the coefficients (:func:`carried`: their joint covariance, inflated); the EKF's smoothed
passes (:mod:`baselines._kalman_smoother`, its default with the wind) start each pass from
that prior instead. The loads see the
air-relative velocity: the wind enters the model's constants or, with per-sample values,
each sample's exogenous row through :func:`aeroid.model.with_wind_symbols` (output-error's
own symbols, the rotation written once in :mod:`aeroid.model`); the Jacobians are exact
(CasADi AD), the UKF's sigma points go through the same CasADi functions mapped over them.

The default ``estimate_wind = "auto"`` carries the wind unless the log says still air
(:mod:`baselines._wind_auto`); :func:`blocked` names where the filters do not carry it
(still air is then assumed there, said in one line).
"""

from __future__ import annotations

import functools
from typing import Any

import casadi as ca
import numpy as np

import aeroid
from aeroid.errors import EstimatorError
from aeroid.flights import Flight, Windows, model_constants
from aeroid.model import EXOGENOUS, N_COEFFICIENTS, N_STATE, Constants, Record, symbolic
from aeroid.model import with_wind_symbols as add_wind
from baselines import _common, _kalman
from baselines._wind_auto import check_wind_option, choose, is_auto

#: Names of the wind states (output-error's names of its wind parameters).
WIND_NAMES = ("wind_n", "wind_e", "wind_d")
#: Initial sd of each wind component [m/s] (default of the option ``wind_sd_mps``): a
#: steady wind of a few m/s (the issue's 5 m/s) lies within one sd.
WIND_SD_MPS = 10.0


def wind_setup(setup: _common.FilterSetup, sd_mps: float) -> _common.FilterSetup:
    """``setup`` with the wind states appended: started at 0 with ``sd_mps``, no process
    noise (a steady wind)."""
    n, k = setup.x0.size, len(WIND_NAMES)
    P0, Q = np.zeros((n + k, n + k)), np.zeros((n + k, n + k))
    P0[:n, :n], P0[n:, n:], Q[:n, :n] = setup.P0, sd_mps**2 * np.eye(k), setup.Q
    return setup._replace(x0=np.concatenate([setup.x0, np.zeros(k)]), P0=P0, Q=Q)


def carried(setup: _common.FilterSetup, last: _kalman.FilterOutput, first: int
            ) -> _common.FilterSetup:
    """``setup`` with the wind started where the pass ``last`` ended, with
    :data:`baselines._common.PASS_INFLATION` times its sd (as the coefficients are)."""
    wind = slice(first, first + len(WIND_NAMES))
    x0, P0 = setup.x0.copy(), setup.P0.copy()
    x0[wind] = last.x[-1, wind]
    both = np.r_[_common.COEFFICIENTS, wind]  # with their correlation (the airspeed's ridge)
    P0[np.ix_(both, both)] = _common.PASS_INFLATION**2 * last.P[np.ix_(both, both)]
    return setup._replace(x0=x0, P0=P0)


@functools.lru_cache(maxsize=16)
def _wind_functions(const: Constants, dt: float, substeps: int, n_pieces: int,
                    varying: bool, position_free: tuple[int, ...]
                    ) -> tuple[ca.Function, ca.Function, ca.Function, ca.Function]:
    n_free, n_wind = len(position_free), len(WIND_NAMES)
    n_aug = N_STATE + N_COEFFICIENTS + n_free + n_wind
    z = ca.SX.sym("z", n_aug)
    sym = symbolic.interval_symbols(n_pieces, varying)
    delta = ca.SX.sym("delta")
    exo = ca.SX.sym("exo", sym.exo_a.shape[0])
    pos_given = ca.SX.sym("pos", 6)
    x, theta = z[:N_STATE], z[N_STATE:N_STATE + N_COEFFICIENTS]
    offsets = z[N_STATE + N_COEFFICIENTS:N_STATE + N_COEFFICIENTS + n_free]
    const_w, sym_w, wind_row = add_wind(const, sym, z[n_aug - n_wind:])
    z_next = ca.vertcat(symbolic.interval_step_symbolic(x, theta, sym_w, const_w, dt,
                                                        substeps), z[N_STATE:])
    f = ca.Function("f_wind", [z, *sym], [z_next, ca.densify(ca.jacobian(z_next, z))])
    f_plain = ca.Function("f_wind_plain", [z, *sym], [z_next])
    pos = ca.vertcat(*[pos_given[c] + offsets[position_free.index(c)]
                       if c in position_free else pos_given[c] for c in range(6)])
    y = symbolic.measurement(x, delta, theta, pos,
                             symbolic.sample_constants(const_w, exo + wind_row))
    h = ca.Function("h_wind", [z, delta, exo, pos_given], [y, ca.densify(ca.jacobian(y, z))])
    h_plain = ca.Function("h_wind_plain", [z, delta, exo, pos_given], [y])
    return f, h, f_plain, h_plain


def wind_model(flight: Flight, substeps: int, record: Record,
               position_free: tuple[int, ...]) -> _kalman.DiscreteModel:
    """The augmented model ``[x, theta, d, w]`` of ``flight`` (as
    :func:`baselines._augmented.augmented_model`, plus the wind states ``w``)."""
    const = model_constants(flight)
    varying = record.exogenous is not None
    # cached by the constants: the per-sample values replace the exogenous fields
    const = Constants(*(float(v) for v in const))
    if varying:
        const = const._replace(**dict.fromkeys(EXOGENOUS, 0.0))
    delta, pieces_table, exo_table = record.symbolic_inputs()
    delta = delta[0]
    pos_flat = flight.airframe.accel_positions.ravel()
    f, h, f_plain, h_plain = _wind_functions(const, float(record.dt), int(substeps),
                                             int(record.n_pieces), varying,
                                             tuple(position_free))
    n_aug = f.size1_in(0)
    mapped: dict[tuple[str, int], ca.Function] = {}

    def transition(z: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        z_next, F = f(z, pieces_table[:, k], exo_table[:, k], exo_table[:, k + 1])
        return np.asarray(z_next).ravel(), np.asarray(F)

    def observe(z: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        y, H = h(z, delta[k], exo_table[:, k], pos_flat)
        return np.asarray(y).ravel(), np.asarray(H)

    def over_points(fun: ca.Function, name: str, n: int) -> ca.Function:
        if (name, n) not in mapped:
            mapped[(name, n)] = fun.map(n)
        return mapped[(name, n)]

    def transition_batch(Z: np.ndarray, k: int) -> np.ndarray:
        step = over_points(f_plain, "f", len(Z))
        return np.asarray(step(Z.T, pieces_table[:, k], exo_table[:, k],
                               exo_table[:, k + 1])).T

    def observe_batch(Z: np.ndarray, k: int) -> np.ndarray:
        meas = over_points(h_plain, "h", len(Z))
        return np.asarray(meas(Z.T, delta[k], exo_table[:, k], pos_flat)).T

    return _kalman.DiscreteModel(n_aug, len(aeroid.model.OUTPUT_CHANNELS), transition,
                                 observe, transition_batch, observe_batch)


def refuse_with(est: Any, what: str) -> None:
    """Raise the one-line error for ``estimate_wind`` combined with ``what`` (not done)."""
    if getattr(est, "estimate_wind", False) is True:  # "auto": resolved before (blocked)
        raise EstimatorError(f"{est.name}: estimate_wind with {what} is not available (a "
                             "steady wind is estimated on one flight without GNSS aiding); "
                             "set estimate_wind = false")


def wind_report(out: _kalman.FilterOutput, first: int) -> tuple[dict[str, Any], str]:
    """``info['wind_ned_mps']``, ``info['wind_stderr_mps']`` from the final filtered state
    (the wind states from index ``first``) and the fit's one-line notice."""
    k = len(WIND_NAMES)
    wind, sd = out.x[-1, first:first + k], np.sqrt(np.diag(out.P)[first:first + k])
    shown = ", ".join(f"{axis} {w:+.2f} +- {s:.2f}" for axis, w, s
                      in zip(("north", "east", "down"), wind, sd, strict=True))
    info = {"wind_ned_mps": wind.tolist(), "wind_stderr_mps": sd.tolist()}
    return info, (f"estimate_wind: a steady wind was carried as three constant states "
                  f"(the loads see the air-relative velocity): {shown} m/s; the along-path "
                  "component trades with every coefficient (the dynamic pressure): carried "
                  "passes walk along it on noisy flights and are refused when they do not "
                  "settle; the smoothed passes (both filters' default with the wind) were "
                  "measured at output-error's accuracy, and an airspeed channel (air_data) "
                  "pins it (benchmarks/results/wind_filters.md, kalman_air.md)")


def blocked(est: Any, data: Flight | Windows) -> str:
    """Why the EKF/UKF with ``est``'s options do not carry a wind on ``data`` ("" when they
    do): the combinations refused with ``estimate_wind = true``, and gust states (they
    carry the moving air: with the steady wind's states as well the passes walk along the
    along-path wind, measured: README "Gust states in the EKF and UKF")."""
    if isinstance(data, Windows):
        return f"{est.name} does not carry a wind over several windows"
    if getattr(data.airframe, "tables", None) is not None:
        return f"{est.name} does not carry a wind with coefficient tables ([tables])"
    if getattr(est, "aiding", "none") != "none":
        return f"{est.name} does not carry a wind with aiding = {est.aiding}"
    if getattr(est, "gusts", False):
        return (f"{est.name}'s gust states carry the moving air (with the steady wind's "
                "states too its passes walk along the along-path wind, measured)")
    if getattr(est, "passes", "auto") == "carried" and "airspeed" not in data.channels:
        return (f"{est.name}'s carried passes walk along the along-path wind without an "
                "airspeed channel (measured; passes = auto smooths them)")
    return ""


def carries_wind(est: Any, flight: Flight) -> bool:
    """Whether ``est``'s filter of ``flight`` carries the wind states: ``estimate_wind``,
    with ``auto`` resolved there as the fit resolves it (:func:`baselines._wind_auto.
    choose`; the fit says it in one line, this does not): for a set-up built outside a
    fit (``est.setup(flight)``)."""
    if is_auto(est):
        return choose(est.name, flight, blocked(est, flight)).used
    return est.estimate_wind is True


__all__ = ["WIND_NAMES", "WIND_SD_MPS", "blocked", "carried", "carries_wind",
           "check_wind_option", "refuse_with", "wind_model", "wind_report", "wind_setup"]
