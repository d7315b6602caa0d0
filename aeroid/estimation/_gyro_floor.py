"""The gyro-only floor of the roll coefficients Cl0, Clp: what the p gyro alone can tell.

The two accelerometer triads lie on the body x axis, so they cannot see the roll
acceleration (the matrix of eqs. 29-30 has rank 5, :func:`aeroid.estimation.
accel_only_matrix`): in the EBM reconstruction the roll moment ``M_X = Ix pdot`` comes
from the differentiated roll gyro alone, and so do the equation-error estimates of Cl0
and Clp (``equation-error``, EBM-PSO, SEBM-PSO). No method that takes the roll moment
from the p gyro can beat the Cramér-Rao floor of that channel alone:

    F = sum_k  s_k s_k^T / sd_k^2,    s_k = d p_k / d (Cl0, Clp, p0),

with ``p_k`` the model's roll rate at sample k (:class:`aeroid.model.ForwardModel`,
central differences), ``sd_k`` the gyro's noise and the initial roll rate ``p0`` a
nuisance parameter (a method that differentiates p does not know it either); the other
seven coefficients are held at ``theta`` (the other channels fix them). The floor is
``sqrt(diag(F^-1))`` of (Cl0, Clp).

Measured on the reference flight (noise-free record, truth, eq. 43's paper noise on p,
per-sample sd ``|p| xi / sqrt(3)``): 130.6 % and 162.1 % of Cl0 and Clp; with p0 known
87.5 % and 109.6 %. Gaussian tactical IMU (0.005 rad/s): 0.44 % and 0.55 %. The full
output-error floor (both triads and the rates, :func:`aeroid.estimation.cramer_rao_sd`)
is far lower because the accelerometers' centripetal terms carry p.
"""

from __future__ import annotations

import numpy as np

from aeroid.estimation._information import fisher_information
from aeroid.estimation._signals import estimate_noise_sd, smooth, switch_free_samples
from aeroid.flights import STATE_CHANNELS, Flight, flight_record, model_constants
from aeroid.model import NAMES, ForwardModel

__all__ = ["GYRO_FLOOR_NAMES", "gyro_only_floor"]

#: The coefficients of the roll moment, the ones the floor is about.
GYRO_FLOOR_NAMES: tuple[str, ...] = ("Cl0", "Clp")
#: RK4 steps per sample of the floor's model (1 ms at 500 Hz, as the fit check's floor):
#: the floor changes by < 1e-7 relative between 1, 2 and 8 steps on the reference flight
#: (measured), and 8 steps cost ~1.6x the time (0.06 vs 0.04 s per call, measured).
GYRO_FLOOR_SUBSTEPS = 2


def gyro_only_floor(flight: Flight, theta: np.ndarray, *,
                    noise_sd: float | np.ndarray | None = None,
                    input: str = "hold",  # noqa: A002 - the estimators' option name
                    ) -> np.ndarray:
    """Return the Cramér-Rao standard deviations of Cl0 and Clp from the p gyro alone.

    Parameters
    ----------
    flight : Flight
        The record (inputs, first state). Its first p, q, r are the 7-point quadratic
        Savitzky-Golay fit at the first sample.
    theta : ndarray, shape (9,)
        Coefficients at which the model is linearised (the truth, or an estimate).
    noise_sd : float or ndarray, shape (n,), optional
        Noise sd of the p gyro per sample [rad/s]; default the data's own
        (:func:`aeroid.estimation.estimate_noise_sd` of p away from relay switches).
        Samples with sd 0 are left out (eq. 43 measures a zero signal exactly); all 0:
        no floor (zeros).
    input : {"hold", "midpoint", "events", "law"}
        How the deflection between samples is modelled (:data:`aeroid.flights.INPUTS`).

    Returns
    -------
    ndarray, shape (2,)
        Floor of Cl0 and Clp (:data:`GYRO_FLOOR_NAMES`), in coefficient units; NaN when
        the model diverges at ``theta`` or the information is singular.

    Raises
    ------
    ValueError
        On a ``theta`` that is not len(NAMES) finite numbers or a negative or non-finite sd.
    """
    theta = np.asarray(theta, dtype=float).reshape(-1)
    if theta.shape != (len(NAMES),) or not np.all(np.isfinite(theta)):
        raise ValueError(f"gyro_only_floor: theta must be {len(NAMES)} finite numbers, "
                         f"got {theta}")
    p = flight["p"]
    if noise_sd is None:
        noise_sd = float(estimate_noise_sd(p, use=switch_free_samples(flight["delta"])))
    sd = np.broadcast_to(np.asarray(noise_sd, dtype=float), p.shape)
    if not (np.all(np.isfinite(sd)) and np.all(sd >= 0)):
        raise ValueError("gyro_only_floor: the p noise sd must be finite and >= 0")
    if not np.any(sd > 0):
        return np.zeros(len(GYRO_FLOOR_NAMES))  # noise-free: no floor
    model = ForwardModel(model_constants(flight), flight_record(flight, input),
                         flight.airframe.accel_positions[:1], substeps=GYRO_FLOOR_SUBSTEPS)
    window = min(7, p.size - 1 + p.size % 2)  # the first state, rates smoothed over
    states = flight.data.iloc[:window][list(STATE_CHANNELS)].to_numpy(dtype=float)  # it
    state0 = states[0].copy()
    state0[3:6] = smooth(states[:window, 3:6], window, min(2, window - 1))[0]
    roll = [NAMES.index(name) for name in GYRO_FLOOR_NAMES]  # only these: 6 trajectories,
    with np.errstate(all="ignore"):  # not 20, summed block by block in time
        information = fisher_information(model, state0, theta, sd[:, None],
                                         channels=[model.output_names.index("p")],
                                         free_states=("p",), coefficients=roll)
    if not np.all(np.isfinite(information)):  # the model diverged at theta
        return np.full(len(GYRO_FLOOR_NAMES), np.nan)
    try:
        cov = np.linalg.inv(information)
    except np.linalg.LinAlgError:
        return np.full(len(GYRO_FLOOR_NAMES), np.nan)
    return np.sqrt(np.abs(np.diag(cov)[: len(GYRO_FLOOR_NAMES)]))
