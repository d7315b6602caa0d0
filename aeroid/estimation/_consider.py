"""Consider parameters: the share of an uncertain mass or inertia in the coefficients' covariance.

A coast's accelerations determine force / mass, not the force: a mass known to 3 % leaves
every force coefficient uncertain by 3 % however long the log. Jategaonkar (Flight
Vehicle System Identification, "consider parameters") and SIDPAC add that share to the
covariance of the estimate::

    cov_total = cov + S diag(sd^2) S^T,    S[:, k] = d theta_hat / d c_k

with ``c_k`` an airframe constant (``mass_kg``, ``ix_kgm2``, ``iy_kgm2``, ``iz_kgm2``) given
with a standard deviation ``sd_k > 0`` (:attr:`aeroid.model.Airframe.mass_sd`).

``S`` is computed the same way for every method: a central difference of two re-fits
(with :data:`REFIT_ITERATION_FACTOR` times the method's ``max_iterations``),
``(theta_hat(c_k + h_k) - theta_hat(c_k - h_k)) / (2 h_k)``, through the method's own
:meth:`~aeroid.estimation.Estimator.fit`. The step is the stated sd, ``h_k = sd_k``: the
secant over +-1 sd is what the linearisation stands for, exact where the estimate is
linear in the constant (a coast's force coefficients are proportional to the mass,
F = m a), and the largest step divides the optimiser's own tolerance least. The re-fits are the
method's own fit with only the constant changed (same prior, same options, one common
seed for both), so ``S`` is the derivative of the very estimator that made the estimate
and what does not depend on the constant cancels in the difference. Each uncertain
constant costs two fits: on the reference flight (``benchmarks/bench_consider.py``,
mass only, ``benchmarks/results/consider.md``) 0.27 s for output-error (its fit 0.13 s),
1.7 s for the EKF (fit 1.1 s), 0.21 s for equation-error (fit 0.21 s; every re-fit also
runs the fit check); an earlier run on a busier machine measured 2.2, 3.1 and 1.2 s. A
warm start by the airframe's prior replaced with the estimate (``warm_start=True``) was
measured and is not the default: slower in both runs (0.52, 2.4 and 0.49 s), and it would
change what the prior means to a method (the PSO methods' box is centred on it).

A method may offer its own warm start, ``estimator.warm_started(result)``: the same
method started from every parameter the fit estimated, the prior left as it is
(output-error: the tables' points, initial state, IMU errors and attitude offsets too;
:mod:`baselines._oe_warm`). Where it does, the re-fits start there by default
(``warm_start=None``) and the consider line says "started from the estimate". Measured on
the rocket measure study's coast (Cx as a Mach table, 10 kg +- 0.3 kg; ``python
benchmarks/rocket_consider_refit.py 0 --cold``, shared machine at load ~12): the two re-fits
took 67 s from the estimate against 286 s from the prior, with the same share (Cx 0.0134
at every knot, Cza 0.255 against 0.256, Czq 3.99 against 3.94; the moments' shares below
1e-3 of their own se in both); from the prior, re-fits at 9.7 kg ended unsuccessful in 10
of 48 fits of that study before (studies/rocket_measure.md), from the estimate in none of
its re-run's fits.

The re-fits hold and give priors to what the fit did (``fit(holds=...)``, read back from
the result's ``held`` and ``priors``; the airframe's own, a passive fin's or its
``[hold]``, it declares again): a held coefficient stays at its value in both, so its
sensitivity is zero and it keeps no standard error.

A flight with a per-sample channel of the constant (``mass``, ``ix``, ...) is refused:
the sd is the airframe constant's, which such a flight does not use.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from aeroid.errors import EstimatorError
from aeroid.estimation._holds import CoefficientSpec, airframe_holds
from aeroid.estimation._holds_fit import holds_of
from aeroid.estimation._result import EstimationResult
from aeroid.estimation._table_holds import fit_tables, table_holds
from aeroid.flights import Windows
from aeroid.model import MASS_SD_FIELDS

if TYPE_CHECKING:
    from aeroid.flights import Flight

__all__ = ["CONSTANT_CHANNELS", "ConsiderCovariance", "add_consider", "check_consider",
           "consider_covariance", "exact_mass_note", "refit_holds"]

#: Each mass constant -> the flight channel that would replace it per sample.
CONSTANT_CHANNELS = {"mass_kg": "mass", "ix_kgm2": "ix", "iy_kgm2": "iy", "iz_kgm2": "iz"}
#: Units of the constants, for the one-line notes.
_UNITS = {"mass_kg": "kg", "ix_kgm2": "kg m^2", "iy_kgm2": "kg m^2", "iz_kgm2": "kg m^2"}


@dataclass(frozen=True, kw_only=True, eq=False)
class ConsiderCovariance:
    """The consider parameters of a fit and their share of its covariance.

    Attributes
    ----------
    names : tuple of str
        The consider parameters (airframe attributes: ``mass_kg``, ``ix_kgm2``, ...).
    values, sd, steps : ndarray, shape (k,)
        Their values, standard deviations and the finite-difference steps used [SI].
    sensitivity : ndarray, shape (n_coefficients, k)
        ``S = d theta_hat / d c`` [coefficient unit per constant unit].
    covariance : ndarray, shape (n_coefficients, n_coefficients)
        Their share, ``S diag(sd^2) S^T``.
    stderr_without, covariance_without : ndarray or None
        The method's own standard errors and covariance, the constants taken as exact
        (the result's ``stderr`` and ``covariance`` include the share).
    n_refits : int
        Fits made for ``S`` (two per constant).
    refit_messages : tuple of str
        The re-fits that ended unsuccessful with a finite estimate, one line each. When
        both ends of a constant are unsuccessful (a verdict such as the fit check: a
        noise-free flight fits no perturbed constant within its noise) their estimates are
        used; when one end is (an optimiser stopped at its iteration limit: its estimate
        is not an optimum, and took Cl0's se to 27x its own on the rocket measure study),
        the other end's one-sided difference from the fit is used instead, and said.
    wall_time_s : float
        Their time [s].
    one_sided : bool
        A constant's sensitivity was taken from one end's one-sided difference (the other
        end unsuccessful; ``refit_messages`` names it).
    started : str
        Where the re-fits started: ``"the estimate"`` (every parameter the fit estimated:
        the method's ``warm_started``) or ``"the prior"`` (the airframe's, as the fit did).
    """

    names: tuple[str, ...]
    values: np.ndarray
    sd: np.ndarray
    steps: np.ndarray
    sensitivity: np.ndarray
    covariance: np.ndarray
    stderr_without: np.ndarray | None
    covariance_without: np.ndarray | None
    n_refits: int
    wall_time_s: float
    refit_messages: tuple[str, ...] = ()
    started: str = "the prior"
    one_sided: bool = False

    @property
    def stderr_share(self) -> np.ndarray:
        """Standard error the constants alone contribute, shape (n_coefficients,)."""
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))

    def describe(self) -> str:
        """Return one line: the consider parameters, their sd and the cost of ``S``."""
        given = ", ".join(f"{n} {v:.6g} +- {s:.3g} {_UNITS.get(n, '')}".rstrip()
                          for n, v, s in zip(self.names, self.values, self.sd, strict=True))
        used = ("the other end's one-sided difference where one end did" if self.one_sided
                else "their estimates used")
        failed = (f" ({len(self.refit_messages)} ended unsuccessful, {used})"
                  if self.refit_messages else "")
        return (f"consider parameters (their uncertainty is in the standard errors): {given}; "
                f"d theta / d c from {self.n_refits} re-fits at +-1 sd started from "
                f"{self.started}{failed}, "
                f"{self.wall_time_s:.3g} s")

    def to_json_dict(self) -> dict[str, Any]:
        """Return the JSON form (names, values, sd, steps, sensitivity, both se)."""
        def listed(a: np.ndarray | None) -> Any:
            return None if a is None else np.where(np.isfinite(a), a, np.nan).tolist()

        return {"names": list(self.names), "values": listed(self.values),
                "sd": listed(self.sd), "steps": listed(self.steps),
                "sensitivity": listed(self.sensitivity),
                "stderr_share": listed(self.stderr_share),
                "stderr_without": listed(self.stderr_without),
                "n_refits": self.n_refits, "wall_time_s": self.wall_time_s,
                "refit_messages": list(self.refit_messages), "started": self.started,
                "one_sided": self.one_sided}


def check_consider(flight: Flight, owner: str) -> None:
    """Refuse a flight whose uncertain constant is replaced by a per-sample channel.

    Raises
    ------
    EstimatorError
        One line naming the constant and the channel.
    """
    for name in flight.airframe.mass_sd:
        channel = CONSTANT_CHANNELS[name]
        if channel in flight.channels:
            raise EstimatorError(
                f"{owner}: the airframe gives {MASS_SD_FIELDS[name]} but the flight has a "
                f"per-sample {channel!r} channel, which replaces {name} in the model: give "
                f"the sd of a constant {name} (drop the channel) or no sd")


#: The re-fits get this many times the method's ``max_iterations`` (where it has one): they
#: start from the airframe's prior as the fit did, a constant off by its sd away, and a
#: re-fit stopped by its iteration limit is no estimate to difference. Measured (the
#: rocket's Mach-table coast, studies/rocket_measure_mass_right.toml): re-fits at +-1 sd
#: of the mass often stopped at output-error's 50 iterations, and their estimates, used,
#: made Cl0's total se 16-31x its own.
REFIT_ITERATION_FACTOR = 4


def refit_holds(flight: Flight | Windows, result: EstimationResult) -> CoefficientSpec | None:
    """Return the holds and priors a re-fit of ``result`` is given (None: none).

    What the fit was given (``fit(holds=...)``), read back from ``result.held`` and
    ``result.priors`` (with tables: their points), less what the flight's airframe declares
    itself (:func:`aeroid.estimation.airframe_holds`: a re-fit's airframe declares it again,
    and the same table named twice would be refused).
    """
    recorded = holds_of(result)
    if recorded is None:
        return None
    own: Any = airframe_holds(flight.airframe)
    if getattr(flight.airframe, "tables", None) is not None and not own.empty:
        own = table_holds(own, fit_tables(flight))  # the same points the fit recorded
    held = {n: v for n, v in recorded.held.items() if own.held.get(n) != v}
    priors = {n: p for n, p in recorded.priors.items()
              if tuple(own.priors.get(n, ())) != tuple(p)}
    return CoefficientSpec(held=held, priors=priors) if held or priors else None


def _refit(estimator: Any, flight: Flight | Windows, theta: np.ndarray | None, name: str,
           step: float, seed: int, holds: CoefficientSpec | None = None) -> EstimationResult:
    """Re-fit with the constant ``name`` moved by ``step`` (in each window, from its own value),
    with the fit's ``holds`` (:func:`refit_holds`)."""
    if "max_iterations" in estimator.option_names():
        with contextlib.suppress(TypeError, ValueError):  # beyond the method's bound: as is
            estimator = dataclasses.replace(estimator, max_iterations=REFIT_ITERATION_FACTOR
                                            * int(estimator.max_iterations))
    exact = {sd: 0.0 for sd in MASS_SD_FIELDS.values()}
    prior = {} if theta is None else {"prior": tuple(float(v) for v in theta)}  # warm start

    def moved(part: Flight) -> Flight:
        changes = {name: getattr(part.airframe, name) + step, **prior}
        return dataclasses.replace(part, airframe=part.airframe.replace(**exact, **changes))

    if isinstance(flight, Windows):
        return estimator.fit(Windows(tuple(moved(f) for f in flight), flight.names), rng=seed,
                             holds=holds)
    return estimator.fit(moved(flight), rng=seed, holds=holds)


def consider_covariance(estimator: Any, flight: Flight | Windows, result: EstimationResult, *,
                        rng: np.random.Generator | int | None = None,
                        warm_start: bool | None = None) -> ConsiderCovariance:
    """Return the consider covariance of ``result`` for the flight airframe's uncertain constants.

    Parameters
    ----------
    estimator : Estimator
        The method that made ``result`` (its :meth:`fit` makes the re-fits).
    flight : Flight or Windows
        The flight fitted; ``flight.airframe.mass_sd`` names the constants (may be empty).
        Several windows: each window's constant is moved by the sd from its own value
        (their sd agree: :func:`aeroid.estimation._windows.check_windows`); ``values``
        are the first window's.
    result : EstimationResult
        The fit, with finite ``theta``.
    rng : Generator, int or None
        Source of the re-fits' common seed (both re-fits of a constant draw from it).
    warm_start : bool or None
        ``None`` (default): start the re-fits from the fit's estimate when the method
        offers it (``estimator.warm_started(result)``: output-error, every parameter it
        estimated, tables included), else from the airframe's prior as the fit did.
        ``True``: also for the other methods, by replacing the airframe's nine-coefficient
        prior with ``result.theta`` (a table fit refused: one line). ``False``: from the
        prior (module docstring).

    Raises
    ------
    EstimatorError
        When a re-fit gives a non-finite estimate (one line naming the constant and the
        re-fit's message). A re-fit that ends unsuccessful with a finite estimate (a
        verdict such as the fit check) is used and named in ``refit_messages``.
    """
    start = time.perf_counter()
    uncertain = flight.airframe.mass_sd
    theta = np.asarray(result.theta, dtype=float)
    seed = int(np.random.default_rng(rng).integers(2**63 - 1))
    names = tuple(uncertain)
    values = np.array([getattr(flight.airframe, n) for n in names])
    sd = np.array([uncertain[n] for n in names])
    steps = sd.copy()
    sensitivity = np.zeros((theta.size, len(names)))
    messages, one_sided = [], False
    refitter, prior, started = _refitter(estimator, flight, result, warm_start)
    holds = refit_holds(flight, result)  # held coefficients stay held
    for k, name in enumerate(names):
        ends, ok, said = [], [], []
        for sign in (1.0, -1.0):
            value = float(values[k] + sign * steps[k])
            fit = _refit(refitter, flight, prior, name, sign * steps[k], seed, holds)
            if not np.all(np.isfinite(fit.theta)):
                raise EstimatorError(f"{estimator.name}: the re-fit at {name} = {value:.6g} "
                                     f"for its sd failed: {fit.message}")
            ok.append(bool(fit.success))
            said.append(f"{name} = {value:.6g}: {fit.message}")
            ends.append(np.asarray(fit.theta, dtype=float))
        if ok[0] != ok[1]:  # one end unsuccessful: the other's one-sided difference
            good = 0 if ok[0] else 1
            sign = 1.0 if good == 0 else -1.0
            sensitivity[:, k] = (ends[good] - theta) / (sign * steps[k])
            one_sided = True
            messages.append(f"{said[1 - good]} (not used: the one-sided difference at "
                            f"{name} {'+' if good == 0 else '-'}1 sd instead)")
        else:
            sensitivity[:, k] = (ends[0] - ends[1]) / (2.0 * steps[k])
            messages.extend(m for m, good in zip(said, ok, strict=True) if not good)
    share = sensitivity @ np.diag(sd**2) @ sensitivity.T
    return ConsiderCovariance(
        names=names, values=values, sd=sd, steps=steps, sensitivity=sensitivity,
        covariance=share, stderr_without=result.stderr, covariance_without=result.covariance,
        n_refits=2 * len(names), wall_time_s=time.perf_counter() - start,
        refit_messages=tuple(messages), started=started, one_sided=one_sided)


def _refitter(estimator: Any, flight: Flight | Windows, result: EstimationResult,
              warm_start: bool | None) -> tuple[Any, np.ndarray | None, str]:
    """Return the re-fits' estimator, the prior to give them (None: the airframe's) and
    where they start (:func:`consider_covariance`'s ``warm_start``)."""
    if warm_start is False:
        return estimator, None, "the prior"
    maker = getattr(estimator, "warm_started", None)  # one flight's parameters: not windows
    warm = maker(result) if maker is not None and not isinstance(flight, Windows) else None
    if warm is not None:
        return warm, None, "the estimate"
    if warm_start is None:
        return estimator, None, "the prior"
    if getattr(flight.airframe, "tables", None) is not None:
        raise EstimatorError(f"{estimator.name}: warm_start=True replaces the airframe's "
                             "nine-coefficient prior by the estimate, and this fit has "
                             "[tables]: give warm_start=None or False")
    return estimator, np.asarray(result.theta, dtype=float), "the estimate"


def add_consider(estimator: Any, flight: Flight | Windows, result: EstimationResult, *,
                 rng: np.random.Generator | int | None = None) -> EstimationResult:
    """Return ``result`` with the airframe's uncertain constants in its standard errors.

    ``stderr`` and ``covariance`` become the totals (``cov + S diag(sd^2) S^T``); the
    method's own ones are kept in ``result.consider``. A method without a covariance
    keeps none and is told in a warning (the share alone is in ``result.consider``). A
    failed fit, or an airframe with every constant exact, is returned as it is; a failed
    re-fit is a warning and the standard errors stay the method's own.
    """
    if not flight.airframe.mass_sd or not result.success:
        return result
    try:
        consider = consider_covariance(estimator, flight, result, rng=rng)
    except EstimatorError as exc:
        return dataclasses.replace(result, warnings=(
            *result.warnings, f"{exc}; the standard errors leave the mass uncertainty out"))
    changes: dict[str, Any] = {"consider": consider}
    if result.covariance is not None:
        total = np.asarray(result.covariance, dtype=float) + consider.covariance
        stderr = np.sqrt(np.clip(np.diag(total), 0.0, None))
        if result.stderr is not None:  # none of its own (a held coefficient): none in total
            stderr = np.where(np.isnan(result.stderr), np.nan, stderr)
        changes.update(covariance=total, stderr=stderr)
    else:
        changes["warnings"] = (*result.warnings, (
            f"{estimator.name} gives no covariance: the mass uncertainty's share of the "
            "standard errors alone is in result.consider"))
    return dataclasses.replace(result, **changes)


def exact_mass_note(airframe: Any) -> str | None:
    """Return the one-line assumption for the mass constants given without sd (None: none).

    ``"mass taken as exact: 70 kg; Ix, Iy, Iz taken as exact: 0.18, 40, 40 kg m^2 (...)"``.
    """
    uncertain = airframe.mass_sd
    parts = []
    if "mass_kg" not in uncertain:
        parts.append(f"mass taken as exact: {airframe.mass_kg:.6g} kg")
    inertias = [n for n in ("ix_kgm2", "iy_kgm2", "iz_kgm2") if n not in uncertain]
    if inertias:
        parts.append(f"{', '.join(n[:2].capitalize() for n in inertias)} taken as exact: "
                     f"{', '.join(f'{getattr(airframe, n):.6g}' for n in inertias)} kg m^2")
    if not parts:
        return None
    return "; ".join(parts) + (" (an sd in the airframe, mass_sd_kg or I*_sd_kgm2, puts "
                               "its uncertainty in the standard errors)")
