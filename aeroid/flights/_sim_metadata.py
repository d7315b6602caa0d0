"""A simulated flight's metadata: the manoeuvre's numbers, the true fin law, its switches.

Written into every simulated flight's sidecar by :func:`aeroid.flights.record_flight`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from aeroid.flights._scenario import Manoeuvre
    from aeroid.model import Airframe


def manoeuvre_metadata(manoeuvre: Manoeuvre) -> dict[str, float | list[float]]:
    """The manoeuvre's numbers (the sidecar accepts numbers and lists of numbers here)."""
    out: dict[str, float | list[float]] = {
        key: value for key in ("command_amplitude", "command_phase_deg")
        if isinstance(value := getattr(manoeuvre, key), float)}
    out.update(sample_rate_hz=manoeuvre.sample_rate_hz, window_s=list(manoeuvre.window_s))
    return out


def actuator_metadata(manoeuvre: Manoeuvre, airframe: Airframe) -> dict[str, object]:
    """The true fin law (the ``[fin_law]`` table's form) and how it was evaluated."""
    if airframe.fin == "passive":
        return {"fin": "passive"}
    table: dict[str, object] = dict(manoeuvre.fin_law(airframe.delta_max_rad).to_table())
    table["evaluation"] = manoeuvre.evaluation
    if manoeuvre.control_rate_hz is not None:
        table["control_rate_Hz"] = manoeuvre.control_rate_hz
    return table


def switch_metadata(truth: Any, start: float, end: float) -> dict[str, dict[str, list]]:
    """The true deflection's knots and the commanded switches within ``[start, end]``.

    ``truth``: an :class:`aeroid.flights.Truth`.
    """
    sched = truth.schedule
    inside = (sched.times > start) & (sched.times < end)
    times = [start, *sched.times[inside].tolist(), end]
    values = [float(sched.at(start)), *sched.values[inside].tolist(), float(sched.before(end))]
    if float(sched.at(end)) != values[-1]:  # a jump at the last sample
        times.append(end)
        values.append(float(sched.at(end)))
    commands = (truth.command_t >= start) & (truth.command_t <= end)
    return {"delta_knots": {"t": times, "delta": values},
            "command_switches": {"t": truth.command_t[commands].tolist(),
                                 "delta": truth.command_delta[commands].tolist()}}


__all__ = ["actuator_metadata", "manoeuvre_metadata", "switch_metadata"]
