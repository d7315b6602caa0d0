"""Output-error's initial attitude under the reconstruction's prior (issue 25, private).

Output-error integrates the states from the first sample, so the attitude it takes from
the flight is the *initial* attitude: an error in it is a constant offset of the
integrated attitude's gravity direction for the whole record (the rates are integrated
on top of it). With ``attitude_prior = "flight"`` the roll and pitch angles at the first
sample, ``phi0`` and ``theta0``, become parameters of the fit (the record model's
``x0_free``: exact forward sensitivities through the same RK4 record as the velocities')
under independent Gaussian priors centred on the flight's values with the sd the flight
states (``metadata["initial_state_sd"]``, :meth:`aeroid.reconstruction.Reconstruction.
to_flight`: the smoothed sd of the reconstruction). The fitted offset and its standard
error are reported in ``info["attitude_offset_rad"]`` and
``info["attitude_offset_stderr_rad"]`` with a one-line notice, and their share reaches
the coefficients' standard errors through the posterior covariance (the Cramér-Rao
information plus the prior's).

Decisions:

- **Estimated under the prior, not a consider parameter** (:mod:`aeroid.estimation.
  _consider` re-fits the whole record at +-1 sd): two more columns of the sensitivities
  the record model propagates anyway (as for the velocities), where a consider share of
  two angles is four more fits (not timed); and the data inform the angles (the
  integrated velocity sees gravity's direction), so the posterior is the interval,
  where a consider share would add the prior's whole share. Measured on the rocket
  coast (tests/unit/test_output_error_attitude.py): theta's posterior sd 1.5e-4 rad
  from a 0.05 rad prior without IMU errors; 8.4e-4 from 9.6e-4 on the flight computer's
  raw IMU with its 18 biases and scale factors fitted (studies/rocket_measure.toml).
- **psi is not freed**: in still air the IMU's outputs do not depend on the heading
  (gravity is along the down axis); its column is exactly zero. With ``estimate_wind``
  it would matter; that combination is refused (not built).
- The two angles' priors are independent; the reconstruction's covariance between the
  angles and the velocities is not in the flight (only the marginal sd are), so the
  priors ignore it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

import aeroid
from aeroid.flights import Flight
from aeroid.model import PHI, STATE_NAMES, THETA
from baselines._common import reconstruction_sd
from baselines._oe_sensors import prior_weights as sensor_prior_weights
from baselines._tables_fit import coefficient_layout

#: The option's values.
ATTITUDE_PRIORS = ("none", "flight")
#: Initial-state components freed by ``attitude_prior = "flight"``.
X0_ATTITUDE = (PHI, THETA)
#: Their names in ``metadata['initial_state_sd']`` and in the report.
ATTITUDE_NAMES = tuple(STATE_NAMES[i] for i in X0_ATTITUDE)


@dataclass(frozen=True, kw_only=True)
class AttitudeOption:
    """Output-error's attitude option (a base of :class:`baselines.output_error.
    OutputErrorEstimator`: ``aeroid methods --options output-error`` lists it).

    Attributes
    ----------
    attitude_prior : {"none", "flight"}
        ``"flight"``: also estimate the roll and pitch angles at the first sample under a
        Gaussian prior centred on the flight's values with the sd in the flight's
        ``metadata['initial_state_sd']`` (a reconstruction's flight: its smoothed sd);
        their share enters the coefficients' standard errors. Reported in
        ``info['attitude_offset_rad']`` (estimate less the flight's) and
        ``info['attitude_offset_stderr_rad']``. Default ``"none"``: the attitude is
        taken as measured (:mod:`baselines._oe_attitude`). A flight without those sd
        is refused.
    """

    attitude_prior: str = "none"


def check_attitude_option(est: Any) -> None:
    """Raise ValueError (one line) for a bad ``attitude_prior`` or a combination not built."""
    if est.attitude_prior not in ATTITUDE_PRIORS:
        raise ValueError(f"attitude_prior must be one of {', '.join(ATTITUDE_PRIORS)}, got "
                         f"{est.attitude_prior!r}")
    if est.attitude_prior == "flight" and getattr(est, "estimate_wind", False) is True:
        raise ValueError("attitude_prior = flight with estimate_wind is not built (the "
                         "heading then matters and is not freed)")


def attitude_x0(est: Any) -> tuple[int, ...]:
    """The initial-state components ``est``'s attitude option frees (none by default)."""
    return X0_ATTITUDE if getattr(est, "attitude_prior", "none") == "flight" else ()


def attitude_sd(flight: Flight) -> np.ndarray:
    """The sd [rad] of ``phi, theta`` at the first sample (``metadata['initial_state_sd']``).

    Raises
    ------
    aeroid.FlightError
        One line: the flight states no positive sd for them.
    """
    sd = reconstruction_sd(flight, ATTITUDE_NAMES)
    if sd is None:
        raise aeroid.FlightError(
            f"{flight.metadata.get('source', 'flight')}: attitude_prior = flight needs "
            "metadata initial_state_sd with positive phi, theta [rad] (a reconstruction's "
            f"flight has them); got {flight.metadata.get('initial_state_sd')!r}")
    return sd


def prior_weights(est: Any, flight: Flight, scale: np.ndarray,
                  position_free: tuple[int, ...]) -> np.ndarray:
    """Return output-error's prior weights on its scaled parameters
    (:func:`baselines._oe_sensors.prior_weights`) with the attitude's prior added:
    ``(scale / sd)^2`` at ``phi0``, ``theta0``; exactly those weights without the option."""
    weight = sensor_prior_weights(est, flight, scale, position_free)
    if not attitude_x0(est):
        return weight
    sd = attitude_sd(flight)
    n_c = len(coefficient_layout(flight)[0])
    out = np.array(weight, dtype=float)
    for j, i in enumerate(est.x0_free()):
        if i in X0_ATTITUDE:
            out[n_c + j] = (scale[n_c + j] / sd[X0_ATTITUDE.index(i)]) ** 2
    return out


def attitude_report(est: Any, flight: Flight, phys: np.ndarray, stderr: np.ndarray,
                    info: dict[str, Any]) -> list[str]:
    """Put the fitted initial-attitude offset in ``info`` and return its one-line notice.

    ``phys``, ``stderr``: every parameter of the fit, named by ``info['parameter_names']``
    (a free initial-state entry is its offset from the flight's first sample).
    ``info['attitude_offset_rad']``: ``{"phi": ..., "theta": ...}``, the estimate less the
    flight's first sample; ``info['attitude_offset_stderr_rad']``: their posterior sd;
    ``info['attitude_prior_sd_rad']``: the prior's sd.
    """
    if not attitude_x0(est):
        return []
    sd = attitude_sd(flight)
    offset, se, names = {}, {}, list(info["parameter_names"])
    for name in ATTITUDE_NAMES:  # the record model's free x0 entries are offsets from x0
        k = names.index(f"{name}0")
        offset[name] = float(phys[k])
        se[name] = float(stderr[k])
    info.update(attitude_offset_rad=offset, attitude_offset_stderr_rad=se,
                attitude_prior_sd_rad=dict(zip(ATTITUDE_NAMES, sd.tolist(), strict=True)))
    shown = ", ".join(f"{n} {offset[n]:+.2e} +- {se[n]:.1e} (prior sd {s:.1e})"
                      for n, s in zip(ATTITUDE_NAMES, sd, strict=True))
    return [f"attitude_prior = flight: the initial roll and pitch were estimated under the "
            f"reconstruction's sd, offsets from the flight's [rad]: {shown}"]


__all__ = ["ATTITUDE_NAMES", "ATTITUDE_PRIORS", "X0_ATTITUDE", "AttitudeOption", "prior_weights",
           "attitude_report", "attitude_sd", "attitude_x0",
           "check_attitude_option"]
