"""A simulated truth (:class:`Truth`), and the passive fin's (no relay, deflection 0)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from aeroid.flights._scenario import Manoeuvre
from aeroid.flights._thrust_flight import sample_thrust
from aeroid.model import Airframe, Schedule, as_vector, constants, exogenous_table, propagate


class Truth(NamedTuple):
    """A simulated truth from t = 0 (:func:`simulate_truth`).

    Attributes
    ----------
    t : ndarray, shape (n,)
        Sample times ``k dt`` [s].
    states : ndarray, shape (n, 9)
        True states at the samples.
    delta : ndarray, shape (n,)
        Fin deflection at each sample [rad] (after a jump at the sample).
    schedule : Schedule
        The true fin deflection from t = 0.
    command_t, command_delta : ndarray, shape (m,)
        Commanded switch instants [s] (before the actuator delay) and the command after
        each [rad].
    wind : ndarray, shape (n, 3), or None
        The wind at each sample, NED [m/s] (steady plus gusts); None: still air.
    """

    t: np.ndarray
    states: np.ndarray
    delta: np.ndarray
    schedule: Schedule
    command_t: np.ndarray
    command_delta: np.ndarray
    wind: np.ndarray | None = None


def passive_truth(airframe: Airframe, coefficients: np.ndarray, manoeuvre: Manoeuvre,
             backend: str) -> Truth:
    """A passive fin (``fin = "passive"``): no fin law, the deflection 0 throughout."""
    n = int(round(manoeuvre.window_s[1] / manoeuvre.dt)) + 1
    t = np.arange(n) * manoeuvre.dt
    delta = np.zeros(n)
    exo = None
    if airframe.thrust_curve is not None:  # the motor's thrust (and mass) per sample
        exo = exogenous_table(constants(airframe), n, sample_thrust(
            airframe.thrust_curve, t, airframe.thrust_n, manoeuvre.mass_scale))
    states = propagate(np.array(manoeuvre.initial_state), as_vector(coefficients)[None, :],
                       delta[:-1], manoeuvre.dt, constants(airframe),
                       substeps=manoeuvre.truth_substeps, backend=backend, exogenous=exo)[0]
    return Truth(t, states, delta, Schedule.hold(t, delta), t[:0], delta[:0])


__all__ = ["Truth", "passive_truth"]
