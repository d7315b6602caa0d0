"""Held, free and prior coefficients: :class:`CoefficientSpec`, written once for every method.

Each coefficient of :data:`aeroid.model.NAMES` is **free** (the default), **held** at a
value (taken as known: it is not estimated and has no standard error), or given a
**Gaussian prior** ``N(mean, sd^2)`` (estimated, with the prior's information
``1 / sd^2`` added to the data's). A spec comes from text (``--hold Czd=0``,
``--prior Cmq=-1500:300``, :meth:`CoefficientSpec.parse`), from a mapping
(:meth:`CoefficientSpec.from_mapping`) or from the airframe (a passive fin holds the fin
terms, :func:`airframe_holds`); :meth:`aeroid.estimation.Estimator.fit` takes it as
``holds=`` and every method that supports it (``supports_holds``) receives it in
``run(..., holds=spec)``.

The spec's own arithmetic is here: the free / held index sets, reduced and full
parameter vectors (:meth:`CoefficientSpec.expand`), the prior's information
(:meth:`CoefficientSpec.prior_information`); what the methods share with it (the
Gaussian combination with the priors, the floor, a swarm's cost, the result's
bookkeeping) is in :mod:`aeroid.estimation._holds_fit`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aeroid.errors import EstimatorError
from aeroid.model import NAMES, tables

__all__ = ["FIN_TERMS", "CoefficientSpec", "HeldIndexes", "airframe_holds", "describe_holds",
           "holds_json"]

#: The coefficients that multiply the fin deflection (aeroid/model/_equations.py: F_AZ's
#: ``Czd delta`` and M_Y's ``Cmd delta``): held at zero for an airframe without a moving fin.
FIN_TERMS: tuple[str, ...] = ("Czd", "Cmd")


def _number(text: Any, where: str) -> float:
    if isinstance(text, bool):
        raise EstimatorError(f"{where}: expected a number, got {text!r}")
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise EstimatorError(f"{where}: expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise EstimatorError(f"{where}: expected a finite number, got {text!r}")
    return value


def _check_name(name: str, where: str) -> str:
    if tables.ANGLE_SEPARATOR in name:  # an angle table point, Cma@A4deg: as a Mach point
        try:
            base, kind, knot = tables.split_point(name)
        except ValueError:
            base, kind, knot = "", "", math.nan
        if base not in NAMES or kind != "alpha" or not math.isfinite(knot):
            raise EstimatorError(f"{where}: {name!r} is no table point (NAME@A<angle>deg, e.g. "
                                 f"Cma@A4deg; coefficients: {', '.join(NAMES)})")
        return f"{base}{tables.ANGLE_SEPARATOR}{math.degrees(knot):g}deg"
    base, sep, knot = name.partition(tables.POINT_SEPARATOR)
    if sep:  # a table point, Cx@M1.4: matched to the flight's tables by the fit
        try:
            number = float(knot)
        except ValueError:
            number = math.nan
        if base not in NAMES or not math.isfinite(number):
            raise EstimatorError(f"{where}: {name!r} is no table point (NAME@M<Mach>, e.g. "
                                 f"Cx@M1.4; coefficients: {', '.join(NAMES)})")
        return tables.point_name(base, number)
    if name not in NAMES:
        raise EstimatorError(f"{where}: unknown coefficient {name!r} "
                             f"(coefficients: {', '.join(NAMES)})")
    return name


def _order(name: str) -> tuple[int, float]:
    """Sort key: a coefficient's place in NAMES, its table points after it by their knot."""
    base, kind, knot = tables.split_point(name)
    return NAMES.index(base), knot if kind else -math.inf


class HeldIndexes:
    """Where the held parameters sit among a spec's parameters (:meth:`parameter_order`):
    shared by :class:`CoefficientSpec` (the nine coefficients) and the tables'
    :class:`aeroid.estimation.TableHolds` (the tables' parameters)."""

    held: Mapping[str, float]
    priors: Mapping[str, tuple[float, float]]

    def parameter_order(self) -> tuple[str, ...]:
        """The parameters the indexes refer to, in order."""
        raise NotImplementedError

    @property
    def free_mask(self) -> np.ndarray:
        """Bool array over :meth:`parameter_order`: True where the parameter is estimated."""
        return np.array([n not in self.held for n in self.parameter_order()])

    @property
    def free_index(self) -> np.ndarray:
        """Indices into :meth:`parameter_order` of the estimated parameters."""
        return np.flatnonzero(self.free_mask)

    @property
    def held_index(self) -> np.ndarray:
        """Indices into :meth:`parameter_order` of the held parameters."""
        return np.flatnonzero(~self.free_mask)

    @property
    def free_names(self) -> tuple[str, ...]:
        """Names of the estimated parameters, in :meth:`parameter_order`."""
        return tuple(n for n in self.parameter_order() if n not in self.held)

    def held_values(self) -> np.ndarray:
        """Values of the held parameters, in :attr:`held_index` order."""
        order = self.parameter_order()
        return np.array([self.held[order[j]] for j in self.held_index], dtype=float)

    def expand(self, free_values: np.ndarray) -> np.ndarray:
        """Return full parameter vectors (..., n) from free ones (..., n_free)."""
        free_values = np.asarray(free_values, dtype=float)
        out = np.empty((*free_values.shape[:-1], len(self.parameter_order())))
        out[..., self.free_index] = free_values
        out[..., self.held_index] = self.held_values()
        return out

    def with_held(self, theta: np.ndarray) -> np.ndarray:
        """Return a copy of full vectors ``theta`` (..., n) with the held values put in."""
        out = np.array(theta, dtype=float, copy=True)
        out[..., self.held_index] = self.held_values()
        return out

    def prior_mean_sd(self) -> tuple[np.ndarray, np.ndarray]:
        """Return the prior's mean and sd over :meth:`parameter_order` (NaN where none;
        a prior on a name outside it - a table point of the nine's spec - is left out)."""
        order = self.parameter_order()
        mean = np.full(len(order), np.nan)
        sd = np.full(len(order), np.nan)
        for name, (m, s) in self.priors.items():
            if name in order:
                mean[order.index(name)], sd[order.index(name)] = m, s
        return mean, sd

    def prior_information(self) -> np.ndarray:
        """Return ``1 / sd^2`` over :meth:`parameter_order` (0 where there is no prior)."""
        _, sd = self.prior_mean_sd()
        return np.where(np.isfinite(sd), 1.0 / np.where(np.isfinite(sd), sd, 1.0) ** 2, 0.0)


@dataclass(frozen=True)
class CoefficientSpec(HeldIndexes):
    """Which coefficients are held (at what value) and which have a Gaussian prior.

    Attributes
    ----------
    held : mapping of str -> float
        Coefficient name -> the value it is held at.
    priors : mapping of str -> (float, float)
        Coefficient name -> ``(mean, sd)`` of its Gaussian prior, ``sd > 0``.
    sources : mapping of str -> str
        Coefficient name -> where the hold or prior was declared (``--hold``, ``passive
        fin``, ...), for the one-line notices.

    Raises
    ------
    EstimatorError
        One line for an unknown name, a non-finite value, ``sd <= 0``, or a coefficient
        both held and given a prior.
    """

    held: Mapping[str, float] = field(default_factory=dict)
    priors: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    sources: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        held = {_check_name(str(n), "hold"): _number(v, f"hold {n}")
                for n, v in dict(self.held).items()}
        priors = {}
        for n, pair in dict(self.priors).items():
            _check_name(str(n), "prior")
            try:
                mean, sd = pair
            except (TypeError, ValueError):
                raise EstimatorError(f"prior {n}: expected (mean, sd), got {pair!r}") from None
            mean, sd = _number(mean, f"prior {n} mean"), _number(sd, f"prior {n} sd")
            if not sd > 0:
                raise EstimatorError(f"prior {n}: the sd must be > 0, got {sd:g} (hold the "
                                     f"coefficient instead: --hold {n}={mean:g})")
            priors[_check_name(str(n), "prior")] = (mean, sd)
        both = [n for n in held if n in priors]
        if both:
            raise EstimatorError(f"{', '.join(both)}: both held and given a prior (choose one)")
        if not [n for n in NAMES if n not in held]:
            raise EstimatorError("every coefficient is held: nothing left to estimate")
        object.__setattr__(self, "held", dict(sorted(held.items(), key=lambda kv: _order(kv[0]))))
        object.__setattr__(self, "priors",
                           dict(sorted(priors.items(), key=lambda kv: _order(kv[0]))))
        object.__setattr__(self, "sources", {str(k): str(v) for k, v in
                                             dict(self.sources).items()})

    # -- building --------------------------------------------------------------------
    @classmethod
    def parse(cls, holds: Iterable[str] = (), priors: Iterable[str] = (), *,
              source: str = "command line") -> CoefficientSpec:
        """Build a spec from text: ``"Czd=0"`` holds, ``"Cmq=-1500:300"`` priors (mean:sd).

        Raises
        ------
        EstimatorError
            One line naming the item: no ``=``, a missing ``:`` in a prior, a bad number,
            an unknown name, a coefficient given twice.
        """
        held: dict[str, float] = {}
        prior: dict[str, tuple[float, float]] = {}
        for kind, items in (("hold", holds), ("prior", priors)):
            for item in items:
                name, sep, value = str(item).partition("=")
                name = name.strip()
                if not sep or not name:
                    form = "NAME=VALUE" if kind == "hold" else "NAME=MEAN:SD"
                    raise EstimatorError(f"--{kind} {item!r}: expected {form}")
                name = _check_name(name, f"--{kind} {item}")
                if name in held or name in prior:
                    what = "held" if name in held else "given a prior"
                    raise EstimatorError(f"--{kind} {item}: {name} is already {what}")
                if kind == "hold":
                    held[name] = _number(value.strip(), f"--hold {item}")
                else:
                    mean, colon, sd = value.partition(":")
                    if not colon:
                        raise EstimatorError(f"--prior {item!r}: expected NAME=MEAN:SD")
                    prior[name] = (_number(mean.strip(), f"--prior {item} mean"),
                                   _number(sd.strip(), f"--prior {item} sd"))
        where = "" if source == "command line" else f" ({source})"
        sources = {n: f"--hold{where}" for n in held}
        sources.update({n: f"--prior{where}" for n in prior})
        return cls(held=held, priors=prior, sources=sources)

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any], *, source: str = "holds"
                     ) -> CoefficientSpec:
        """Build a spec from ``{"hold": {name: value}, "prior": {name: [mean, sd]}}``.

        Raises
        ------
        EstimatorError
            One line naming ``source`` and the unknown key or bad entry.
        """
        if not isinstance(data, Mapping):
            raise EstimatorError(f"{source}: expected a table with 'hold' and/or 'prior', "
                                 f"got {type(data).__name__}")
        unknown = sorted(str(k) for k in data if k not in ("hold", "prior"))
        if unknown:
            raise EstimatorError(f"{source}: unknown key(s) {', '.join(unknown)} (allowed: "
                                 "hold, prior)")
        held = data.get("hold", {}) or {}
        prior = data.get("prior", {}) or {}
        for key, table in (("hold", held), ("prior", prior)):
            if not isinstance(table, Mapping):
                raise EstimatorError(f"{source}: {key} must be a table of coefficients")
        sources = {str(n): f"{source} hold" for n in held}
        sources.update({str(n): f"{source} prior" for n in prior})
        return cls(held=dict(held), priors=dict(prior), sources=sources)

    @classmethod
    def coerce(cls, value: Any) -> CoefficientSpec:
        """Return ``value`` as a spec: a spec, None (all free) or a mapping (``from_mapping``)."""
        if value is None:
            return cls()
        if isinstance(value, CoefficientSpec):
            return value
        if isinstance(value, Mapping):
            return cls.from_mapping(value)
        raise EstimatorError(f"holds: expected a CoefficientSpec, a mapping or None, got "
                             f"{type(value).__name__}")

    def merged(self, other: CoefficientSpec) -> CoefficientSpec:
        """Return both specs in one; a coefficient declared in both must agree exactly.

        Raises
        ------
        EstimatorError
            One line naming the coefficient declared differently and where.
        """
        held, priors, sources = dict(self.held), dict(self.priors), dict(self.sources)
        for name in sorted({*NAMES, *other.held, *other.priors}, key=_order):
            mine = ("hold", self.held[name]) if name in self.held else (
                ("prior", self.priors[name]) if name in self.priors else None)
            theirs = ("hold", other.held[name]) if name in other.held else (
                ("prior", other.priors[name]) if name in other.priors else None)
            if theirs is None:
                continue
            if mine is not None and mine != theirs:
                raise EstimatorError(
                    f"{name}: declared twice, differently: {mine[0]} {mine[1]} "
                    f"({self.sources.get(name, '?')}) and {theirs[0]} {theirs[1]} "
                    f"({other.sources.get(name, '?')})")
            if name in other.held:
                held[name] = other.held[name]
            else:
                priors[name] = other.priors[name]
            sources.setdefault(name, other.sources.get(name, "?"))
        return CoefficientSpec(held=held, priors=priors, sources=sources)

    @property
    def points(self) -> tuple[str, ...]:
        """The names of table points (``Cx@M1.4``, ``Cma@A4deg``) held or given a prior."""
        return tuple(n for n in (*self.held, *self.priors) if n not in NAMES)

    # -- index sets ------------------------------------------------------------------
    @property
    def empty(self) -> bool:
        """True when every coefficient is free without a prior."""
        return not self.held and not self.priors

    def parameter_order(self) -> tuple[str, ...]:
        """The nine coefficients, :data:`NAMES`."""
        return NAMES

    # -- reporting ---------------------------------------------------------------------
    def describe(self) -> str:
        """Return one line: what is held and what has a prior (empty when all are free)."""
        return describe_holds(self)

    def to_json(self) -> dict[str, Any]:
        """Return ``{"held": {name: value}, "priors": {name: {"mean", "sd"}}}``."""
        return holds_json(self)


def describe_holds(spec: Any) -> str:
    """One line of ``spec``'s ``held`` (with ``sources``) and ``priors`` (empty when none);
    :class:`CoefficientSpec` and the tables' :class:`aeroid.estimation.TableHolds`."""
    parts = []
    if spec.held:
        parts.append("held " + ", ".join(
            f"{n} = {v:g} ({spec.sources.get(n, 'given')})" for n, v in spec.held.items()))
    if spec.priors:
        parts.append("prior " + ", ".join(
            f"{n} ~ N({m:g}, {s:g}^2)" for n, (m, s) in spec.priors.items()))
    return "; ".join(parts)


def holds_json(spec: Any) -> dict[str, Any]:
    """``{"held": {name: value}, "priors": {name: {"mean", "sd"}}}`` of ``spec``."""
    return {"held": dict(spec.held),
            "priors": {n: {"mean": m, "sd": s} for n, (m, s) in spec.priors.items()}}


def airframe_holds(airframe: Any) -> CoefficientSpec:
    """Return what an airframe declares: the fin terms held at zero for ``fin =
    "passive"`` (a log without a moving fin says nothing of them), its ``[hold]`` values
    and its ``[prior_sd]`` priors, centred on its ``[prior]``.

    Raises
    ------
    EstimatorError
        When the passive fin and ``[hold]`` or ``[prior_sd]`` disagree on a fin term.
    """
    spec = CoefficientSpec()
    if getattr(airframe, "fin", "relay") == "passive":
        spec = CoefficientSpec(held=dict.fromkeys(FIN_TERMS, 0.0),
                               sources=dict.fromkeys(FIN_TERMS, "passive fin"))
    held = dict(getattr(airframe, "hold", ()) or ())
    sd = dict(getattr(airframe, "prior_sd", ()) or ())
    if not (held or sd):
        return spec
    mean = dict(zip(NAMES, airframe.prior_vector(), strict=True))
    sources = {n: "airframe [hold]" for n in held}
    sources.update({n: "airframe [prior_sd]" for n in sd})
    return spec.merged(CoefficientSpec(held=held, priors={n: (mean[n], s) for n, s in sd.items()},
                                       sources=sources))
