"""The deflection an estimator integrates, checked against the logged one before a fit.

With ``input = law`` (the fin law on the measured roll angle) or ``events`` (switch
knots) the model does not integrate the logged deflection ``delta`` but one of its own.
If that one contradicts the log (a law with the wrong phase or amplitude, knots of the
opposite sign), the fit is of the wrong physics and Czd, Cmd, Czq, Cmq come out wrong,
often with the wrong sign. So the model's deflection at the sample instants (exactly as
the estimator evaluates it, the law's delay and the estimator's ``delay_s`` included) is
compared with ``delta`` (:func:`input_agreement`):

* a sample **agrees** when the two differ by at most :data:`AGREE_RTOL` of the
  airframe's ``delta_max``;
* a law that places a switch less than one sample interval off the log's disagrees at
  most at one sample per switch; the **disagreements per switch** (disagreeing samples
  over the log's switches) is then about the mean switch offset in sample intervals.

Verdicts (:func:`check_input`): more than :data:`REFUSE_PER_SWITCH` disagreements per
switch (more than switch timing within a sample can explain: a wrong phase or amplitude,
the opposite sign, another relay) is a one-line :class:`~aeroid.errors.FlightError`;
more than :data:`WARN_PER_SWITCH`, or a logged throw that differs from ``delta_max`` by
more than :data:`THROW_RTOL`, is a warning with the figures. Calibration (noise-free
flights of ``studies/scenarios/continuous_relay.toml`` and ``delayed_relay.toml``,
``tests/unit/test_input_agreement.py``): the right law on a continuous, a latched, a
delayed rate-limited and a 2 kHz control-rate relay disagrees at 0 of 501 samples; a
sign-flipped log at 501 (15.7 per switch), the phase 90 deg off at 67 (2.1), the
amplitude ``A = 1`` for 0.5 at 86 (2.7); a law 1 ms late at 15 (0.47), ``A = 0.6`` at 15,
the phase 10 deg off at 11 (0.34), the 1.3 kHz control-rate relay modelled as continuous
at 4 (0.125: it lags the law by up to 0.77 ms, 5.4 % mean error with the law).

What the check cannot see: a relay latched at a clock (the log's or its own) agrees with
a continuous law at every sample instant; between samples it switches up to a clock
period later (the latched relay of ``continuous_relay.toml``: 18.6 % mean error with the
continuous law, refused by the fit check). State the clock in the law (``[fin_law]
evaluation = "latched"`` or ``control_rate_Hz``, :mod:`aeroid.model._actuator`): then
the law is the relay's (0.52 %).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from aeroid.errors import FlightError
from aeroid.flights._flight import Flight
from aeroid.flights._record import resolve_input, schedule

#: A logged sample agrees with the model's deflection when they differ by at most this
#: fraction of the airframe's ``delta_max``: a tenth of the throw (0.8 deg at 8 deg), far
#: above a simulated log's rounding and a deflection sensor's noise, far below the 2
#: ``delta_max`` of a relay on the other stop. A throw off by less is :data:`THROW_RTOL`'s.
AGREE_RTOL = 0.1
#: Disagreeing samples per logged switch above which the input contradicts the log: a
#: switch placed less than a sample interval off disagrees at one sample at most.
REFUSE_PER_SWITCH = 1.0
#: Disagreeing samples per logged switch above which the agreement is partial (a warning):
#: a mean switch offset of a tenth of a sample interval. Correct laws on simulated flights
#: disagree nowhere; this leaves room for a few switches a noisy roll angle misplaces.
WARN_PER_SWITCH = 0.1
#: The logged throw (median ``|delta|`` where the model is at a stop and agrees) differing
#: from the airframe's ``delta_max`` by more than this fraction is a warning: the law
#: integrates ``delta_max``, so Czd and Cmd would be off by about as much.
THROW_RTOL = 0.01
#: Inputs whose deflection is not the logged one (the others are made from ``delta``).
CHECKED_INPUTS = ("law", "events")


@dataclass(frozen=True)
class Agreement:
    """How the model's deflection at the sample instants agrees with the logged one.

    Attributes
    ----------
    input : str
        The input compared (``law`` or ``events``).
    n_samples, n_agree : int
        Samples, and those that agree (:data:`AGREE_RTOL`).
    n_switches : int
        Switches in the log (sign changes of ``delta``).
    first_disagreement_s : float or None
        Time of the first disagreeing sample [s].
    opposite_sign : int
        Disagreeing samples where the model's deflection has the opposite sign.
    throw_ratio : float
        Median logged ``|delta|`` over ``delta_max`` where the model is at a stop and
        agrees (NaN when there is no such sample).
    dt : float
        Sample interval [s].
    """

    input: str
    n_samples: int
    n_agree: int
    n_switches: int
    first_disagreement_s: float | None
    opposite_sign: int
    throw_ratio: float
    dt: float

    @property
    def share(self) -> float:
        """Share of the samples that agree."""
        return self.n_agree / self.n_samples

    @property
    def per_switch(self) -> float:
        """Disagreeing samples per logged switch (inf with disagreements and no switch)."""
        n_disagree = self.n_samples - self.n_agree
        if n_disagree == 0:
            return 0.0
        return n_disagree / self.n_switches if self.n_switches else math.inf

    @property
    def verdict(self) -> str:
        """``"agrees"``, ``"partial"`` (a warning) or ``"contradicts"`` (an error)."""
        if self.per_switch > REFUSE_PER_SWITCH:
            return "contradicts"
        if self.per_switch > WARN_PER_SWITCH or (
                math.isfinite(self.throw_ratio) and abs(self.throw_ratio - 1.0) > THROW_RTOL):
            return "partial"
        return "agrees"

    def figures(self) -> str:
        """The figures in words, one line."""
        what = "the [fin_law] agrees" if self.input == "law" else "the switch knots agree"
        text = (f"{what} with the logged delta at {self.n_agree} of "
                f"{self.n_samples} samples ({100.0 * self.share:.1f} %)")
        if self.first_disagreement_s is not None:
            text += (f", first disagreement at t = {self.first_disagreement_s:.6g} s; "
                     f"{self.n_samples - self.n_agree} disagreeing samples at "
                     f"{self.n_switches} logged switches")
            if self.opposite_sign:
                text += f", {self.opposite_sign} of them of the opposite sign"
        return text

    def as_dict(self) -> dict[str, Any]:
        """The figures as a JSON-ready dict (for a result's ``info``)."""
        return {"input": self.input, "n_samples": self.n_samples, "n_agree": self.n_agree,
                "share": self.share, "n_switches": self.n_switches,
                "first_disagreement_s": self.first_disagreement_s,
                "opposite_sign": self.opposite_sign,
                "throw_ratio": None if math.isnan(self.throw_ratio) else self.throw_ratio,
                "verdict": self.verdict}


def input_agreement(flight: Flight, input: str, delay_s: float = 0.0,  # noqa: A002
                    ) -> Agreement:
    """Compare the model's deflection of ``input`` with the logged ``delta`` (module doc).

    Parameters
    ----------
    flight : Flight
    input : str
        An input of :data:`aeroid.flights.INPUTS` (``auto`` is resolved first).
    delay_s : float
        The estimator's actuator delay [s] on top of the law's own (option ``delay_s``).
    """
    mode, _ = resolve_input(flight, input)
    sched = schedule(flight, mode)
    if delay_s:
        sched = sched.shifted(delay_s)
    t = flight.t
    model = sched.at(t)
    logged = flight["delta"]
    dmax = float(flight.airframe.delta_max_rad)
    bad = np.abs(model - logged) > AGREE_RTOL * dmax
    signs = np.sign(logged[logged != 0.0])
    n_switches = int(np.count_nonzero(signs[1:] != signs[:-1]))
    opposite = bad & (model * logged < 0.0)
    at_stop = ~bad & (np.abs(np.abs(model) - dmax) <= 1e-9 * dmax)
    throw = float(np.median(np.abs(logged[at_stop])) / dmax) if np.any(at_stop) else math.nan
    first = float(t[np.argmax(bad)]) if np.any(bad) else None
    return Agreement(input=mode, n_samples=int(t.size), n_agree=int(t.size - bad.sum()),
                     n_switches=n_switches, first_disagreement_s=first,
                     opposite_sign=int(opposite.sum()), throw_ratio=throw,
                     dt=float(flight.dt))


@dataclass(frozen=True)
class InputChoice:
    """The input an estimator integrates, why, and how it agrees with the log.

    Attributes
    ----------
    given : str
        The option as given (``auto`` or an input).
    input : str
        The input used (never ``auto``).
    reason : str
        Why, in words (``"given"`` when named).
    agreement : Agreement or None
        For ``law`` and ``events``; None for inputs made from the logged deflection.
    warnings : tuple of str
        One line each: a partial agreement with its figures.
    """

    given: str
    input: str
    reason: str
    agreement: Agreement | None
    warnings: tuple[str, ...]

    def as_info(self) -> dict[str, Any]:
        """The entries of a result's ``info``: ``input``, ``input_reason``,
        ``input_agreement``."""
        return {"input": self.input, "input_reason": self.reason,
                "input_agreement": None if self.agreement is None else self.agreement.as_dict()}

    def notice(self, owner: str) -> str:
        """One line saying which input was taken for ``auto`` and why."""
        text = f"{owner}: input = {self.input} ({self.reason}"
        if self.agreement is not None:
            text += f"; {self.agreement.figures()}"
        other = "hold" if self.input == "law" else "law"
        return text + f"); name input = {other} or another to override"


def check_input(flight: Flight, input: str, delay_s: float = 0.0, *,  # noqa: A002
                owner: str = "estimator") -> InputChoice:
    """Resolve ``input`` on ``flight`` and check its deflection against the log.

    Returns
    -------
    InputChoice
        The input used and why; for ``law`` and ``events`` the agreement and, when it is
        partial, one warning with the figures.

    Raises
    ------
    FlightError
        One line when the model's deflection contradicts the logged one (module
        docstring), or the input cannot be made (``law`` without a fin law, ``events``
        without knots, an unknown input).
    """
    mode, reason = resolve_input(flight, input)
    where = flight.metadata.get("source", "flight")
    if mode not in CHECKED_INPUTS:
        schedule(flight, mode)  # an unknown input: the one-line error
        return InputChoice(input, mode, reason, None, ())
    agreement = input_agreement(flight, mode, delay_s)
    verdict = agreement.verdict
    hint = ("check [fin_law] (command_amplitude, command_phase_deg, delay_s, evaluation) and "
            "the sign of delta" if mode == "law"
            else "check the knots' sign and times (delta_knots)")
    if verdict == "contradicts":
        raise FlightError(
            f"{where}: {owner}: input '{mode}' contradicts the log: {agreement.figures()} "
            f"({agreement.per_switch:.3g} per switch; a switch placed less than a sample "
            f"off disagrees at one sample at most): {hint}, or name input = hold")
    warnings: tuple[str, ...] = ()
    if verdict == "partial":
        parts = []
        if agreement.per_switch > WARN_PER_SWITCH:
            parts.append(f"{agreement.figures()}, as if its switches were "
                         f"{1e3 * agreement.per_switch * agreement.dt:.2g} ms off the log's "
                         f"on average")
        if math.isfinite(agreement.throw_ratio) and \
                abs(agreement.throw_ratio - 1.0) > THROW_RTOL:
            dmax_deg = math.degrees(flight.airframe.delta_max_rad)
            parts.append(f"the logged throw is {agreement.throw_ratio * dmax_deg:.4g} deg, "
                         f"the model's {dmax_deg:.4g} deg (airframe delta_max_deg): Czd and "
                         f"Cmd scale with it")
        warnings = (f"{where}: input '{mode}' agrees only in part with the logged "
                    f"deflection: {'; '.join(parts)}; the fit may be biased ({hint})",)
    return InputChoice(input, mode, reason, agreement, warnings)


__all__ = ["AGREE_RTOL", "Agreement", "CHECKED_INPUTS", "InputChoice", "REFUSE_PER_SWITCH",
           "THROW_RTOL", "WARN_PER_SWITCH", "check_input", "input_agreement"]
