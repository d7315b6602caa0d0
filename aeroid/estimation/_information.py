"""The Fisher information of the output-error model, written once and summed over time.

With independent zero-mean measurement errors of standard deviation ``sd_kc`` (sample
k, output channel c) the Fisher information of the parameters (coefficients, free
initial-state components) is::

    F = sum_k sum_c  J_kc^T J_kc / sd_kc^2,      J_kc = d y_kc / d params,

``J`` the central-difference sensitivities of the forward model
(:meth:`aeroid.model.ForwardModel.sensitivity_blocks`). The sum runs block by block in
time, so the n x m x p sensitivity matrix of a long log is never held: memory is that
of one block (:data:`aeroid.model.SENSITIVITY_BLOCK_BYTES`) whatever the log's length.
Samples whose ``sd`` is exactly zero carry no usable Gaussian weight and are left out
(eq. 43 measures a zero signal exactly).

The weights ``1 / sd^2`` come from the noise model (:func:`model_noise_sd`) or from the
data's noise levels. Every Cramér-Rao figure of aeroid is this sum: the output-error floor
(:func:`aeroid.estimation.cramer_rao_sd`), the fit check's floor from the data
(:func:`aeroid.estimation.data_floor`) and the gyro-only floor of the roll coefficients
(:func:`aeroid.estimation.gyro_only_floor`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from aeroid.estimation._objectives import EAM_OUTPUTS
from aeroid.flights import NOISE_FORMS, GaussianNoise, NoiseModel, PaperNoise
from aeroid.model import DEFAULT_REL_STEP, N_COEFFICIENTS, OUTPUT_CHANNELS, ForwardModel

__all__ = ["CHANNEL_SETS", "coefficient_information", "fisher_information",
           "information_from_sensitivities", "model_noise_sd", "weighted_information"]

#: Channel subsets: ``both`` triads and the rates (default), or ``triad1`` and the rates
#: (the EAM output set: triad 1 at [Rx1, 0, 0] only).
CHANNEL_SETS: dict[str, tuple[int, ...]] = {
    "both": tuple(range(len(OUTPUT_CHANNELS))),
    "triad1": tuple(OUTPUT_CHANNELS.index(c) for c in EAM_OUTPUTS),
}


def inverse_variance(sd: np.ndarray) -> np.ndarray:
    """Return ``1 / sd^2``, 0 where ``sd`` is 0 (a sample left out); same shape."""
    sd = np.asarray(sd, dtype=float)
    weight = np.zeros(sd.shape)
    np.divide(1.0, sd**2, out=weight, where=sd > 0)
    return weight


def weighted_information(sensitivities: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Return ``sum_k sum_c J_kc^T w_kc J_kc``, shape (p, p).

    Parameters
    ----------
    sensitivities : ndarray, shape (n, m, p)
        ``J``: sample, output channel, parameter.
    weight : ndarray, shape (n, m)
        ``1 / sd^2`` (:func:`inverse_variance`).
    """
    return np.einsum("kci,kc,kcj->ij", sensitivities, weight, sensitivities)


def fisher_information(model: ForwardModel, state0: np.ndarray, theta: np.ndarray,
                       noise_sd: np.ndarray | float, *, channels: Sequence[int] | None = None,
                       free_states: Sequence[str] = (),
                       coefficients: Sequence[int] | None = None,
                       rel_step: float = DEFAULT_REL_STEP,
                       block_samples: int | None = None) -> np.ndarray:
    """Return the Fisher information of the model's parameters, summed block by block.

    Parameters
    ----------
    model : ForwardModel
        The record's forward model (inputs, constants, triad positions, substeps).
    state0 : ndarray, shape (9,)
        Initial state [m/s, rad/s, rad].
    theta : ndarray, shape (9,)
        Coefficients at which the information is evaluated.
    noise_sd : float or ndarray, broadcastable to (n, len(channels))
        Error standard deviation per sample and used channel [m/s^2, rad/s]; 0 leaves
        the sample out; negative or non-finite values are an error.
    channels : sequence of int, optional
        Output channels used (indices into ``model.output_names``); default all.
    free_states, coefficients, rel_step, block_samples
        The parameters and the blocks (:meth:`aeroid.model.ForwardModel.sensitivity_blocks`).

    Returns
    -------
    ndarray, shape (p, p)
        ``p`` = the coefficients (all nine, or ``coefficients``), then ``free_states``.
        All NaN when the model diverges (non-finite sensitivities) at ``theta``.

    Raises
    ------
    ValueError
        On a bad ``noise_sd`` (shape, sign, non-finite) or a bad channel index.
    """
    used = list(range(len(model.output_names)) if channels is None else channels)
    if not all(0 <= c < len(model.output_names) for c in used):
        raise ValueError(f"fisher: channels must index the model's {len(model.output_names)} "
                         f"outputs, got {used}")
    given = np.asarray(noise_sd, dtype=float)
    check_sd(given)
    try:  # a view: the weights are formed per block
        sd = np.broadcast_to(given, (model.n_samples, len(used)))
    except ValueError:
        raise ValueError(f"fisher: noise sd of shape {given.shape} does not fit "
                         f"{model.n_samples} samples x {len(used)} channels") from None
    n_par = (N_COEFFICIENTS if coefficients is None else len(coefficients)) + len(free_states)
    info = np.zeros((n_par, n_par))
    for rows, jac in model.sensitivity_blocks(state0, theta, free_states=free_states,
                                              rel_step=rel_step, coefficients=coefficients,
                                              block_samples=block_samples):
        jac = jac[:, used]
        if not np.all(np.isfinite(jac)):
            return np.full((n_par, n_par), np.nan)
        info += weighted_information(jac, inverse_variance(sd[rows]))
    return info


def information_from_sensitivities(
    sensitivities: np.ndarray, sd: np.ndarray, *, channels: str = "both"
) -> np.ndarray:
    """Return ``F = sum_k sum_c J_kc^T J_kc / sd_kc^2``, shape (9, 9).

    Parameters
    ----------
    sensitivities : ndarray, shape (n, 9, n_params)
    sd : ndarray, broadcastable to (n, 9)
        Error standard deviations; entries that are 0 (exact measurements of a zero
        signal under eq. 43) are left out; negative or non-finite values are an error.
    channels : {"both", "triad1"}
    """
    jac = np.asarray(sensitivities, dtype=float)
    sd = np.broadcast_to(np.asarray(sd, dtype=float), jac.shape[:2])
    cols = channel_indices(channels)
    check_sd(sd)
    if not np.all(np.isfinite(jac)):
        raise ValueError("fisher: non-finite sensitivities (the model diverged)")
    return weighted_information(jac[:, cols], inverse_variance(sd[:, cols]))


def channel_indices(channels: str) -> list[int]:
    """Return the output channels of a :data:`CHANNEL_SETS` name."""
    if channels not in CHANNEL_SETS:
        raise ValueError(f"fisher: unknown channels {channels!r} "
                         f"(expected {' or '.join(CHANNEL_SETS)})")
    return list(CHANNEL_SETS[channels])


def check_sd(sd: np.ndarray) -> None:
    """Raise ValueError unless every standard deviation is finite and >= 0."""
    if not np.all(np.isfinite(sd)) or np.any(sd < 0):
        raise ValueError("fisher: noise standard deviations must be finite and >= 0")


def model_noise_sd(
    noise_model: NoiseModel,
    outputs: np.ndarray,
    *,
    noise_form: str = "heteroscedastic",
) -> np.ndarray:
    """Return the measurement-error standard deviation of every output, shape (n, 9).

    Parameters
    ----------
    noise_model : PaperNoise or GaussianNoise
    outputs : ndarray, shape (n, 9)
        Noise-free model outputs ``s`` (columns :data:`aeroid.model.OUTPUT_CHANNELS`)
        [m/s^2, rad/s].
    noise_form : {"heteroscedastic", "homoscedastic"}
        Paper noise only: ``|s_k| xi / sqrt(3)`` per sample (default, what eq. 43 says),
        or ``xi RMS(s) / sqrt(3)`` per channel. Ignored for Gaussian noise.
    """
    outputs = np.asarray(outputs, dtype=float)
    if outputs.ndim != 2 or outputs.shape[1] != len(OUTPUT_CHANNELS):
        raise ValueError(f"fisher: outputs must have shape (n, {len(OUTPUT_CHANNELS)}), "
                         f"got {outputs.shape}")
    if noise_form not in NOISE_FORMS:
        raise ValueError(f"fisher: unknown noise_form {noise_form!r} "
                         f"(expected {' or '.join(NOISE_FORMS)})")
    if isinstance(noise_model, PaperNoise | GaussianNoise):  # the noise model's own sd
        return noise_model.output_sd(outputs, form=noise_form)
    raise ValueError(
        f"fisher: no Cramér-Rao floor for noise model {getattr(noise_model, 'name', noise_model)!r}"
        " (needs 'paper' or 'gaussian': noise-free data have no floor)"
    )


def coefficient_information(information: np.ndarray) -> np.ndarray:
    """Return the information of the coefficients with the nuisance parameters removed.

    For a joint information ``[[F_tt, F_tx], [F_xt, F_xx]]`` of the nine coefficients
    and ``m`` nuisance parameters (estimated initial-state components), the Schur
    complement ``F_tt - F_tx F_xx^-1 F_xt`` (9 x 9), whose inverse is the coefficient
    block of the joint inverse. With no nuisance parameters it is ``information`` itself.
    """
    info = np.asarray(information, dtype=float)
    n = N_COEFFICIENTS
    if info.shape[0] == n:
        return info.copy()
    f_tt, f_tx, f_xx = info[:n, :n], info[:n, n:], info[n:, n:]
    return f_tt - f_tx @ np.linalg.solve(f_xx, f_tx.T)
