"""The estimator interface: :class:`Estimator` and the default search box, :func:`prior_bounds`.

An estimator is a frozen, keyword-only dataclass that holds options only (no state is
kept on ``self``: one instance serves many runs and processes). Subclasses implement
:meth:`Estimator.run`; callers use :meth:`Estimator.fit`, which validates the flight,
times the run, passes progress reports to the caller's listener and turns any failure
inside the method into ``success=False`` with a message (failure is data: a study
records it and goes on).
"""

from __future__ import annotations

import abc
import dataclasses
import logging
import time
import typing
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from aeroid.errors import AeroidError, EstimatorError
from aeroid.estimation._air_data import ignored_air_data_warning
from aeroid.estimation._consider import add_consider, check_consider
from aeroid.estimation._fitcheck import apply_fit_check, data_noise_levels, floor_warnings
from aeroid.estimation._holds import CoefficientSpec, airframe_holds
from aeroid.estimation._holds_fit import apply_holds, check_free
from aeroid.estimation._identifiability import record_findings, record_verdict
from aeroid.estimation._options import OptionInfo, coerce, describe_options, options_of, parse_value
from aeroid.estimation._progress import ProgressCallback, progress_listener
from aeroid.estimation._result import EstimationResult, failed_result
from aeroid.estimation._table_holds import TableHolds, fit_tables, table_holds
from aeroid.estimation._windows import (
    check_windows,
    common_findings,
    pooled_noise_levels,
    windows_info,
)
from aeroid.flights import (
    AIR_TEMPERATURE,
    Flight,
    InputChoice,
    Windows,
    check_input,
    flight_mach_tables,
    speed_of_sound_note,
    unused_note,
    with_pitot_airspeed,
)
from aeroid.model import NAMES, Airframe

__all__ = ["Estimator", "prior_bounds"]


@dataclass(frozen=True, kw_only=True)
class Estimator(abc.ABC):
    """Base class of every estimator: a frozen keyword-only dataclass of options.

    Subclasses set the class variables :attr:`name` and :attr:`description`, declare
    their options as dataclass fields with defaults and type hints (used to parse
    ``--option key=value`` and study files) and document each in the class docstring's
    ``Options`` (or ``Attributes``) section (``aeroid methods --options NAME`` prints
    the first sentence of each entry), and implement :meth:`run`.

    An option named ``input`` is the fin deflection between samples of a method that
    integrates the model (:data:`aeroid.flights.INPUTS`, default ``auto``): :meth:`fit`
    resolves it, checks the deflection of ``law`` and ``events`` against the logged one
    (:func:`aeroid.flights.check_input`, with the option ``delay_s`` when there is one)
    and records the input used in the result's field ``input`` and its ``info``
    (``input``, ``input_reason``, ``input_agreement``); an option named ``noise_model``
    is recorded in the result's field ``noise_model``. A method whose ``input`` is not
    used in some configuration overrides :meth:`deflection_input`.
    """

    name: ClassVar[str] = ""
    description: ClassVar[str] = ""
    #: True for a method that uses the sd of a reconstruction's states (a flight with
    #: ``metadata['initial_state_sd']``, :meth:`aeroid.reconstruction.Reconstruction.
    #: to_flight`); for the others :meth:`fit` warns that the states were taken as exact.
    uses_state_sd: ClassVar[bool] = False
    #: True for a method that leaves a flight's saturated samples (``metadata
    #: ['saturated']``, :func:`aeroid.flights.used_samples`) out of its likelihood; the
    #: others refuse such a flight in :meth:`fit` (its clipped values are not the truth).
    leaves_out_saturated: ClassVar[bool] = False
    #: True for a method that fits several windows with shared coefficients
    #: (:meth:`run_windows`); :meth:`fit` of a :class:`aeroid.flights.Windows` refuses the
    #: others in one line.
    supports_windows: ClassVar[bool] = False
    #: True for a method that uses a flight's logged air-data angles (its option
    #: ``air_data``); :meth:`fit` warns in one line that every other one ignores them.
    uses_air_data: ClassVar[bool] = False
    #: True for a method whose :meth:`run` takes ``holds=`` (a
    #: :class:`aeroid.estimation.CoefficientSpec` with something held or a prior): it
    #: estimates only the free coefficients and adds the priors' information. :meth:`fit`
    #: refuses holds and priors for the others in one line.
    supports_holds: ClassVar[bool] = False
    #: True for a method that fits the airframe's coefficient tables in Mach
    #: (``[tables]``, :class:`aeroid.model.TableSpec`); :meth:`fit` refuses such a flight
    #: for the others instead of fitting constants in silence.
    fits_tables: ClassVar[bool] = False

    @abc.abstractmethod
    def run(self, flight: Flight, rng: np.random.Generator) -> EstimationResult:
        """Estimate the nine coefficients from a validated ``flight``.

        Implementations read the airframe from ``flight.airframe`` and never read
        ``flight.metadata["true_coefficients"]``. They may raise on failure:
        :meth:`fit` turns that into ``success=False``. Long methods may report progress
        with :func:`aeroid.estimation.report_progress`.
        """

    def run_windows(self, windows: Windows, rng: np.random.Generator, holds: Any = None
                    ) -> EstimationResult:
        """Estimate the coefficients shared by several validated windows (``supports_windows``).

        Each window keeps its own initial state, atmosphere and, where the method
        estimates them, IMU errors and fin delay (reported per window in
        ``info['window_parameters']`` and ``info['window_parameter_stderr']``).
        ``holds`` as :meth:`run`'s (given only when something is held or has a prior, and
        only to a method with ``supports_holds``).
        """
        raise EstimatorError(f"{self.name or type(self).__name__}: cannot fit several windows")

    def fit(self, flight: Flight | Windows, *,
            rng: np.random.Generator | int | None = None,
            progress: ProgressCallback | None = None,
            holds: CoefficientSpec | Mapping[str, Any] | None = None) -> EstimationResult:
        """Validate ``flight``, run the method, time it; never raise for a numerical failure.

        An airframe with a mass or inertia sd (``mass_sd_kg``, ...) makes two more fits
        per uncertain constant: the result's ``stderr`` and ``covariance`` then include
        its share and ``result.consider`` keeps the method's own
        (:func:`aeroid.estimation.add_consider`).

        Parameters
        ----------
        flight : Flight or Windows
            Several windows (:class:`aeroid.flights.Windows`) are fitted together with
            shared coefficients by a method with ``supports_windows``
            (:meth:`run_windows`); the others refuse. Every window is checked as a
            flight is; the fit check judges the stacked residuals
            (:mod:`aeroid.estimation._windows`); a coefficient is named as not
            identifiable when no window determines it.
        rng : Generator, int or None
            Source of the method's random draws (``np.random.default_rng(rng)``).
        progress : callable or None
            ``progress(event)`` with a :class:`aeroid.estimation.ProgressEvent`, called
            by methods that report progress (the paper's PSO methods: every iteration).
        holds : CoefficientSpec, mapping or None
            Coefficients held at a value or given a Gaussian prior (default: all free;
            a mapping is read by :meth:`CoefficientSpec.from_mapping`). What is held is
            said in one line (logger ``aeroid``, INFO) and recorded in the result
            (``held``, ``priors``); held coefficients have no standard error. An
            airframe with ``fin = "passive"`` holds Czd and Cmd at zero (a hold or prior
            given on them too must agree: one line otherwise). A
            coefficient the record cannot determine
            (:func:`aeroid.estimation.record_findings`: no fin motion, no pitch or yaw
            rate, a constant roll rate) is named before the fit (same logger); left free
            without a prior, the result is ``success=False`` and
            ``info["not_identifiable"]`` names it with its reason.

        Raises
        ------
        FlightError
            When the flight is invalid (missing channel, NaN, bad time base...).
        EstimatorError
            When ``rng`` is not a valid seed or generator.
        AeroidError
            Any other bad input the method finds (e.g. a swarm too large for the flight);
            every other exception inside the method gives ``success=False``.
        """
        owner = self.name or type(self).__name__
        flight = with_pitot_airspeed(flight)  # a probe's pressures as its airspeed, said
        windows = flight if isinstance(flight, Windows) else None
        parts = dict(windows.items()) if windows is not None else {"": flight}
        tables = getattr(flight.airframe, "tables", None)
        if tables is not None and not self.fits_tables:
            raise EstimatorError(
                f"{owner}: the airframe's [tables] makes "
                f"{', '.join(name for name, _ in (*tables.knots, *tables.angle_knots))} "
                "tables (in Mach or the angle of attack); this method "
                "fits constant coefficients (output-error, equation-error, ekf and ukf fit "
                "tables); "
                "remove [tables] to fit constants")
        if windows is not None and tables is not None and any(
                AIR_TEMPERATURE in p.channels for p in parts.values()):
            raise EstimatorError(f"{owner}: several windows with [tables] and an "
                                 f"{AIR_TEMPERATURE} channel: Mach from a logged temperature "
                                 "is fitted on one flight (fit a window alone, or drop it)")
        given = airframe_holds(flight.airframe).merged(CoefficientSpec.coerce(holds))
        if windows is not None:
            check_windows(self, windows, given, tables is not None)
        saturated = {}
        for name, part in parts.items():
            part.validate()
            saturated = part.metadata.get("saturated") or {}
            if saturated and windows is not None:
                raise EstimatorError(
                    f"{owner}: window {name!r} has saturated samples (metadata "
                    "'saturated'); several windows cannot leave them out yet: fit that "
                    "window alone")
            if saturated and not self.leaves_out_saturated:
                raise EstimatorError(
                    f"{owner}: the flight has {sum(len(k) for k in saturated.values())} "
                    f"saturated sample(s) in {', '.join(saturated)} (metadata 'saturated'); "
                    "this method cannot leave them out of its fit (output-error, ekf and ukf "
                    "can)")
        if given.points and tables is None:
            raise EstimatorError(f"{owner}: {', '.join(given.points)}: table points, and the "
                                 "airframe has no [tables]")
        if not given.empty and not self.supports_holds:
            raise EstimatorError(f"{owner}: this method cannot hold coefficients or take "
                                 f"priors ({given.describe()}); fit all nine free")
        spec: CoefficientSpec | TableHolds = given  # with tables: their constants and points
        if tables is not None and not given.empty:
            spec = table_holds(given, fit_tables(flight))  # windows: their shared knots
        if not spec.empty:
            logging.getLogger("aeroid").info(f"{owner}: {spec.describe()}")
        if tables is not None and windows is None:  # which speed of sound Mach used
            logging.getLogger("aeroid").info(
                f"{owner}: {speed_of_sound_note(flight, flight_mach_tables(flight))}")
        known = spec.covers() if isinstance(spec, TableHolds) else {**spec.held, **spec.priors}
        findings = common_findings([record_findings(p) for p in parts.values()])
        for finding in findings:  # what the record cannot determine, said first
            if any(n not in known for n in finding.names):
                logging.getLogger("aeroid").info(f"{owner}: {finding.text()}")
        choices = {name: self.input_choice(part) for name, part in parts.items()}
        for part in parts.values():
            check_consider(part, owner)
        try:
            generator = np.random.default_rng(rng)
        except (TypeError, ValueError) as exc:
            raise EstimatorError(f"{owner}: bad seed {rng!r}: "
                                 f"{' '.join(str(exc).split())}") from None
        start = time.perf_counter()
        try:
            with np.errstate(all="ignore"), progress_listener(progress):
                if windows is not None and spec.empty:
                    result = self.run_windows(windows, generator)
                elif windows is not None:
                    result = self.run_windows(windows, generator, holds=spec)
                elif spec.empty:
                    result = self.run(flight, generator)
                else:
                    result = self.run(flight, generator, holds=spec)  # type: ignore[call-arg]
        except AeroidError:
            raise  # bad input found by the method (data, options): a user error, one line
        except Exception as exc:  # failure is data (module docstring)
            text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
            result = failed_result(self.name, f"{type(exc).__name__}: {text}".rstrip(": "))
        elapsed = time.perf_counter() - start
        if result.success and not np.all(np.isfinite(result.theta)):
            result = dataclasses.replace(result, success=False,
                                         message=result.message or "non-finite estimate")
        used = sorted({c.input for c in choices.values() if c is not None})
        result = dataclasses.replace(result, input=",".join(used) or None,
                                     noise_model=self.noise_model_used())
        result = apply_holds(result, spec)
        if windows is not None:
            levels = pooled_noise_levels(windows) if result.success else None
            checked = windows.joined()
        else:  # one smoother pass
            levels = data_noise_levels(flight) if result.success else None
            checked = flight
        result = check_free(result, spec,  # held coefficients are known: not checked
                            lambda r: apply_fit_check(r, checked, levels, self.options()))
        failure, left = record_verdict(findings, known, {})
        if left and failure is not None:  # estimated freely though the record cannot tell
            result = dataclasses.replace(  # the cause first; the method's own failure kept
                result, success=False, message=failure, info={**result.info,
                                                              "not_identifiable": left},
                warnings=(*result.warnings, *([] if result.success else [result.message])))
        info = dict(result.info)
        info.setdefault("options", self.options())
        extra: tuple[str, ...] = ()
        if windows is not None:
            info.update(windows_info(windows, choices))
        else:
            choice = choices[""]
            if choice is not None:
                info.update(choice.as_info())
            if saturated:  # left out of the likelihood by this method (leaves_out_saturated)
                info["saturated_left_out"] = {c: len(k) for c, k in saturated.items()}
            extra += floor_warnings(result, flight, levels)
        result = dataclasses.replace(result, wall_time_s=elapsed, info=info)
        for choice in choices.values():
            extra += tuple(w for w in (choice.warnings if choice else ()) if w not in extra)
        if (any("initial_state_sd" in p.metadata for p in parts.values())
                and not self.uses_state_sd):
            extra += (f"{owner}: the {'windows' if windows else 'flight'}'s states are a "
                      "reconstruction's, with sd (metadata initial_state_sd); this method "
                      "takes them as exact, so its standard errors leave their uncertainty "
                      "out",)
        for part in parts.values():
            ignored = None if self.uses_air_data else ignored_air_data_warning(part, owner)
            extra += (ignored,) if ignored and ignored not in extra else ()
            unused = unused_note(part)  # a logged air temperature without [tables]
            extra += (f"{owner}: {unused}",) if unused and f"{owner}: {unused}" not in extra \
                else ()
        if extra:
            result = dataclasses.replace(result, warnings=tuple(result.warnings) + extra)
        return add_consider(self, flight, result, rng=generator)  # uncertain mass, if any

    def deflection_input(self) -> str | None:
        """Return the ``input`` option of a method that integrates the model, else None."""
        return getattr(self, "input", None) if "input" in self.option_names() else None

    def noise_model_used(self) -> str | None:
        """Return the ``noise_model`` option of a method that has one, else None."""
        return getattr(self, "noise_model", None) if "noise_model" in self.option_names() \
            else None

    def input_choice(self, flight: Flight) -> InputChoice | None:
        """Resolve and check the deflection input on ``flight`` (class docstring).

        ``auto`` taken as ``law`` is said in one line (logger ``aeroid``, level INFO).

        Raises
        ------
        FlightError
            When the deflection of ``law`` or ``events`` contradicts the logged one.
        """
        given = self.deflection_input()
        if given is None:
            return None
        owner = self.name or type(self).__name__
        choice = check_input(flight, given, float(getattr(self, "delay_s", 0.0) or 0.0),
                             owner=owner)
        if given == "auto" and choice.input == "law":
            logging.getLogger("aeroid").info(choice.notice(owner))
        return choice

    def options(self) -> dict[str, Any]:
        """Return the options as a dict (field name -> value)."""
        return {f.name: getattr(self, f.name) for f in options_of(self)}

    @classmethod
    def option_names(cls) -> tuple[str, ...]:
        """Return the names of the options."""
        return tuple(f.name for f in options_of(cls))

    @classmethod
    def describe_options(cls) -> list[OptionInfo]:
        """Return each option's name, type, default and one-line description."""
        return describe_options(cls)

    @classmethod
    def from_options(cls, options: Mapping[str, Any] | None = None) -> Estimator:
        """Build the estimator from options given as values or as text (``"450"``).

        Raises
        ------
        EstimatorError
            One line naming the estimator and the unknown or invalid option.
        """
        options = dict(options or {})
        owner = cls.name or cls.__name__
        allowed = cls.option_names()
        unknown = sorted(set(options) - set(allowed))
        if unknown:
            raise EstimatorError(
                f"{owner}: unknown option(s) {', '.join(unknown)} "
                f"(options: {', '.join(allowed) or 'none'})"
            )
        hints = typing.get_type_hints(cls)
        kwargs = {}
        for key, value in options.items():
            if isinstance(value, str):
                value = parse_value(value)
            kwargs[key] = coerce(key, value, hints.get(key, Any), owner)
        try:
            return cls(**kwargs)
        except (TypeError, ValueError) as exc:
            raise EstimatorError(f"{owner}: {exc}") from None


def prior_bounds(airframe: Airframe, box: Any = None,
                 scale: tuple[float, float] = (0.5, 1.5)) -> np.ndarray:
    """Return the PSO search box, shape (N_COEFFICIENTS, 2) [low, high] per coefficient.

    The box is the airframe's prior (nominal values when it has none) times ``scale``,
    sorted per coefficient (negative coefficients flip), or ``box`` when given: a
    (N_COEFFICIENTS, 2) array-like, or a flat list of 2 N_COEFFICIENTS numbers
    ``[low0, high0, low1, ...]``.
    The true coefficients are never read.
    """
    if box is not None:
        arr = np.asarray(box, dtype=float).reshape(len(NAMES), 2)
        if not (np.all(np.isfinite(arr)) and np.all(arr[:, 0] < arr[:, 1])):
            raise EstimatorError(f"search box: need {len(NAMES)} finite [low, high] pairs "
                                 "with low < high")
        return arr
    prior = airframe.prior_vector()
    ends = np.stack([prior * scale[0], prior * scale[1]], axis=1)
    return np.sort(ends, axis=1)
