"""Output-error's starts, and a fit warm-started from a previous estimate (consider re-fits).

:func:`make_starts` builds the starts of :meth:`baselines.output_error.
OutputErrorEstimator.run`: the airframe's prior (or the PSO warm start's best point),
equation-error's estimate and the random draws (:mod:`baselines._oe_starts`).

:func:`warm_started` is output-error started from every parameter a previous fit
estimated, not only the nine coefficients: the tables' points, the initial state, the
IMU errors, the attitude offsets, the positions, the aiding terms (the field
``start_parameters``: that fit's ``info['parameters']``). It is what
:meth:`OutputErrorEstimator.warm_started` returns and what
:func:`aeroid.estimation.consider_covariance` re-fits with: a re-fit at the mass +-1 sd
then starts one sd's worth of change from its optimum instead of from the design tool's
``[prior]`` (from which a 3 % mass error is past the rocket coast's region of
convergence: ``studies/rocket_measure.md``). ``start_parameters`` is no option
(:data:`aeroid.estimation.NOT_AN_OPTION`: not in ``options()``, ``from_options`` or
``aeroid methods``): it is set by code, not chosen by a user, and its one start replaces
the fit's starts (the airframe's prior still scales the parameters, so its meaning is
unchanged).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from baselines._held import held_template
from baselines._oe_starts import Start, equation_error_start, warm_start_point
from baselines._restricted import restricted_fit


def make_starts(est: Any, prob: Any, flight: Any, first: np.ndarray, prior: np.ndarray,
                scale: np.ndarray, rng: np.random.Generator, names: tuple[str, ...] = (),
                holds: Any = None) -> tuple[list[Start], int]:
    """Return the fit's starts (scaled parameters) and the evaluations spent making them.

    ``first`` (n_p,) is the prior start in scaled parameters (the coefficients, or the
    tables' parameters, first: ``prior.size`` of them, named ``names``); it is modified
    in place by the PSO warm start as the fit's own code did. With the option
    ``staged_start`` the prior start is :func:`staged_start`'s.
    """
    n_c = prior.size
    warm = est.start_parameters
    if warm is not None:
        return [warm_start(prob, warm)], 0
    extra_evals = 0
    if est.pso_warm_start:
        theta_pso, extra_evals = warm_start_point(est, prob, flight, rng)
        first[:n_c] = theta_pso / scale[:n_c]
    starts = [Start("pso" if est.pso_warm_start else "prior", first)]
    if getattr(est, "staged_start", False):
        starts[0], evals = staged_start(est, prob, first, names, holds, starts[0].label)
        extra_evals += evals
    if est.equation_error_start:
        starts.append(equation_error_start(flight, first, scale, rng))
    for k in range(est.n_starts - 1):
        p = first.copy()
        p[:n_c] = prior * (1.0 + 0.2 * rng.standard_normal(n_c)) / scale[:n_c]
        starts.append(Start(f"random {k + 1}", p))
    return starts, extra_evals


def staged_start(est: Any, prob: Any, first: np.ndarray, names: tuple[str, ...],
                 holds: Any, label: str) -> tuple[Start, int]:
    """Return the start ``first`` with the axial force's coefficients fitted first.

    Stage one: Gauss-Newton over the ``Cx`` coefficients alone (a table's points too),
    every other parameter (coefficients, initial state, IMU errors, attitude offsets) held
    at ``first`` (held coefficients at their values); its end is the start of the full
    fit. A told mass a few % below the flown one is, for output-error, a Cx start further
    off by as much (F = m a: the fit's Cx is Cx m_told / m_flown), and from the design
    tool's prior the rocket coast's pitch plane then wanders into a poorer optimum
    (Cza -5.5, Czq -360, theta offset 10 prior sd) or past max_iterations. Measured on
    studies/rocket_measure.toml's runs 11 and 13 (flown 3.7 % heavier, Cx constant:
    ``benchmarks/rocket_mass_refit.py RUN --staged``): both converge in 18 iterations,
    run 13 at the cost of the cold fit told the flown mass, its Cx that one's x
    m_told / m_flown. Freeing the nuisance parameters in stage one as well did not
    (run 13: max_iterations, theta offset -9e-3 rad). A stage one that raises or ends
    non-finite leaves ``first`` as it is (said in the label).
    """
    keep = np.zeros(first.size, dtype=bool)
    keep[:len(names)] = [n == "Cx" or n.startswith("Cx@") for n in names]
    template = first
    if holds is not None and getattr(holds, "held", None):
        template = held_template(prob, first, holds)
        keep[holds.held_index] = False
    if not np.any(keep[:len(names)]):
        return Start(label, first), 0
    try:
        fit = restricted_fit(est, prob, keep, template)
    except FloatingPointError:
        return Start(f"{label} (stage one failed)", first), 0
    if not np.all(np.isfinite(fit.p[keep])):
        return Start(f"{label} (stage one failed)", first), fit.n_evaluations
    return Start(f"{label}, Cx first", fit.p), fit.n_evaluations


def warm_start(prob: Any, parameters: tuple[float, ...]) -> Start:
    """Return the start at a previous fit's physical parameters (``info['parameters']``).

    A vector of another length (the re-fit's problem has other parameters) is a failed
    start, said in its message.
    """
    model = prob.model
    scale = np.asarray(model.scale, dtype=float)
    phys = np.asarray(parameters, dtype=float)
    if phys.shape != scale.shape or not np.all(np.isfinite(phys)):
        return Start("estimate", None, f"the previous estimate has {phys.size} parameters, "
                                       f"this fit {scale.size}")
    return Start("estimate", (phys - getattr(model, "phys_offset", 0.0)) / scale)


def warm_started(est: Any, result: Any) -> Any:
    """Return ``est`` started from ``result``'s parameters (its ``info['parameters']``,
    the field ``start_parameters``, no option).

    ``None`` when the result keeps no finite parameters (a failed fit).
    """
    parameters = result.info.get("parameters")
    if parameters is None or not np.all(np.isfinite(parameters)):
        return None
    return dataclasses.replace(est, start_parameters=tuple(float(v) for v in parameters))
