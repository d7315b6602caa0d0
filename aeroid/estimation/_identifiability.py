"""Can the method's data determine each coefficient? Information and correlation checks.

From what a result carries: its ``covariance`` (inverse information) or, for methods
without one, ``info["information"]`` (the curvature of the method's objective in the
coefficients, any positive scale: EBM-PSO's quadratic form). Three findings:

- **no information**: a coefficient the objective does not depend on. From the
  information: its diagonal, scaled to the coefficient's size, is zero to rounding
  (:data:`ZERO_INFORMATION` of the largest: a regressor column that is zero); from a
  covariance: a variance that is not finite, or a standard error above
  :data:`NO_INFORMATION_SD` times the estimate. Its estimate is wherever the search
  stopped: never part of a success.
- **almost no information** (from a covariance only: an information matrix of unknown
  scale has no absolute yardstick): a standard error above the estimate itself
  (:data:`LITTLE_INFORMATION_SD`): the data do not fix even its sign (a warning).
- **confounded pairs**: two coefficients whose estimates correlate above
  :data:`CORRELATION_LIMIT` in magnitude: the data determine a combination of the two
  much better than either (a warning naming them).

Before the fit, from the record alone (:func:`record_findings`): coefficients whose
regressor the record does not excite, each named with its reason and the suggestion to
hold it or give it a prior. A fit that estimates such a coefficient freely anyway is not
a success (:func:`record_verdict`):

- **no fin motion** (the logged deflection's range below :data:`FIN_MOTION_RAD`): the
  fin terms Czd, Cmd multiply the deflection (regressor zero, or a constant confounded
  with any constant force);
- **no pitch or yaw rate** (the RMS of ``sqrt(q^2 + r^2)`` at most :data:`RATE_SNR`
  times their noise level, or below :data:`RATE_FLOOR_RADPS`): the damping terms Czq,
  Cmq multiply q and r;
- **a roll rate that never changes** (the spread of ``p / V`` along a cubic in time below
  :data:`ROLL_VARIATION` of its mean): the roll moment ``Cl0 + Clp p d / (2 V)`` then
  fixes only that combination, so Cl0 and Clp are named together.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from aeroid.estimation._signals import estimate_noise_sd

if TYPE_CHECKING:
    from aeroid.flights import Flight

#: Scaled information at most this fraction of the largest is zero: squares of rounding
#: (1e-16 relative) sum to 1e-32; real differences between coefficients stay far above
#: 1e-24 (EBM-PSO's quadratic form on the reference flight spans 1e-9 between Czq and
#: Cl0 on the noise-free log, where its noise weights are at their floors; measured).
ZERO_INFORMATION = 1e-24
#: A standard error above this many times the estimate: no information (a singular
#: information matrix inverted, or a prior variance the data never reduced).
NO_INFORMATION_SD = 1e6
#: A standard error above the estimate's own size: almost no information (a warning).
LITTLE_INFORMATION_SD = 1.0
#: Correlations above this magnitude are reported (issue 18). Cl0 and Clp correlate
#: 0.9999 in every fit of the reference flight (the roll rate stays near its steady
#: state, which fixes the ratio Cl0 / Clp), so those fits carry this warning.
CORRELATION_LIMIT = 0.98

#: A fin whose logged deflection spans less than this [rad] (0.06 deg, below one count of
#: a servo log) does not move: the reference flight's relay spans 0.28 rad, 279 times it.
FIN_MOTION_RAD = 1e-3
#: Pitch and yaw rates whose RMS is at most this many times their noise level are noise:
#: on the reference flight they are at least 20 (Gaussian tactical IMU) and 41 (paper
#: noise) times it over 50 seeds each (benchmarks/identifiability_false_alarms.py), so
#: the limit keeps a factor 6.6 from a normal flight.
RATE_SNR = 3.0
#: Below this RMS [rad/s] the pitch and yaw rates are zero whatever the noise estimate
#: says (a noise-free log of a pure roll).
RATE_FLOOR_RADPS = 1e-6
#: A roll regressor ``p / V`` whose cubic trend over the record spreads less than this
#: fraction of its mean does not separate Cl0 from Clp: the reference flight's spreads at
#: least 0.020 (noise-free, Gaussian) and 0.018 (paper noise, 50 seeds), 18 times it.
ROLL_VARIATION = 1e-3

Pairs = tuple[tuple[str, str, float], ...]


class RecordFinding(NamedTuple):
    """Coefficients the record cannot determine, and why (one phrase)."""

    names: tuple[str, ...]
    reason: str

    def text(self) -> str:
        """Return one line: the names, the reason, what to do."""
        verb = "is" if len(self.names) == 1 else "are"
        holds = " ".join(f"--hold {n}=VALUE" for n in self.names)
        return (f"{', '.join(self.names)} {verb} not identifiable from this record "
                f"({self.reason}): hold {'it' if len(self.names) == 1 else 'them'} "
                f"({holds}) or give a prior (--prior NAME=MEAN:SD)")


def record_findings(flight: Flight) -> tuple[RecordFinding, ...]:
    """Return the coefficients the record does not excite (module docstring), with why.

    From the logged deflection, the body rates and the velocities alone (no fit): the
    fin terms without fin motion, the damping terms without pitch or yaw rate, Cl0 and
    Clp when the roll rate never changes. A test whose channels the flight lacks is not
    made.
    """
    found = []
    if "delta" in flight.channels:
        span = float(np.ptp(flight["delta"]))
        if span < FIN_MOTION_RAD:
            found.append(RecordFinding(("Czd", "Cmd"), f"no fin motion: the deflection "
                                       f"spans {span:.2g} rad < {FIN_MOTION_RAD:g}"))
    have = set(flight.channels)
    if {"q", "r"} <= have:
        q, r = flight["q"], flight["r"]
        rms = float(np.sqrt(np.mean(q * q + r * r)))
        noise = estimate_noise_sd(np.column_stack([q, r]), floor_fraction=0.0)
        level = float(np.sqrt(np.sum(noise * noise)))
        if rms <= max(RATE_SNR * level, RATE_FLOOR_RADPS):
            found.append(RecordFinding(("Czq", "Cmq"), f"pitch and yaw rates near zero: RMS "
                                       f"{rms:.2g} rad/s, noise {level:.2g} rad/s"))
    if not {"p", "u", "v", "w"} <= have:
        return tuple(found)
    t = flight.t - np.mean(flight.t)
    speed = np.sqrt(flight["u"] ** 2 + flight["v"] ** 2 + flight["w"] ** 2)
    x = flight["p"] / np.where(speed > 0, speed, np.nan)
    if np.all(np.isfinite(x)) and x.size > 4:
        trend = np.polyval(np.polyfit(t, x, 3), t)
        mean = abs(float(np.mean(trend)))
        spread = float(np.std(trend)) / mean if mean > 0 else 0.0
        if spread < ROLL_VARIATION:
            found.append(RecordFinding(("Cl0", "Clp"), f"a roll rate that never changes: "
                                       f"p / V spreads {spread:.2g} of its mean < "
                                       f"{ROLL_VARIATION:g}, so only Cl0 + Clp p d / (2V) is "
                                       "determined"))
    return tuple(found)


def record_verdict(findings: Sequence[RecordFinding], held: Mapping[str, Any],
                   priors: Mapping[str, Any]) -> tuple[str | None, dict[str, str]]:
    """Return (failure message or None, name -> reason) of the findings a fit leaves free.

    A coefficient held or given a prior is determined by that; any other named by
    ``findings`` makes the fit no success for it.
    """
    left: dict[str, str] = {}
    for finding in findings:
        for name in finding.names:
            if name not in held and name not in priors:
                left[name] = finding.reason
    if not left:
        return None, {}
    reasons = dict.fromkeys(left.values())
    text = "; ".join(f"{', '.join(n for n in left if left[n] == why)}: {why}"
                     for why in reasons)
    return (f"not identifiable from this record, estimated anyway: {text}; hold them or "
            "give priors (--hold NAME=VALUE, --prior NAME=MEAN:SD)", left)


def _from_information(theta_scale: np.ndarray, information: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Return (no-information mask, correlation) from an information matrix."""
    info = np.asarray(information, dtype=float) * np.outer(theta_scale, theta_scale)
    diag = np.diag(info).copy()
    top = np.max(np.abs(diag)) if diag.size else 0.0
    keep = diag > ZERO_INFORMATION * top
    corr = np.full(info.shape, np.nan)
    if np.any(keep):
        d = np.sqrt(diag[keep])
        cov = np.linalg.pinv(info[np.ix_(keep, keep)] / np.outer(d, d))
        s = np.sqrt(np.abs(np.diag(cov)))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr[np.ix_(keep, keep)] = cov / np.outer(s, s)
    return ~keep, corr


def identifiability(names: Sequence[str], theta: np.ndarray, *,
                    covariance: np.ndarray | None = None,
                    information: np.ndarray | None = None,
                    ) -> tuple[tuple[str, ...], tuple[str, ...], Pairs]:
    """Return the coefficients without and with almost no information, and confounded pairs.

    Parameters
    ----------
    names : sequence of str, length k
    theta : ndarray, shape (k,)
    covariance, information : ndarray, shape (k, k)
        One of them (``covariance`` wins when both are given: it has a scale).

    Returns
    -------
    none : tuple of str
        Coefficients with no information.
    little : tuple of str
        Coefficients whose standard error exceeds the estimate (covariance only).
    pairs : tuple of (str, str, float)
        ``(a, b, correlation)`` with ``|correlation| > CORRELATION_LIMIT``.
    """
    theta = np.asarray(theta, dtype=float).reshape(-1)
    k = theta.size
    if len(names) != k:
        raise ValueError(f"identifiability: {len(names)} names for {k} coefficients")
    matrix = covariance if covariance is not None else information
    if matrix is None:
        return (), (), ()
    matrix = np.asarray(matrix, dtype=float)
    if matrix.shape != (k, k):
        raise ValueError(f"identifiability: a {matrix.shape} matrix for {k} coefficients")
    size = np.where(np.isfinite(theta) & (theta != 0.0), np.abs(theta), 1.0)
    little = np.zeros(k, dtype=bool)
    if covariance is not None:
        var = np.diag(matrix).copy()
        with np.errstate(invalid="ignore", divide="ignore"):
            relative = np.sqrt(np.abs(var)) / size
            s = np.sqrt(np.where(var > 0.0, var, np.nan))
            corr = matrix / np.outer(s, s)
        none = ~np.isfinite(var) | (relative > NO_INFORMATION_SD)
        little = ~none & (relative > LITTLE_INFORMATION_SD)
    else:
        bad = ~np.all(np.isfinite(matrix), axis=1)
        clean = np.where(np.isfinite(matrix), matrix, 0.0)
        none, corr = _from_information(size, clean)
        none |= bad
    pick = [names[j] for j in range(k)]
    pairs = tuple((names[i], names[j], float(corr[i, j]))
                  for i in range(k) for j in range(i + 1, k)
                  if not (none[i] or none[j]) and np.isfinite(corr[i, j])
                  and abs(corr[i, j]) > CORRELATION_LIMIT)
    return (tuple(n for n, z in zip(pick, none, strict=True) if z),
            tuple(n for n, z in zip(pick, little, strict=True) if z), pairs)


def identifiability_findings(names: Sequence[str], theta: np.ndarray,
                             covariance: np.ndarray | None, information: np.ndarray | None,
                             ) -> tuple[str | None, tuple[str, ...]]:
    """Return (failure message or None, warnings) of :func:`identifiability`."""
    none, little, pairs = identifiability(names, theta, covariance=covariance,
                                          information=information)
    failure = None
    if none:
        failure = (f"no information on {', '.join(none)} in this method's objective: the "
                   "data cannot determine it; the estimate is where the search stopped "
                   "(fix it, or use a method or flight that carries it)")
    warnings: tuple[str, ...] = ()
    if little:
        warnings += (f"almost no information on {', '.join(little)}: the standard error "
                     "exceeds the estimate (the data do not fix even its sign)",)
    if pairs:
        text = ", ".join(f"{a}-{b} ({r:+.5f})" for a, b, r in pairs)
        warnings += (f"nearly confounded (|correlation| > {CORRELATION_LIMIT:g}): {text}; "
                     "the data determine a combination of each pair better than either",)
    return failure, warnings


def nuisance_findings(names: Sequence[str], theta: np.ndarray, covariance: np.ndarray,
                      nuisance: Sequence[str]) -> tuple[str, ...]:
    """Return warnings on the ``nuisance`` parameters of a fit (e.g. sensor biases).

    :func:`identifiability` over all of a method's parameters (``names``, ``theta`` and
    their ``covariance``), keeping what involves a nuisance parameter: the pairs above
    :data:`CORRELATION_LIMIT` with one of them (which bias trades against which
    coefficient), and nuisance parameters without information. One line each, empty
    when there is nothing to say.
    """
    extra = set(nuisance)
    none, _, pairs = identifiability(names, theta, covariance=covariance)
    out: tuple[str, ...] = ()
    lost = [n for n in none if n in extra]
    if lost:
        out += (f"no information on {', '.join(lost)}: the data cannot determine it "
                "(its estimate is where the search stopped)",)
    mine = [(a, b, r) for a, b, r in pairs if a in extra or b in extra]
    if mine:
        text = ", ".join(f"{a}-{b} ({r:+.5f})" for a, b, r in mine)
        out += (f"nearly confounded (|correlation| > {CORRELATION_LIMIT:g}): {text}; the "
                "data determine a combination of each pair better than either",)
    return out


__all__ = ["CORRELATION_LIMIT", "FIN_MOTION_RAD", "LITTLE_INFORMATION_SD",
           "NO_INFORMATION_SD", "RATE_FLOOR_RADPS", "RATE_SNR", "ROLL_VARIATION",
           "ZERO_INFORMATION", "RecordFinding", "identifiability", "identifiability_findings",
           "nuisance_findings", "record_findings", "record_verdict"]
