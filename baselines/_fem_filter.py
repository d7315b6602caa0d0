"""The filter-error method's filter: an EKF with NED gust states, many parameter sets at once.

The filter's state is the model's state ``x`` and the wind ``w`` [m/s, NED] the loads see
(the air's velocity over the ground: a steady part ``w_s``, a parameter, plus a gust
``g = w - w_s``). Each gust component is a first-order Gauss-Markov process, Dryden's
first-order approximation (time constant ``tau = L / V``, intensity ``sigma``):

    g_{k+1} = a g_k + n_k,    a = exp(-dt / tau),    n_k ~ N(0, sigma^2 (1 - a^2) I),

started stationary (``g_0 ~ N(0, sigma^2 I)``). Over a sample interval the wind is held
at ``w_k`` in the loads. The transition and measurement of ``[x, theta, w]`` and their
exact Jacobians are the EKF's steady-wind functions (:mod:`baselines._kalman_wind`,
CasADi AD of the model written once in :mod:`aeroid.model`): the wind there is constant,
here it decays towards ``w_s`` (``F_ww = a I``) and carries the gusts' process noise. The
coefficients ``theta`` are parameters, not states: their columns of the Jacobians are
dropped. Gusts fixed in the air turn in body axes at the roll rate; in NED they do not,
and the measurement's Jacobian ``H = dh/d(x, w)`` turns with the roll angle: the gain is
time-varying (the README's section on the failed steady-gain prototype).

The runs of one call are independent filters (the finite-difference perturbations of
:mod:`baselines._fem_fit`), evaluated together: per sample one call of the compiled
prediction and one of the update (:func:`baselines._fem_model.step_functions`, the
covariance algebra in C), each mapped over all runs. Against the same algebra in batched
numpy: a batch of 11 filters 0.15 -> 0.08 s, of 1 0.060 -> 0.017 s (reference flight,
min of 5), innovations the same to 7e-13.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import casadi as ca
import numpy as np

from aeroid.flights import Flight, flight_record, model_constants
from aeroid.model import EXOGENOUS, N_STATE, OUTPUT_CHANNELS, Buffered, Constants
from baselines._fem_model import N_FILTER, N_WIND, step_functions


class FilterRuns(NamedTuple):
    """The innovations of ``r`` filter runs over ``n`` samples, ``m`` outputs.

    Attributes
    ----------
    innovation : ndarray, shape (r, n, m)
        Measurement minus its prediction before each update.
    S : ndarray, shape (r, n, m, m)
        Innovation covariance ``H P^- H^T + R``.
    ok : ndarray, shape (r,), bool
        False where a run's state or covariance stopped being finite or S positive definite.
    x : ndarray, shape (r, n, N_FILTER)
        Filtered state ``[x, w]`` at each sample.
    """

    innovation: np.ndarray
    S: np.ndarray
    ok: np.ndarray
    x: np.ndarray


@dataclass(frozen=True)
class GustModel:
    """The flight's transition and measurement with the wind as states (CasADi).

    Build with :func:`gust_model`. ``predict`` and ``update``: one EKF step of the filter's
    state ``xw = [x, w]`` and its covariance (:func:`baselines._fem_model.step_functions`).
    """

    predict: ca.Function
    update: ca.Function
    delta: np.ndarray
    pieces: np.ndarray
    exo: np.ndarray
    positions: np.ndarray
    dt: float
    compiled: bool
    #: Air-data channels measured after the IMU's, their calibration parameters, the
    #: probe's position [m, body] (:mod:`baselines._fem_air`; none by default).
    air_channels: tuple[str, ...] = ()
    calibration: tuple[str, ...] = ()
    probe: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def n_samples(self) -> int:
        """Samples of the record."""
        return int(self.delta.size)


def gust_model(flight: Flight, substeps: int, input: str, delay_s: float,  # noqa: A002
               compile_model: bool = True, channels: tuple[str, ...] = (),
               calibration: tuple[str, ...] = (), probe: np.ndarray | None = None
               ) -> GustModel:
    """The model of ``flight`` with the wind as states, accelerometers at the airframe's
    positions (:func:`baselines._fem_model.step_functions`); with air-data ``channels``
    measured at ``probe`` [m, body] with ``calibration`` parameters after the IMU's."""
    record = flight_record(flight, input, delay_s)
    const = Constants(*(float(v) for v in model_constants(flight)))
    varying = record.exogenous is not None
    if varying:  # the per-sample values replace the exogenous fields (as wind_model)
        const = const._replace(**dict.fromkeys(EXOGENOUS, 0.0))
    delta, pieces, exo = record.symbolic_inputs()
    predict, update, compiled = step_functions(const, float(record.dt), int(substeps),
                                               int(record.n_pieces), varying,
                                               len(OUTPUT_CHANNELS), compile_model,
                                               tuple(channels), tuple(calibration))
    return GustModel(predict, update, delta[0], pieces, exo,
                     flight.airframe.accel_positions.ravel(), float(record.dt), compiled,
                     tuple(channels), tuple(calibration),
                     np.zeros(3) if probe is None else np.asarray(probe, dtype=float))


_WIND = slice(N_STATE, N_FILTER)


def run_filters(model: GustModel, theta: np.ndarray, steady: np.ndarray, sigma: np.ndarray,
                decay: float, x0: np.ndarray, P0x: np.ndarray, R: np.ndarray,
                zs: np.ndarray, cal: np.ndarray | None = None) -> FilterRuns:
    """Run ``r`` gust filters over the measurements ``zs`` (module docstring).

    Parameters
    ----------
    model : GustModel
    theta : ndarray, shape (r, N_COEFFICIENTS)
        Coefficients of each run.
    steady : ndarray, shape (r, N_WIND)
        Steady wind of each run [m/s, NED].
    sigma : ndarray, shape (r,)
        Gust intensity of each run [m/s].
    decay : float
        ``a = exp(-dt / tau)``.
    x0 : ndarray, shape (N_STATE,)
        The model's state at the first sample (every run).
    P0x : ndarray, shape (N_STATE, N_STATE)
        Its covariance.
    R : ndarray, shape (m,) or (n, m)
        Measurement-noise variances (per channel, or per sample and channel).
    zs : ndarray, shape (n, m)
        The IMU's outputs, then the model's air-data channels (``model.air_channels``).
    cal : ndarray, shape (r, len(model.calibration)), optional
        The air data's calibration parameters of each run (zeros when not given).

    Returns
    -------
    FilterRuns
    """
    r = theta.shape[0]
    n, m = zs.shape
    R = np.broadcast_to(np.asarray(R, dtype=float), (n, m))
    x = np.empty((r, N_FILTER))
    x[:, :N_STATE] = x0
    x[:, _WIND] = steady
    P = np.zeros((r, N_FILTER, N_FILTER))
    P[:, :N_STATE, :N_STATE] = P0x
    P[:, _WIND, _WIND] = (sigma**2)[:, None, None] * np.eye(N_WIND)
    q = sigma**2 * (1.0 - decay**2)
    # numpy buffers shared with CasADi (aeroid.model.Buffered): per-run inputs as columns
    # (column-major), the record's and the measurements shared by every run
    predict = Buffered(model.predict.map(r, [False] * 4 + [True, False] + [True] * 3,
                                         [False] * 2),
                       [x.T, np.hstack(list(P)), theta.T, steady.T, [decay], q[None],
                        model.pieces[:, 0], model.exo[:, 0], model.exo[:, 0]])
    air: list = []  # the calibration per run, the probe shared
    if model.air_channels:
        cal = np.zeros((r, len(model.calibration))) if cal is None else np.asarray(cal, float)
        air = [np.ascontiguousarray(cal.T), model.probe]
    update = Buffered(model.update.map(r, [False] * 3 + [True] * 5 + [False, True][:len(air)],
                                       [False] * 4),
                      [x.T, np.hstack(list(P)), theta.T, model.delta[:1], model.exo[:, 0],
                       model.positions, zs[0], R[0], *air])
    innovation = np.empty((r, n, m))
    S_all = np.empty((r, n, m, m))
    xs = np.empty((r, n, N_FILTER))
    for k in range(n):
        if k > 0:
            predict.inputs[1][:] = P.ravel()  # symmetric: either order
            predict.inputs[6][:] = model.pieces[:, k - 1]
            predict.inputs[7][:] = model.exo[:, k - 1]
            predict.inputs[8][:] = model.exo[:, k]
            x_next, P_next = predict(x.ravel())
            x = x_next.reshape(r, N_FILTER)
            P = P_next.reshape(r, N_FILTER, N_FILTER)
        update.inputs[1][:] = P.ravel()
        update.inputs[3][0] = model.delta[k]
        update.inputs[4][:] = model.exo[:, k]
        update.inputs[6][:] = zs[k]
        update.inputs[7][:] = R[k]
        x_new, P_new, nu, S = update(x.ravel())
        x = x_new.reshape(r, N_FILTER).copy()  # the buffers are reused by the next call
        P = P_new.reshape(r, N_FILTER, N_FILTER).copy()
        innovation[:, k] = nu.reshape(r, m)
        S_all[:, k] = S.reshape(r, m, m)
        xs[:, k] = x
    ok = (np.all(np.isfinite(innovation), axis=(1, 2)) & np.all(np.isfinite(xs), axis=(1, 2))
          & np.all(np.isfinite(S_all), axis=(1, 2, 3)))
    return FilterRuns(innovation, S_all, ok, xs)
