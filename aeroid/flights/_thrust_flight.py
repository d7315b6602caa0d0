"""A thrust curve made into a flight's per-sample ``thrust`` (and ``mass``) channels.

:func:`with_thrust_curve` fills the flight's exogenous ``thrust`` channel from a
:class:`aeroid.model.ThrustCurve` (the airframe's ``[thrust_curve]``, or one given) at
the log's sample times: the curve inside the burn window, zero outside. Every estimator
then uses it as any per-sample thrust (:func:`aeroid.flights.exogenous`: linear between
samples, so a step at a burn window's end is spread over one sample interval). The mass
along the burn, when the curve has it, becomes the ``mass`` channel (the burn's end
values held beyond the window). Refused, in one line: samples inside the burn without a
mass along it (thrust without the mass it burns changes the physics quietly: fit the
coast, or give the mass), a flight that already has a ``thrust`` channel (two thrusts:
which one?), a ``mass`` channel beside a curve's mass, and (by the airframe) a
``thrust_N`` other than 0. A flight whose airframe has a curve and no ``thrust`` channel
is refused by every estimator (:func:`aeroid.flights.exogenous`), never fitted without it.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import numpy as np

from aeroid.errors import AirframeError, FlightError
from aeroid.flights._flight import Flight
from aeroid.model import Constants, ThrustCurve, constants

if TYPE_CHECKING:
    from aeroid.flights._scenario import Manoeuvre
    from aeroid.model import Airframe


def with_thrust_curve(flight: Flight, curve: ThrustCurve | None = None) -> tuple[Flight, str]:
    """Return ``flight`` with its ``thrust`` (and ``mass``) channels from a curve, and a note.

    Parameters
    ----------
    flight : Flight
        Its ``t`` is the log's clock (the one ``curve.origin_s`` and ``burn_s`` are on).
    curve : ThrustCurve, optional
        Default: the flight airframe's ``thrust_curve``.

    Returns
    -------
    flight : Flight
        A copy with the channels, its airframe carrying the curve (so a written flight's
        sidecar has it).
    note : str
        One line: what was used (the curve, its origin, the burn window, the samples
        inside it, the impulse used, the mass).

    Raises
    ------
    FlightError
        One line (module docstring).
    """
    where = flight.metadata.get("source", "flight")
    curve = curve if curve is not None else flight.airframe.thrust_curve
    if curve is None:
        raise FlightError(f"{where}: no thrust curve given and the airframe has no "
                          "[thrust_curve]")
    if "thrust" in flight.channels:
        raise FlightError(f"{where}: the flight has a 'thrust' channel and a thrust curve "
                          f"({curve.source}) was given: use one (drop the column or the curve)")
    airframe = flight.airframe.replace(thrust_curve=curve)  # thrust_N must be 0
    t = flight.t
    inside = curve.burning(t)
    n_in = int(inside.sum())
    if n_in and curve.mass_kg is None:
        raise FlightError(
            f"{where}: {n_in} samples ({t[inside][0]:g}..{t[inside][-1]:g} s) are inside the "
            f"burn window {curve.burn_s[0]:g}..{curve.burn_s[1]:g} s and the thrust curve "
            f"({curve.source}) has no mass along the burn: give its mass_kg column, or fit "
            f"the samples after {curve.burn_s[1]:g} s only")
    data = flight.data.copy()
    data["thrust"] = curve.thrust(t)
    if n_in:
        if "mass" in flight.channels:
            raise FlightError(f"{where}: the flight has a 'mass' channel and the thrust curve "
                              f"({curve.source}) a mass along the burn: use one")
        data["mass"] = curve.mass(t)
    span = (f"{n_in} of {t.size} samples inside the burn" if n_in else
            f"no sample inside the burn ({t[0]:g}..{t[-1]:g} s): thrust 0 throughout"
            + ("; the curve's mass not used, the airframe's holds"
               if curve.mass_kg is not None else ""))
    note = f"{curve.describe()}; {span}"
    return dataclasses.replace(flight, data=data, airframe=airframe), note


def sample_thrust(curve: ThrustCurve, t: np.ndarray, thrust_n: float = 0.0,
                  mass_scale: float = 1.0) -> dict[str, np.ndarray]:
    """Return the simulator's exogenous columns of ``curve`` at truth times ``t`` [s].

    ``thrust`` (the curve inside the burn, 0 outside) and, when the curve has one, ``mass``
    times ``mass_scale`` (the truth's mass over the stated one). ``thrust_n``: the
    airframe's constant thrust, which must be 0 beside a curve. A burn inside ``t``
    without the mass along it is refused, as for a log (:func:`with_thrust_curve`).
    """
    if thrust_n != 0:
        raise FlightError(f"simulate: the airframe's thrust_N is {thrust_n:g} N and it has a "
                          f"thrust curve ({curve.source}): set thrust_N = 0")
    out = {"thrust": curve.thrust(t)}
    if curve.mass_kg is not None:
        out["mass"] = curve.mass(t) * mass_scale
    elif np.any(curve.burning(t)):
        raise FlightError(f"simulate: the flight reaches the burn window "
                          f"{curve.burn_s[0]:g}..{curve.burn_s[1]:g} s and the thrust curve "
                          f"({curve.source}) has no mass along the burn: give its mass_kg")
    return out


def recorded_constants(airframe: Airframe, manoeuvre: Manoeuvre, truth: Any,
                        k0: int) -> Constants:
    """The model constants at the recorded samples of ``truth`` from sample ``k0``: the
    thrust and mass of a thrust curve and the wind per sample, where there are ones
    (:func:`aeroid.flights.record_flight`; ``truth``: an :class:`aeroid.flights.Truth`)."""
    const = constants(airframe)
    if airframe.thrust_curve is not None:  # the true thrust and mass at the samples
        given = sample_thrust(airframe.thrust_curve, truth.t[k0:], airframe.thrust_n,
                              manoeuvre.mass_scale)
        const = const._replace(**given)
    if manoeuvre.wind is None:
        return const
    if truth.wind is None:
        raise AirframeError("record_flight: the manoeuvre has a wind but the truth none "
                            "(simulate it with simulate_truth)")
    wind = truth.wind[k0:]
    return const._replace(wind_n=wind[:, 0], wind_e=wind[:, 1], wind_d=wind[:, 2])


__all__ = ["recorded_constants", "sample_thrust", "with_thrust_curve"]
