"""Filter-error's test of what the user asserted: held coefficients and priors (issue 26).

In turbulence a wrong pitch-plane coefficient (Cma, Cza, Cmq) passes the fit check and the
gust verdict (:mod:`baselines._gust_verdict`): the gust states take the error up and the
innovations stay white. A hold, though, is a hypothesis the data can test: the filter-error
likelihood with the held coefficients free (a nested model, one more parameter per hold)
against the held fit, the likelihood-ratio test of Maine & Iliff (NASA RP-1168, ch. 8) and
Jategaonkar's model-structure tests (ch. 6): under the hold's truth

    LR = 2 (L_held - L_free) ~ chi-square(k),    k = the number of tested constraints,

``L`` the negative log-likelihood of the innovations (:func:`baselines._fem_fit.nll`,
plus the priors). A prior ``N(mu, s^2)`` is tested the same way with the prior removed
(locally ``LR = (theta_free - mu)^2 / (se^2 + s^2)``, one degree of freedom): a prior far
off the data's estimate is a conflict. The free fit starts at the held optimum (so ``LR
>= 0`` up to the optimizer's tolerance) and refits every free parameter, the gust
intensity included: a wrong Cma raises the fitted intensity, freeing it lowers it again.

A fit with ``p = chi2.sf(LR, k)`` below :data:`LR_ALPHA` is refused in one line naming the
constraints and the free fit's values. Not tested: the fin terms a passive fin holds at
zero (a physical fact: the record has no fin motion to test them on). When the free fit
fails or does not converge the test is not done, and a warning says so.

Measured (``benchmarks/bench_gust_verdict.py --seeds 40``, ``results/gust_verdict.md``;
the turbulence study's flights, Dryden sd 3 m/s in a 5 m/s steady wind): Cma and Cza held
at 0.7x or 1.3x refused 160/160 (LR 8.0-116), Cmq 9/80 (its se is 20 % of it there: 30 %
off is 1.5 se); holds at the truth refused by the test 1/120 (LR mean 0.93-1.19, chi-square
(1): 1). In still air right holds 0/30, wrong 60/60. In a steady wind without gusts right
Cma and Cza holds are refused 3/20 (LR 4.5-7.5): filter-error's own free Cma and Cza are
2.1-2.8 se off there (the steady wind decays in its gust model), so the likelihood is
right to prefer them; output-error with the wind estimated is the method on such flights.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.stats import chi2

from aeroid.estimation import FIN_TERMS
from aeroid.model import NAMES
from baselines import _fem_fit
from baselines._fem_setup import say

#: Significance of the likelihood-ratio test: a hold (or prior) at the truth is refused
#: with this probability if LR is chi-square distributed (Wilks). Measured false-alarm
#: rate: the module docstring's benchmark.
LR_ALPHA = 0.01
#: The source of holds that are physics, not assertions: not tested.
PHYSICAL_SOURCES = ("passive fin",)


@dataclass(frozen=True)
class HoldTest:
    """The likelihood-ratio test's outcome.

    Attributes
    ----------
    ok : bool
        False when the data refuse the constraints (``p < alpha``).
    message : str
        One line: what was refused (empty when ``ok``), or why the test was not done.
    figures : dict
        ``tested`` (names), ``kind`` (per name: ``hold`` or ``prior``), ``lr``,
        ``dof``, ``p_value``, ``alpha``, ``free_values`` and ``free_stderr`` (per name:
        the free fit's estimate and se), ``free_gust_sd_mps``, ``done``.
    """

    ok: bool
    message: str
    figures: dict = field(default_factory=dict)


def tested_constraints(holds: Any) -> dict[str, str]:
    """Name -> ``hold`` or ``prior``: the user's constraints the test frees (module
    docstring; the passive fin's holds left out), in :data:`aeroid.model.NAMES` order."""
    if holds is None:
        return {}
    sources = dict(getattr(holds, "sources", {}) or {})
    out = {}
    for name in NAMES:
        physical = name in FIN_TERMS and sources.get(name) in PHYSICAL_SOURCES
        if name in holds.held and not physical:
            out[name] = "hold"
        elif name in holds.priors:
            out[name] = "prior"
    return out


def freed_problem(problem: _fem_fit.Problem, p: np.ndarray, prior: np.ndarray,
                  names: tuple[str, ...]) -> tuple[_fem_fit.Problem, np.ndarray]:
    """The problem with ``names`` free and without their priors, and its start ``p``.

    ``p``: the held fit's scaled parameters; ``prior``: the airframe's coefficients (the
    freed coefficients' scale, as the estimator scales a free one).
    """
    index = [NAMES.index(n) for n in names]
    free = np.union1d(problem.free, index).astype(int)
    scale = np.where(prior[free] != 0.0, prior[free], 1.0)
    old = {int(j): i for i, j in enumerate(problem.free)}
    mean = np.zeros(free.size)
    info = np.zeros(free.size)
    start = np.empty(free.size)
    for i, j in enumerate(free):
        if j in old:
            k = old[int(j)]
            start[i] = p[k] * problem.scale[k] / scale[i]
            mean[i], info[i] = problem.prior_mean[k], problem.prior_info[k]
        else:
            start[i] = problem.theta_base[j] / scale[i]
        if NAMES[j] in names:
            info[i] = 0.0  # the tested prior removed
    freed = _fem_fit.Problem(problem.model, problem.zs, problem.x0, problem.P0x, problem.decay,
                             problem.theta_base, free, scale, problem.estimate_wind, mean,
                             info, problem.gust)
    return freed, np.concatenate([start, p[problem.free.size:]])


def likelihood_ratio(cost_held: float, cost_free: float, dof: int) -> tuple[float, float]:
    """``(LR, p)``: ``LR = 2 (cost_held - cost_free)`` (costs: negative log-likelihoods)
    and its chi-square(``dof``) upper tail (a negative LR, the optimizer's tolerance,
    counts as 0)."""
    lr = 2.0 * (cost_held - cost_free)
    return lr, float(chi2.sf(max(lr, 0.0), dof))


def hold_test(problem: _fem_fit.Problem, fit: _fem_fit.Fit, holds: Any, prior: np.ndarray,
              *, update_noise: bool, r_floor: np.ndarray, max_iterations: int, tol: float,
              who: str) -> HoldTest | None:
    """Test the user's holds and priors of a converged fit (module docstring); None when
    there are none to test."""
    kinds = tested_constraints(holds)
    if not kinds or not fit.converged:
        return None
    names = tuple(kinds)
    freed, p0 = freed_problem(problem, fit.p, prior, names)
    figures: dict[str, Any] = {"tested": list(names), "kind": kinds, "alpha": LR_ALPHA,
                               "dof": len(names), "done": False}
    what = ", ".join(f"{n} ({kinds[n]})" for n in names)
    try:
        free_fit = _fem_fit.fisher_scoring(freed, p0, fit.R, update_noise=update_noise,
                                           r_floor=r_floor, max_iterations=max_iterations,
                                           tol=tol)
    except FloatingPointError as exc:
        return HoldTest(True, f"{who}: the likelihood-ratio test of {what} was not done: the "
                        f"fit with them free failed ({exc})", figures)
    if not free_fit.converged:
        return HoldTest(True, f"{who}: the likelihood-ratio test of {what} was not done: the "
                        f"fit with them free did not converge ({free_fit.message})", figures)
    lr, p_value = likelihood_ratio(fit.cost, free_fit.cost, len(names))
    theta, _, sigma = freed.unpack(free_fit.p[None])
    index = [int(np.flatnonzero(freed.free == NAMES.index(n))[0]) for n in names]
    keep = np.arange(free_fit.p.size) != (freed.i_sigma if free_fit.at_bound else -1)
    with np.errstate(invalid="ignore", divide="ignore"):  # as the estimator: the intensity
        cov = np.linalg.pinv(free_fit.information[np.ix_(keep, keep)])  # at its bound left out
        se = np.sqrt(np.diag(cov))[index] * np.abs(freed.scale[index])
    values = {n: float(theta[0, NAMES.index(n)]) for n in names}
    figures.update({"lr": lr, "p_value": p_value, "done": True,
                    "free_values": values,
                    "free_stderr": dict(zip(names, se.tolist(), strict=True)),
                    "free_gust_sd_mps": float(sigma[0])})
    say(f"{who}: tested {what} by a likelihood ratio against a fit with them free: "
        f"{lr:.2f} against chi-square({len(names)}), p {p_value:.2g} (limit {LR_ALPHA:g})")
    if p_value >= LR_ALPHA:
        return HoldTest(True, "", figures)
    given = ", ".join(f"{n} {kinds[n]} {_given(holds, n, kinds[n])} vs free "
                      f"{values[n]:.4g} +- {s:.2g}" for n, s in zip(names, se, strict=True))
    p_text = f"{p_value:.1e}" if p_value > 0 else f"< {math.ulp(0.0):.0e}"
    return HoldTest(False, f"{who}: the data refuse the user's {what}: likelihood ratio "
                    f"{lr:.1f} against chi-square({len(names)}), p {p_text} (limit "
                    f"{LR_ALPHA:g}); {given}", figures)


def hold_test_from(problem: _fem_fit.Problem, p: np.ndarray, R: np.ndarray, holds: Any,
                   prior: np.ndarray, *, update_noise: bool, r_floor: np.ndarray,
                   max_iterations: int, tol: float, who: str) -> HoldTest | None:
    """:func:`hold_test` from a held point ``p`` that is not yet the held fit's optimum
    (the gust filters' estimate: :mod:`baselines._kalman_holds`).

    The held fit is first converged from ``p`` (Fisher scoring, as filter-error's), then
    tested as filter-error's own; None when nothing is to be tested. A held fit that
    fails or does not converge leaves the test not done, said in the message.
    """
    kinds = tested_constraints(holds)
    if not kinds:
        return None
    what = ", ".join(f"{n} ({kinds[n]})" for n in kinds)
    figures: dict[str, Any] = {"tested": list(kinds), "kind": kinds, "alpha": LR_ALPHA,
                               "dof": len(kinds), "done": False}
    try:
        fit = _fem_fit.fisher_scoring(problem, p, R, update_noise=update_noise,
                                      r_floor=r_floor, max_iterations=max_iterations, tol=tol)
    except FloatingPointError as exc:
        return HoldTest(True, f"{who}: the likelihood-ratio test of {what} was not done: the "
                        f"held fit failed ({exc})", figures)
    if not fit.converged:
        return HoldTest(True, f"{who}: the likelihood-ratio test of {what} was not done: the "
                        f"held fit did not converge ({fit.message})", figures)
    return hold_test(problem, fit, holds, prior, update_noise=update_noise, r_floor=r_floor,
                     max_iterations=max_iterations, tol=tol, who=who)


def _given(holds: Any, name: str, kind: str) -> str:
    if kind == "hold":
        return f"{holds.held[name]:.4g}"
    mean, sd = holds.priors[name]
    return f"{mean:.4g} +- {sd:.2g}"
