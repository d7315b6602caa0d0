"""What the model needs of a flight: its constants, its inputs in time, per-sample values.

Every estimator, the EBM reconstruction and the Cramér-Rao floor take the model's view of
a flight from here, so a channel given is used everywhere or nowhere:

* :func:`model_constants`: the airframe's constants (a per-sample atmosphere leaves the
  constant density NaN: only the per-sample values may be used);
* :func:`exogenous` / :func:`sample_constants`: the per-sample density (from ``rho``,
  ``altitude`` through the ISA, or ``qbar`` and the airspeed), mass, thrust and inertias,
  as an exogenous table or as constants whose fields are per-sample arrays;
* :func:`flight_record`: the fin deflection between samples, chosen by the estimator
  option ``input`` (:data:`INPUTS`), optionally delayed by ``delay_s``;
  :func:`resolve_input` says which input ``auto`` is for a flight, and why.

Inputs between samples (the options of the estimators that integrate the model):

``auto`` (the estimators' default)
    ``law`` when the flight's airframe has a fin law (``[fin_law]``), else ``hold``. The
    law is what the relay does between samples; held, a relay that switches between
    samples biases Czq and Cmq (``studies/delayed_relay.md``: 3.4 % mean error against
    0.71 % with the law, tactical IMU). Before a fit the law is checked against the
    logged deflection (:func:`aeroid.flights.check_input`).
``hold``
    Each logged deflection holds until the next sample: right for a digital relay latched
    at the log clock (the paper's reference scenario).
``midpoint``
    A change seen between two samples happened halfway between them. The switch instants
    are then unbiased when the true instant is uniform in the interval, but each is still
    off by up to half a sample, and a model that integrates the states accumulates those
    errors: on the continuous-relay flight (noise-free, 32 switches, timing error sd
    0.5 ms) output-error's Cmq is 41 % off with ``midpoint`` and 34 % with ``hold``;
    ``events`` and ``law`` are exact. The fit check fails both (residuals 77x and 113x
    the resolution); under the paper's noise ``midpoint`` can pass it. Use ``events`` or
    ``law`` when the relay is not latched at the log clock.
``events``
    The switch instants are known: ``flight.metadata["delta_knots"]`` (``{"t": [...],
    "delta": [...]}``, the knots of the deflection as a piecewise-linear function of time,
    two knots at one time being a jump), written by the simulator or from a
    higher-rate deflection log.
``law``
    The airframe's fin law (``[fin_law]``) evaluated on the measured roll angle
    interpolated between samples, its switch instants located inside each interval.
"""

from __future__ import annotations

import numpy as np

from aeroid.errors import FlightError
from aeroid.flights._air_temperature import air_temperature
from aeroid.flights._flight import Flight
from aeroid.model import EXOGENOUS, Constants, Record, Schedule, constants, with_exogenous
from aeroid.model import density as isa_density

#: The estimator option ``input``: how the deflection between samples is modelled.
INPUTS: tuple[str, ...] = ("auto", "hold", "midpoint", "events", "law")
#: Per-sample channels that set one exogenous quantity each (besides the atmosphere).
EXOGENOUS_CHANNELS: dict[str, str] = {"mass": "mass", "thrust": "thrust", "ix": "ix",
                                      "iy": "iy", "iz": "iz"}


def model_constants(flight: Flight) -> Constants:
    """Return the model constants of the flight's airframe.

    With a per-sample atmosphere the constant density is NaN: a computation that forgot the
    per-sample values fails instead of using a wrong density.
    """
    return constants(flight.airframe)


def per_sample_density(flight: Flight) -> np.ndarray | None:
    """Return the density at every sample [kg/m^3] from the atmosphere channel, or None."""
    channel = flight.airframe.atmosphere_channel
    if channel is None:
        return None
    if channel not in flight.channels:
        raise FlightError(f"{flight.metadata.get('source', 'flight')}: [atmosphere] per_sample "
                          f"= {channel!r} but the flight has no {channel!r} channel")
    values = flight[channel]
    if channel == "rho":
        return values
    if channel == "altitude":
        return np.asarray(isa_density(values), dtype=float)
    speed2 = np.sum(flight.states()[:, :3] ** 2, axis=1)  # qbar = rho V^2 / 2
    return 2.0 * values / speed2


def exogenous(flight: Flight) -> np.ndarray | None:
    """Return the exogenous table (n, 7) of the flight's per-sample channels, or None."""
    if getattr(flight.airframe, "thrust_curve", None) is not None \
            and "thrust" not in flight.channels:  # never ignored: made into the channel
        raise FlightError(f"{flight.metadata.get('source', 'flight')}: the airframe has a "
                          "[thrust_curve] and the flight no 'thrust' channel: make it with "
                          "aeroid.flights.with_thrust_curve(flight) (aeroid estimate does)")
    given: dict[str, np.ndarray] = {}
    rho = per_sample_density(flight)
    if rho is not None:
        given["rho"] = rho
    for channel, name in EXOGENOUS_CHANNELS.items():
        if channel in flight.channels:
            given[name] = flight[channel]
    if flight.airframe.tables is not None:  # the Mach tables' speed of sound (else unused)
        temperature = air_temperature(flight)
        if temperature is not None:
            given["temperature"] = temperature
    if not given:
        return None
    const = model_constants(flight)
    table = np.tile(np.array([float(getattr(const, name)) for name in EXOGENOUS]),
                    (flight.n_samples, 1))
    for name, values in given.items():
        table[:, EXOGENOUS.index(name)] = values
    return table


def sample_constants(flight: Flight) -> Constants:
    """Return the constants with per-sample fields (arrays (n,)) where channels give them."""
    table = exogenous(flight)
    const = model_constants(flight)
    return const if table is None else with_exogenous(const, table.T)


def resolve_input(flight: Flight, input: str = "auto") -> tuple[str, str]:  # noqa: A002
    """Return the input ``input`` stands for on ``flight`` and why, in words.

    ``auto`` is ``law`` when the flight's airframe has a fin law, else ``hold``; any other
    input is itself ("given").
    """
    if input != "auto":
        return input, "given"
    if getattr(flight.airframe, "fin_law", None) is not None:
        return "law", "the airframe has a [fin_law]"
    return "hold", "the airframe has no [fin_law]"


def schedule(flight: Flight, input: str = "hold") -> Schedule:  # noqa: A002 - the option's name
    """Return the fin deflection of ``flight`` as a function of time (:data:`INPUTS`).

    Raises
    ------
    FlightError
        For an unknown input, ``events`` without the flight's switch knots, ``law`` without
        the airframe's fin law.
    """
    where = flight.metadata.get("source", "flight")
    t, delta = flight.t, flight["delta"]
    input, _ = resolve_input(flight, input)  # noqa: A001
    if input == "hold":
        return Schedule.hold(t, delta)
    if input == "midpoint":
        return Schedule.midpoint(t, delta)
    if input == "events":
        knots = flight.metadata.get("delta_knots")
        if not knots:
            raise FlightError(f"{where}: input 'events' needs the switch instants "
                              "(metadata['delta_knots'], e.g. from a deflection log)")
        try:
            return Schedule(np.asarray(knots["t"], dtype=float),
                            np.asarray(knots["delta"], dtype=float))
        except (KeyError, TypeError, ValueError) as exc:
            raise FlightError(f"{where}: malformed delta_knots ({exc})") from None
    if input == "law":
        law = getattr(flight.airframe, "fin_law", None)
        if law is None:
            raise FlightError(f"{where}: input 'law' needs the airframe's [fin_law]")
        return law.schedule(t, flight["phi"], initial=float(delta[0]))
    raise FlightError(f"unknown input {input!r} (expected one of {', '.join(INPUTS)})")


def flight_record(flight: Flight, input: str = "hold", delay_s: float = 0.0,  # noqa: A002
                  ) -> Record:
    """Return the model's record of ``flight``: deflection in time and per-sample values.

    Parameters
    ----------
    flight : Flight
    input : {"auto", "hold", "midpoint", "events", "law"}
        How the deflection between samples is modelled (module docstring).
    delay_s : float
        Actuator time delay [s]: every knot of the schedule moves later by it; before
        the first delayed knot the deflection logged at the first sample holds.
    """
    sched = schedule(flight, input)
    if delay_s:
        sched = sched.shifted(delay_s)
    return Record.scheduled(sched, flight.t, exogenous(flight))
