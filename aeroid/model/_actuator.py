"""The fin law: the paper's ON-OFF relay driven by the roll angle, an actuator delay and rate.

The commanded deflection (paper section 4; notes, "Actuator and excitation")::

    delta_c(t) = delta_max sign(sin 2 phi + A(t) sin(phi + phi0(t))),   sign(0) = +1

with ``phi`` the roll angle: a guidance command fixed in the non-rolling frame plus a
dither at twice the roll frequency. The command amplitude ``A`` and phase ``phi0`` are
constants or piecewise-linear functions of time given by ``(time_s, value)`` pairs (held
beyond the first and last pair). The fin follows the command after a time delay ``tau
>= 0``; with a rate limit ``r`` it moves toward the command at ``r``: a switch becomes a
ramp of slope ``+-r``, and a switch back before the ramp ends reverses it from where it
is (:meth:`FinLaw.actuate`; delay and rate limit commute, both being time-invariant).

:meth:`FinLaw.schedule` evaluates the law open loop on a measured roll-angle history
(:mod:`aeroid.model._law_schedule`); the simulator evaluates it closed loop on the true
roll angle (:func:`aeroid.flights.simulate`).

File form (the airframe file's optional ``[fin_law]`` table; ``delta_max`` is
``[airframe] delta_max_deg``)::

    [fin_law]
    command_amplitude = 0.5                 # A: a number or [[t_s, A], ...] pairs
    command_phase_deg = [[0.0, 60.0], [10.0, 90.0]]   # phi0 [deg], the same
    delay_s = 0.001                         # optional, default 0
    rate_limit_dps = 8000.0                 # optional, default none (infinite)
    evaluation = "continuous"               # optional: "continuous" (default), "latched"
    # control_rate_Hz = 2000.0              #   or "control_rate" at this clock

``evaluation`` says when the relay reads its law, as the scenario's ``[actuator]``:
``continuous`` switches where the switching function crosses zero; ``latched`` reads it
at the log's sample instants and holds (the paper's digital relay); ``control_rate`` at
the instants ``m / control_rate_Hz`` from t = 0 of a clock of its own. A relay latched
at a clock that the law calls continuous switches up to a clock period later than the
law says, which the log's samples cannot show (``aeroid.flights.check_input``).
Measured (tactical IMU, seeds 11 and 12, output-error with the law): the latched relay
of ``studies/scenarios/continuous_relay.toml`` modelled as continuous 18.6 and 18.8 %
mean error (held: 0.52 and 0.46 %); a 1.3 kHz control-rate relay 5.4 and 5.8 %.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from aeroid.errors import AirframeError
from aeroid.model._fileform import check_keys, check_table, is_number, number, text
from aeroid.model._inputs import Schedule
from aeroid.model._law_schedule import law_schedule, law_switches

#: A law parameter: a constant, or ``(time_s, value)`` pairs with increasing times.
Profile = float | tuple[tuple[float, float], ...]
#: Keys of the ``[fin_law]`` table (and of the scenario's ``[actuator]`` law).
FIN_LAW_KEYS = ("command_amplitude", "command_phase_deg", "delay_s", "rate_limit_dps")
#: Keys of the ``[fin_law]`` table that say when the relay reads its law (the scenario's
#: ``[actuator]`` has its own, for the simulator).
CLOCK_KEYS = ("evaluation", "control_rate_Hz")
#: When the relay reads its law (:class:`FinLaw`).
LAW_EVALUATIONS = ("continuous", "latched", "control_rate")
#: Longest actuator delay [s]: a fin servo answers in milliseconds; a delay of a second or
#: more is a delay in milliseconds written as seconds.
MAX_DELAY_S = 1.0


def _clipped(value: Any, limit: int = 80) -> str:
    """Return ``repr(value)``, cut to ``limit`` characters: a message keeps its reason
    after a long value (cutting the whole message cut the reason after a long path)."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def profile(value: Any, where: str) -> Profile:
    """Return a law parameter from its file form: a number or ``[[t_s, value], ...]``.

    Raises
    ------
    AirframeError
        One line naming ``where``: not a number nor a list of pairs, a pair that is not
        two finite numbers, times not strictly increasing.
    """
    if is_number(value):
        return number(value, where)
    shape = f"{where} must be a number or a list of [time_s, value] pairs"
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, list | tuple) \
            or not value:
        raise AirframeError(f"{shape}, got {_clipped(value)}")
    pairs = []
    for pair in value:
        if (isinstance(pair, str | bytes | Mapping) or not isinstance(pair, list | tuple)
                or len(pair) != 2 or not all(is_number(x) and math.isfinite(x) for x in pair)):
            raise AirframeError(f"{shape}; {_clipped(pair)} is not two finite numbers")
        pairs.append((float(pair[0]), float(pair[1])))
    times = [p[0] for p in pairs]
    if any(b <= a for a, b in zip(times, times[1:], strict=False)):
        raise AirframeError(f"{where}: the times of the pairs must increase strictly, "
                            f"got {_clipped(times)}")
    return tuple(pairs)


def _evaluate(param: Profile, t: Any, name: str) -> np.ndarray | float:
    if isinstance(param, float):
        return param
    if t is None:
        raise ValueError(f"fin law: {name} varies in time; give the time t")
    times, values = np.array(param).T
    return np.interp(np.asarray(t, dtype=float), times, values)


def _file_form(param: Profile) -> float | list[list[float]]:
    return param if isinstance(param, float) else [list(p) for p in param]


@dataclass(frozen=True, kw_only=True)
class FinLaw:
    """The paper's relay fin law with an actuator delay and rate limit (module docstring).

    Attributes
    ----------
    delta_max_rad : float
        Fin deflection when ON [rad], > 0.
    command_amplitude : float or tuple of (time_s, value) pairs
        ``A``: a constant, or piecewise linear in time between the pairs.
    command_phase_deg : float or tuple of (time_s, value) pairs
        ``phi0`` [deg], the same.
    delay_s : float
        Actuator time delay [s], 0 <= delay < :data:`MAX_DELAY_S`.
    rate_limit_dps : float or None
        Largest fin rate [deg/s], > 0; None: infinite (a switch is a jump).
    evaluation : {"continuous", "latched", "control_rate"}
        When the relay reads the law (module docstring): where the switching function
        crosses zero (default), at the log's sample instants, or at ``control_rate_hz``.
    control_rate_hz : float or None
        The relay's clock [Hz] (``control_rate`` only), instants ``m / control_rate_hz``.
    """

    delta_max_rad: float
    command_amplitude: Profile = 0.5
    command_phase_deg: Profile = 60.0
    delay_s: float = 0.0
    rate_limit_dps: float | None = None
    evaluation: str = "continuous"
    control_rate_hz: float | None = None

    def __post_init__(self) -> None:
        dmax = number(self.delta_max_rad, "fin law: delta_max_rad")
        if dmax <= 0:
            raise AirframeError(f"fin law: delta_max_rad must be positive, got {dmax:g}")
        object.__setattr__(self, "delta_max_rad", dmax)
        for name in ("command_amplitude", "command_phase_deg"):
            object.__setattr__(self, name, profile(getattr(self, name), f"fin law: {name}"))
        delay = number(self.delay_s, "fin law: delay_s")
        if not 0.0 <= delay < MAX_DELAY_S:
            raise AirframeError(f"fin law: delay_s must be in [0, {MAX_DELAY_S:g}) s, got "
                                f"{delay:g} (milliseconds written as seconds?)")
        object.__setattr__(self, "delay_s", delay)
        if self.rate_limit_dps is not None:
            rate = number(self.rate_limit_dps, "fin law: rate_limit_dps")
            if rate <= 0:
                raise AirframeError(f"fin law: rate_limit_dps must be positive, got {rate:g}")
            object.__setattr__(self, "rate_limit_dps", rate)
        if self.evaluation not in LAW_EVALUATIONS:
            raise AirframeError(f"fin law: evaluation must be one of "
                                f"{', '.join(map(repr, LAW_EVALUATIONS))}, "
                                f"got {_clipped(self.evaluation)}")
        if (self.evaluation == "control_rate") != (self.control_rate_hz is not None):
            raise AirframeError("fin law: control_rate_Hz goes with evaluation = "
                                "\"control_rate\" and nothing else")
        if self.control_rate_hz is not None:
            clock = number(self.control_rate_hz, "fin law: control_rate_Hz")
            if clock <= 0:
                raise AirframeError(f"fin law: control_rate_Hz must be positive, got {clock:g}")
            object.__setattr__(self, "control_rate_hz", clock)

    # the law ---------------------------------------------------------------------------
    @property
    def time_varying(self) -> bool:
        """Whether ``A`` or ``phi0`` varies in time."""
        return not (isinstance(self.command_amplitude, float)
                    and isinstance(self.command_phase_deg, float))

    @property
    def rate_limit_radps(self) -> float:
        """Largest fin rate [rad/s] (``inf`` without a rate limit)."""
        return math.inf if self.rate_limit_dps is None else math.radians(self.rate_limit_dps)

    def amplitude(self, t: np.ndarray | float | None = None) -> np.ndarray | float:
        """Return ``A`` at time(s) ``t`` [s] (``t`` needed only when it varies)."""
        return _evaluate(self.command_amplitude, t, "command_amplitude")

    def phase_rad(self, t: np.ndarray | float | None = None) -> np.ndarray | float:
        """Return ``phi0`` [rad] at time(s) ``t`` [s] (``t`` needed only when it varies)."""
        return np.radians(_evaluate(self.command_phase_deg, t, "command_phase_deg"))

    def switching_function(self, phi: np.ndarray | float,
                           t: np.ndarray | float | None = None) -> np.ndarray:
        """Return ``sin(2 phi) + A(t) sin(phi + phi0(t))``; the relay switches at its zeros.

        Parameters
        ----------
        phi : array_like
            Roll angle(s) [rad].
        t : array_like, optional
            Time(s) [s] broadcasting with ``phi``; needed when ``A`` or ``phi0`` varies.
        """
        phi = np.asarray(phi, dtype=float)
        return np.sin(2.0 * phi) + self.amplitude(t) * np.sin(phi + self.phase_rad(t))

    def command(self, phi: np.ndarray | float,
                t: np.ndarray | float | None = None) -> np.ndarray:
        """Return the commanded deflection ``delta_max sign(s)`` [rad], ``sign(0) = +1``."""
        s = self.switching_function(phi, t)
        return np.where(s >= 0.0, self.delta_max_rad, -self.delta_max_rad)

    def __call__(self, phi: np.ndarray | float,
                 t: np.ndarray | float | None = None) -> np.ndarray:
        """Return the commanded deflection (:meth:`command`)."""
        return self.command(phi, t)

    # the actuator ----------------------------------------------------------------------
    def actuate(self, t0: float, initial: float, times: np.ndarray,
                values: np.ndarray) -> Schedule:
        """Return the fin deflection that follows commanded switches (delay, rate limit).

        Parameters
        ----------
        t0 : float
            Start [s]: the fin is at ``initial`` [rad] and at rest (commanded ``initial``).
        times, values : ndarray, shape (m,)
            Commanded switch instants [s] (non-decreasing, >= ``t0``) and the command
            after each [rad]; each acts ``delay_s`` later.

        Returns
        -------
        Schedule
            Knots of the deflection from ``t0``: a jump per switch without a rate limit,
            else ramps of slope ``+-rate_limit_radps`` (continuous, reversed by a switch
            that comes before the ramp ends).
        """
        track = Track(float(t0), float(initial), self.rate_limit_radps)
        for when, value in zip(np.asarray(times, dtype=float) + self.delay_s,
                               np.asarray(values, dtype=float), strict=True):
            track.switch(float(when), float(value))
        return track.schedule()

    def schedule(self, t: np.ndarray, phi: np.ndarray, *, initial: float | None = None,
                 phi_rate: np.ndarray | None = None, subdivisions: int = 8) -> Schedule:
        """Return the deflection the law gives on a measured roll angle (open loop).

        See :func:`aeroid.model._law_schedule.law_schedule` for the interpolation, the
        location of the switch instants and what is assumed before ``t[0] + delay_s``.
        """
        return law_schedule(self, t, phi, initial=initial, phi_rate=phi_rate,
                            subdivisions=subdivisions)

    def switches(self, t: np.ndarray, phi: np.ndarray, *, phi_rate: np.ndarray | None = None,
                 subdivisions: int = 8) -> tuple[np.ndarray, np.ndarray]:
        """Return the commanded switch instants in ``(t[0], t[-1]]`` and the command after each.

        See :func:`aeroid.model._law_schedule.locate_switches` (a law read at a clock:
        :func:`aeroid.model._law_schedule.clocked_switches`).
        """
        times, values, _ = law_switches(self, t, phi, phi_rate=phi_rate,
                                        subdivisions=subdivisions)
        return times, values

    # file form -------------------------------------------------------------------------
    def replace(self, **changes: Any) -> FinLaw:
        """Return a copy with some fields replaced (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    def to_table(self) -> dict[str, Any]:
        """Return the ``[fin_law]`` table (``delta_max`` is the airframe's)."""
        table: dict[str, Any] = {
            "command_amplitude": _file_form(self.command_amplitude),
            "command_phase_deg": _file_form(self.command_phase_deg),
            "delay_s": self.delay_s}
        if self.rate_limit_dps is not None:
            table["rate_limit_dps"] = self.rate_limit_dps
        if self.evaluation != "continuous":
            table["evaluation"] = self.evaluation
        if self.control_rate_hz is not None:
            table["control_rate_Hz"] = self.control_rate_hz
        return table

    @classmethod
    def from_table(cls, table: Any, *, delta_max_rad: float, where: str,
                   required: tuple[str, ...] = ("command_amplitude", "command_phase_deg")
                   ) -> FinLaw:
        """Build a fin law from a ``[fin_law]`` table (the module docstring's form).

        Parameters
        ----------
        table : mapping
            The parsed table.
        delta_max_rad : float
            The airframe's fin throw [rad].
        where : str
            ``"FILE: [fin_law]"``, named in every error.
        required : tuple of str
            Keys that must be given (an airframe file states its law: ``A`` and ``phi0``).

        Raises
        ------
        AirframeError
            One line naming ``where`` and the key: unknown or missing keys, wrong types,
            values out of range.
        """
        table = check_table(table, where)
        check_keys(table, (*FIN_LAW_KEYS, *CLOCK_KEYS), where, required)
        kwargs: dict[str, Any] = {}
        for key in ("command_amplitude", "command_phase_deg"):
            if key in table:
                kwargs[key] = profile(table[key], f"{where} {key}")
        for key in ("delay_s", "rate_limit_dps"):
            if key in table:
                kwargs[key] = number(table[key], f"{where} {key}")
        if "control_rate_Hz" in table:
            kwargs["control_rate_hz"] = number(table["control_rate_Hz"],
                                               f"{where} control_rate_Hz")
            kwargs["evaluation"] = "control_rate"
        if "evaluation" in table:
            kwargs["evaluation"] = text(table["evaluation"], f"{where} evaluation")
        try:
            return cls(delta_max_rad=delta_max_rad, **kwargs)
        except AirframeError as exc:
            raise AirframeError(f"{where}: {str(exc).removeprefix('fin law: ')}") from None


class Track:
    """The fin position built switch by switch: knots of a piecewise-linear deflection.

    Starts at rest at ``value`` at ``t0``. :meth:`switch` sets a new target at ``t``
    (non-decreasing): without a rate limit the fin jumps there; with one it ramps at
    ``rate`` [rad/s] from where it is at ``t`` (a ramp still running is cut there).
    ``snap`` maps every knot time made (the simulator puts a knot within rounding of an
    integration grid point exactly on it).
    """

    def __init__(self, t0: float, value: float, rate: float,
                 snap: Callable[[float], float] | None = None) -> None:
        self.times = [t0]
        self.values = [value]
        self.target = value
        self.rate = rate
        self.snap = snap or (lambda when: when)

    def value_at(self, t: float) -> float:
        """Return the fin position at ``t`` >= the last switch."""
        if len(self.times) > 1 and t < self.times[-1]:  # inside the running ramp
            (ta, tb), (va, vb) = self.times[-2:], self.values[-2:]
            return va + (vb - va) * (t - ta) / (tb - ta)
        return self.values[-1]

    def switch(self, t: float, target: float) -> None:
        """Command ``target`` [rad] from time ``t`` [s] on."""
        if target == self.target:
            return
        t = self.snap(t)
        value = self.value_at(t)
        while self.times[-1] > t:  # the end of a ramp that the switch cuts
            self.times.pop()
            self.values.pop()
        if self.times[-1] < t or self.values[-1] != value:
            self.times.append(t)
            self.values.append(value)
        self.target = target
        if value == target:  # a reversal at the very start of a ramp
            return
        if math.isinf(self.rate):
            self.times.append(t)
        else:
            self.times.append(self.snap(t + abs(target - value) / self.rate))
        self.values.append(target)

    def schedule(self) -> Schedule:
        """Return the knots as a :class:`~aeroid.model.Schedule`."""
        return Schedule(np.array(self.times), np.array(self.values))


def RelayActuator(*, delta_max_rad: float, command_amplitude: float = 0.5,  # noqa: N802
                  command_phase_rad: float = math.radians(60.0)) -> FinLaw:
    """Return the fin law with a constant ``A`` and ``phi0`` [rad] (the former class's
    signature; new code uses :class:`FinLaw`)."""
    return FinLaw(delta_max_rad=delta_max_rad, command_amplitude=command_amplitude,
                  command_phase_deg=math.degrees(command_phase_rad))


__all__ = ["CLOCK_KEYS", "FIN_LAW_KEYS", "LAW_EVALUATIONS", "FinLaw", "MAX_DELAY_S", "Profile",
           "RelayActuator", "Track", "profile"]
