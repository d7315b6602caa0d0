"""pyswarms' global-best PSO on the paper's EBM and EAM objectives (a library yardstick).

The objectives are aeroid's (:func:`aeroid.estimation.ebm_cost` on EBM step 1,
:class:`aeroid.estimation.OutputErrorCost` for EAM), with the same weighting, smoothing
and default budgets as the paper's estimators (450 particles, 200 iterations). The
search runs in the unit cube over :func:`aeroid.prior_bounds` (as aeroid's PSO does), so
one velocity clamp, the paper's ``V_max = 0.2`` of each range, fits every dimension.

Randomness, honestly: pyswarms draws from numpy's GLOBAL random state
(``np.random.uniform`` and friends) and offers no generator argument. To keep aeroid's
rule (same ``rng``, same result; no global state leaked to the caller), the initial swarm
is drawn from ``rng`` (its first particle is the prior), and the global state is seeded
from ``rng`` inside a context that saves it with ``np.random.get_state()`` and restores
it with ``np.random.set_state()`` afterwards, even on error. This is not thread-safe: two
threads running pyswarms at once share the global state (processes are fine).
pyswarms' progress bar is disabled (``verbose=False``), its logger silenced, and its
habit of reconfiguring the root logger with a ``./report.log`` file handler at every
optimizer construction is suppressed (:func:`_quiet_pyswarms`).
"""

from __future__ import annotations

import contextlib
import logging
import logging.config
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np

import aeroid
from aeroid import estimation
from aeroid.estimation import EstimationResult, Estimator
from aeroid.flights import Flight
from baselines import _held


@contextlib.contextmanager
def seeded_global_state(rng: np.random.Generator) -> Iterator[None]:
    """Seed numpy's global random state from ``rng``; restore the caller's state after."""
    saved = np.random.get_state()  # noqa: NPY002 - pyswarms draws from the global state
    np.random.seed(int(rng.integers(0, 2**32 - 1)))  # noqa: NPY002
    try:
        yield
    finally:
        np.random.set_state(saved)  # noqa: NPY002


@contextlib.contextmanager
def _quiet_pyswarms() -> Iterator[None]:
    """Keep pyswarms from reconfiguring logging and writing ``./report.log``.

    pyswarms' ``Reporter`` (created at import by ``pyswarms.backend`` and by every
    optimizer) calls ``logging.config.dictConfig`` with a root-logger stream handler and a
    file handler on ``./report.log``. Inside this context ``logging.config.dictConfig`` is
    a no-op (pyswarms is imported inside it too) and the ``pyswarms`` loggers are
    silenced; both are restored on exit. Not thread-safe (it patches a module attribute).
    """
    logger = logging.getLogger("pyswarms")
    level, propagate = logger.level, logger.propagate
    original = logging.config.dictConfig
    logging.config.dictConfig = lambda config: None
    logger.setLevel(logging.CRITICAL)
    logger.propagate = False
    try:
        yield
    finally:
        logging.config.dictConfig = original
        logger.setLevel(level)
        logger.propagate = propagate


@dataclass(frozen=True, kw_only=True)
class PyswarmsEstimator(Estimator):
    """pyswarms ``GlobalBestPSO`` on the EBM (default) or EAM objective.

    Attributes
    ----------
    objective : {"ebm", "eam"}
        EBM second-step cost (eq. 34) or EAM output-error cost (eq. 23).
    n_particles, n_iterations : int
        Budget (defaults 450 and 200, the paper's estimators' defaults).
    c1, c2 : float
        Cognitive and social coefficients (default 1.0 each, the paper's).
    w : float
        Inertia weight, constant (default 0.5, the mean of the paper's ``w ~ U[0, 1]``,
        which pyswarms cannot draw).
    weighting : {"noise", "relative"}
        Channel weighting of the objective (default "noise", as EBM-PSO/EAM-PSO).
    smoothing : {"both", "forces", "none"}
        EBM smoothing (default "both").
    v_max : float
        Velocity clamp as a fraction of each range (default 0.2, eq. 19).
    input : {"auto", "hold", "midpoint", "events", "law"}
        How the fin deflection between samples is modelled (EAM objective only):
        ``auto`` (default) is ``law`` when the flight's airframe has a ``[fin_law]``,
        else ``hold`` (:data:`aeroid.flights.INPUTS`).
    polish : bool
        Finish with a least-squares solve of the same objective from the swarm's best
        point, within the box (default False; :func:`aeroid.estimation.polish`): exact
        bounded least squares for EBM, trust-region least squares for EAM.
    polish_initial_rates : bool
        EAM objective with ``polish`` only: also fit the initial body rates p, q, r
        (default True, as EAM-PSO).

    Notes
    -----
    ``history`` (axis "iteration") holds pyswarms' best cost per iteration and the best
    position after the run only at the last step (pyswarms keeps no position history
    of the global best; ``theta`` rows before the last repeat the final best). With
    ``polish`` the history stays the swarm's and ``info["polish"]`` holds the swarm's and
    the polished cost.
    """

    name: ClassVar[str] = "pyswarms"
    supports_holds: ClassVar[bool] = True  # the free coefficients only: baselines._held
    description: ClassVar[str] = "pyswarms global-best PSO on the EBM or EAM objective"

    objective: Literal["ebm", "eam"] = "ebm"
    n_particles: int = 450
    n_iterations: int = 200
    c1: float = 1.0
    c2: float = 1.0
    w: float = 0.5
    weighting: Literal["noise", "relative"] = "noise"
    smoothing: Literal["both", "forces", "none"] = "both"
    v_max: float = 0.2
    input: Literal["auto", "hold", "midpoint", "events", "law"] = "auto"
    polish: bool = False
    polish_initial_rates: bool = True

    def __post_init__(self) -> None:
        if self.objective not in ("ebm", "eam"):
            raise ValueError(f"objective must be 'ebm' or 'eam', got {self.objective!r}")
        if not (2 <= self.n_particles <= estimation.MAX_PARTICLES
                and 1 <= self.n_iterations <= estimation.MAX_ITERATIONS):
            raise ValueError(f"n_particles must be in 2..{estimation.MAX_PARTICLES} and "
                             f"n_iterations in 1..{estimation.MAX_ITERATIONS}")
        if not self.v_max > 0:
            raise ValueError(f"v_max must be > 0, got {self.v_max}")

    def deflection_input(self) -> str | None:
        """The ``input`` option with the EAM objective (the EBM one integrates nothing)."""
        return self.input if self.objective == "eam" else None

    def cost_function(self, flight: Flight):
        """Return the objective ``theta (P, N_COEFFICIENTS) -> (P,)``."""
        if self.objective == "ebm":
            rec = estimation.reconstruct(flight)
            return estimation.ebm_cost(flight, rec, weighting=self.weighting,
                                       smoothing=self.smoothing)
        return estimation.OutputErrorCost(flight, weighting=self.weighting, input=self.input)

    def fit_entries(self, flight: Flight, cost, theta: np.ndarray,
                    state0: np.ndarray | None = None) -> dict:
        """Residuals of the objective's model at ``theta`` for the fit check (EAM: simulated
        from ``state0``, default the cost's)."""
        if self.objective == "eam":
            predicted = cost.predict(theta, state0)[0]
            return {"fit_residuals": {name: cost.measured[:, j] - predicted[:, j]
                                      for j, name in enumerate(estimation.EAM_OUTPUTS)}}
        rec = estimation.reconstruct(flight)
        X, y = estimation.ebm_regression(flight, rec, smoothing=self.smoothing)
        return estimation.regression_fit(rec, X, y, theta, estimation.EBM_ROWS)

    def run(self, flight: Flight, rng: np.random.Generator, holds: Any = None
            ) -> EstimationResult:
        """Run the swarm (initial swarm from ``rng``, pyswarms' draws seeded from it;
        ``holds``: the free coefficients only, priors' penalty added: ``free_cost``)."""
        cost = self.cost_function(flight)
        bounds = aeroid.prior_bounds(flight.airframe)
        free, search, expand = _held.swarm_problem(self, cost, holds, flight.n_samples)
        bounds_all, bounds = bounds, bounds[free]
        low, span = bounds[:, 0], bounds[:, 1] - bounds[:, 0]
        count = {"n": 0}

        def fun(u: np.ndarray) -> np.ndarray:
            count["n"] += len(u)
            values = np.asarray(search(low + u * span), dtype=float)
            return np.where(np.isfinite(values), values, np.inf)

        init = rng.random((self.n_particles, len(bounds)))
        init[0] = np.clip((flight.airframe.prior_vector()[free] - low) / span, 0.0, 1.0)
        options = {"c1": self.c1, "c2": self.c2, "w": self.w}
        with seeded_global_state(rng), _quiet_pyswarms():
            from pyswarms.single import GlobalBestPSO

            optimizer = GlobalBestPSO(
                n_particles=self.n_particles, dimensions=len(bounds), options=options,
                bounds=(np.zeros(len(bounds)), np.ones(len(bounds))),
                velocity_clamp=(-self.v_max, self.v_max),
                init_pos=init)
            best_cost, best_u = optimizer.optimize(fun, iters=self.n_iterations,
                                                   verbose=False)
        theta = expand(low + np.asarray(best_u) * span)
        hist_cost = np.asarray(optimizer.cost_history, dtype=float)
        history = {"axis": "iteration", "step": np.arange(1, len(hist_cost) + 1),
                   "theta": np.tile(theta, (len(hist_cost), 1)), "cost": hist_cost}
        info = {"objective": self.objective, "bounds": bounds_all}
        message, warnings, state0 = f"{self.n_iterations} iterations", (), None
        if self.polish and np.isfinite(best_cost):
            polished = estimation.polish(cost, bounds_all, theta,
                                         initial_rates=self.polish_initial_rates)
            theta, best_cost, state0 = polished.theta, polished.cost, polished.state0
            count["n"] += polished.n_evaluations
            message += f"; polished: {polished.message}"
            info["polish"] = estimation.polish_info(polished)
            if not polished.converged:
                warnings = (f"polish did not converge ({polished.message}): the answer may "
                            "not be the optimum of the objective",)
        info.update(self.fit_entries(flight, cost, theta, state0))
        return EstimationResult(
            estimator=self.name, theta=theta, cost=float(best_cost),
            success=bool(np.isfinite(best_cost)),
            warnings=estimation.box_edge_warnings(theta[free], bounds,
                                                  [aeroid.NAMES[j] for j in free]) + warnings,
            message=message, n_evaluations=count["n"],
            n_iterations=self.n_iterations, history=history,
            info=info)
