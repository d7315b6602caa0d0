"""Output-error maximum-likelihood baseline (Klein & Morelli's output-error method, CasADi).

Model: the airframe equations (eqs. 2-10) integrated with RK4 from the initial state,
``delta`` held over each sample interval; outputs the six accelerations of eq. 28 at the
estimator's sensor positions and ``p, q, r`` (:mod:`aeroid.model`, the same
equations as :mod:`aeroid.model`). The whole record is one CasADi graph: the RK4 step
is a CasADi Function, ``mapaccum`` runs it over the record with ``delta`` as an input
sequence, and the output Jacobian with respect to the parameters comes from CasADi's
algorithmic differentiation (forward sensitivities carried through the record). Built
graphs are cached per (constants, dt, substeps, n_samples, parameter set) and, by
default, the per-step functions are compiled to C (see ``compile_model``).

Estimation (Klein & Morelli, ch. 6): measurement noise Gaussian, white, with unknown
diagonal covariance ``R``; Gauss-Newton on the weighted least-squares cost
``1/2 sum_k e_k^T R^-1 e_k`` with Levenberg damping (the damping grows tenfold on a
rejected step), parameters scaled to order one (``theta / prior``); after every accepted
step ``R`` is re-estimated from the residuals, ``R_jj = mean_k e_kj^2`` (the relaxation
technique), until the Gauss-Newton step is below ``tol`` standard deviations and ``R``
has settled. The Cramér-Rao covariance is ``(sum_k J_k^T R^-1 J_k)^-1`` (Fisher
information) at the optimum; on a reference flight with the true sensor positions its
standard deviations are within 10 % of the independent prototype's
(reference/README.md), except Cx (0.012 % against 0.02 %), and over 50
Gaussian-noise flights the 95 % intervals covered the truth in 96 % of coefficient-runs
(tests/statistical/test_coverage.py).
"""

from __future__ import annotations

import functools
import hashlib
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import casadi as ca
import numpy as np

import aeroid
from aeroid.estimation._interface import EstimationResult, Estimator
from aeroid.flights._flight import Flight
from aeroid.model import _symbolic as _model
from aeroid.model._dynamics import Constants
from baselines import _common

#: Initial-state components that can be estimated: the rates p, q, r
#: (``estimate_initial_state``) and the velocities u, v, w (``estimate_initial_velocity``).
#: The attitude (phi, theta) enters only through gravity and psi not at all, so they are
#: taken from the first measured sample.
X0_RATES = (3, 4, 5)
X0_VELOCITIES = (0, 1, 2)
X0_NAMES = ("u0", "v0", "w0", "p0", "q0", "r0")
#: Floor of each R_jj as a fraction of the channel's mean square: keeps the weights
#: finite on noise-free data, far below any real noise level.
R_FLOOR_REL = 1e-24
#: Largest scaled parameter step per iteration (a trust region in units of the prior
#: values; inf = none: a cap of 0.5 or 2 made fits from a 20 % wrong prior creep).
MAX_STEP = math.inf
#: A trial step is accepted when it does not raise the cost by more than this fraction
#: (rounding: at a noise-free optimum the cost is flat to the last digits).
COST_RTOL = 1e-12
#: A step below this (in units of the prior values) with R settled also ends the fit.
STALL_STEP = 1e-8
#: R has settled when no R_jj changed by more than this fraction at the last update.
R_SETTLED_RTOL = 1e-3
#: Largest Levenberg damping tried before an iteration is declared stuck.
MAX_DAMPING = 1e8


@functools.lru_cache(maxsize=16)
def output_functions(const: Constants, dt: float, substeps: int, n_samples: int,
                     x0_free: tuple[int, ...], rx_free: tuple[int, ...] = (),
                     compiled: bool = False
                     ) -> tuple[ca.Function, ca.Function, bool]:
    """Return the CasADi output model of a record and its parameter Jacobian.

    Parameters ``p`` (order one): ``theta = p[:9] * scale[:9]``; the next
    ``len(x0_free)`` are offsets of those state components (indices into the state,
    increasing) from the first measured sample (``x0 = x0_meas + p * scale``); the last
    ``len(rx_free)`` are offsets of the x positions of those triads (0: triad 1, 1:
    triad 2).

    The Jacobian is propagated with the record (forward sensitivities): the RK4 step
    ``x_{k+1} = F(x_k, theta)`` is differentiated by CasADi AD in the directions
    ``S_k = dx_k/dp`` (``jtimes``), ``S_{k+1} = dF/dx S_k + dF/dtheta dtheta/dp``, and
    ``mapaccum`` carries ``(x, S)`` over the record; the outputs' Jacobian is
    ``dh/dx S_k + dh/dtheta dtheta/dp + dh/dpos dpos/dp``. This is exact (the chain rule
    through the discrete RK4 map) and several times faster than differentiating the
    ``mapaccum`` graph as a whole.

    Returns
    -------
    simulate : Function ``(p, scale, x0_meas (9), delta (1, n), pos (6)) -> Y (n, 9)``
    jacobian : Function ``(same) -> (Y (n, 9), dY (9, n n_p))``
        Columns ``k n_p .. (k + 1) n_p`` of ``dY`` are ``dy_k / dp``.
    is_compiled : bool
        With ``compiled``, the per-step SX functions are compiled to C
        (:func:`aeroid.model.compile_functions`); False when that failed.
    """
    n_x0 = len(x0_free)
    n_rx = len(rx_free)
    n_p = 9 + n_x0 + n_rx
    # one step with sensitivities (SX)
    x = ca.SX.sym("x", 9)
    sens = ca.SX.sym("S", 9, n_p)
    p9 = ca.SX.sym("p9", 9)
    scale9 = ca.SX.sym("scale9", 9)
    d = ca.SX.sym("delta")
    theta = p9 * scale9
    dtheta = ca.horzcat(ca.SX.eye(9), ca.SX.zeros(9, n_p - 9))  # d p9 / d p
    x_next = _model.rk4_step(x, d, theta, const, dt, substeps)
    s_next = ca.jtimes(x_next, ca.vertcat(x, p9), ca.vertcat(sens, dtheta))
    # symbol names unique per configuration: several compiled libraries may be loaded in
    # one process
    tag = (f"p{n_p}x{''.join(map(str, x0_free)) or 'n'}r{''.join(map(str, rx_free)) or 'n'}"
           f"s{substeps}h"
           f"{hashlib.sha256(repr((tuple(const), dt, n_samples)).encode()).hexdigest()[:8]}")
    step = ca.Function(f"step_sens_{tag}", [x, sens, p9, scale9, d], [x_next, s_next])
    # outputs with sensitivities (SX)
    prx = ca.SX.sym("prx", 2)  # x-position offsets of triads 1 and 2 (scaled)
    scale_rx = ca.SX.sym("scale_rx", 2)
    pos0 = ca.SX.sym("pos", 6)
    pos = pos0 + ca.vertcat(prx[0] * scale_rx[0], 0, 0, prx[1] * scale_rx[1], 0, 0)
    y = _model.measurement(x, d, theta, pos, const)
    drx = ca.SX.zeros(2, n_p)
    for j, triad in enumerate(rx_free):
        drx[triad, 9 + n_x0 + j] = 1.0
    dy = ca.jtimes(y, ca.vertcat(x, p9, prx), ca.vertcat(sens, dtheta, drx))
    out = ca.Function(f"out_sens_{tag}", [x, sens, p9, scale9, d, pos0, prx, scale_rx], [y, dy])
    out_plain = ca.Function(f"out_{tag}", [x, p9, scale9, d, pos0, prx, scale_rx], [y])
    step_plain = ca.Function(f"step_{tag}", [x, p9, scale9, d], [x_next])
    is_compiled = False
    if compiled:
        built = _model.compile_functions([step, out, step_plain, out_plain],
                                         f"aeroid_oe_{tag}")
        if built is not None:
            step, out, step_plain, out_plain = built
            is_compiled = True

    # the record (MX graph of mapped SX functions)
    p = ca.MX.sym("p", n_p)
    scale = ca.MX.sym("scale", n_p)
    x0_meas = ca.MX.sym("x0_meas", 9)
    delta = ca.MX.sym("delta", 1, n_samples)
    pos_given = ca.MX.sym("pos", 6)
    pm, sm = p[:9], scale[:9]
    prx_parts, srx_parts = [ca.MX(0.0), ca.MX(0.0)], [ca.MX(0.0), ca.MX(0.0)]
    for j, triad in enumerate(rx_free):
        prx_parts[triad] = p[9 + n_x0 + j]
        srx_parts[triad] = scale[9 + n_x0 + j]
    prx_m, srx_m = ca.vertcat(*prx_parts), ca.vertcat(*srx_parts)
    x0 = x0_meas
    s0 = ca.MX.zeros(9, n_p)
    if n_x0:
        select = np.zeros((9, n_x0))
        select[list(x0_free), np.arange(n_x0)] = 1.0  # state component <- parameter
        offsets = p[9:9 + n_x0] * scale[9:9 + n_x0]
        x0 = x0_meas + ca.mtimes(ca.DM(select), offsets)
        s0 = ca.horzcat(ca.MX.zeros(9, 9),
                        ca.mtimes(ca.DM(select), ca.diag(scale[9:9 + n_x0])),
                        ca.MX.zeros(9, n_p - 9 - n_x0))
    m = n_samples - 1

    def rep(v, k):
        return ca.repmat(v, 1, k)

    xs = step_plain.mapaccum("record", m)(x0, rep(pm, m), rep(sm, m), delta[:, :m])
    states = ca.horzcat(x0, xs)
    Y = out_plain.map(n_samples)(states, rep(pm, n_samples), rep(sm, n_samples), delta,
                                 rep(pos_given, n_samples), rep(prx_m, n_samples),
                                 rep(srx_m, n_samples))
    inputs = [p, scale, x0_meas, delta, pos_given]
    simulate = ca.Function("oe_simulate", inputs, [ca.densify(Y.T)])
    xs, ss = step.mapaccum("record_sens", m, 2)(x0, s0, rep(pm, m), rep(sm, m), delta[:, :m])
    states = ca.horzcat(x0, xs)
    sens_all = ca.horzcat(s0, ss)  # 9 x (n_samples n_p), block k = S_k
    Y, dY = out.map(n_samples)(states, sens_all, rep(pm, n_samples), rep(sm, n_samples),
                               delta, rep(pos_given, n_samples), rep(prx_m, n_samples),
                               rep(srx_m, n_samples))
    # dY: 9 x (n_samples n_p), block k = dy_k/dp -> rows j * n + k of the Jacobian
    jacobian = ca.Function("oe_jacobian", inputs, [ca.densify(Y.T), ca.densify(dY)])
    return simulate, jacobian, is_compiled


class _Buffered:
    """Evaluate a CasADi function on numpy buffers bound once (``Function.buffer``).

    Converting CasADi's DM outputs to numpy cost as much as the evaluation itself
    (measured: 40 % of a fit); here inputs and outputs are numpy arrays shared with
    CasADi, read and written in place. Every output must be dense.
    """

    def __init__(self, fun: ca.Function, inputs: Sequence[np.ndarray]) -> None:
        self.fun = fun
        self.inputs = [np.ascontiguousarray(np.asarray(a, dtype=float).T.ravel())
                       for a in inputs]  # column-major nonzeros
        self.outputs = [np.empty(fun.nnz_out(i)) for i in range(fun.n_out())]
        for i in range(fun.n_out()):
            if fun.nnz_out(i) != fun.numel_out(i):
                raise ValueError(f"{fun.name()}: output {i} is not dense")
        self.buffer, self.evaluate = fun.buffer()
        for i, a in enumerate(self.inputs):
            self.buffer.set_arg(i, memoryview(a))
        for i, r in enumerate(self.outputs):
            self.buffer.set_res(i, memoryview(r))

    def __call__(self, p: np.ndarray) -> list[np.ndarray]:
        """Evaluate with input 0 set to ``p``; returns the output buffers (reused)."""
        self.inputs[0][:] = p
        self.evaluate()
        if self.buffer.ret() != 0:
            raise RuntimeError(f"{self.fun.name()}: evaluation failed")
        return self.outputs


@dataclass(frozen=True)
class _Problem:
    """A flight turned into arrays for the Gauss-Newton loop."""

    z: np.ndarray          # (n, 9) measurements
    scale: np.ndarray      # (n_p,)
    x0_meas: np.ndarray    # (9,)
    delta: np.ndarray      # (1, n)
    pos: np.ndarray        # (6,)
    simulate: _Buffered
    jacobian: _Buffered
    r_floor: np.ndarray    # (9,)
    compiled: bool         # the per-step functions run as compiled C

    def residuals(self, p: np.ndarray) -> np.ndarray:
        """Return ``z - y(p)``, shape (n, 9)."""
        (y,) = self.simulate(p)
        n = self.z.shape[0]
        return self.z - y.reshape(9, n).T

    def residuals_jacobian(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return ``z - y(p)`` (n, 9) and ``dy/dp`` (9, n, n_p)."""
        y, dy = self.jacobian(p)
        n = self.z.shape[0]
        # dY (9, n n_p) column-major: entry (j, k n_p + i) at (k n_p + i) 9 + j
        J = dy.reshape(n, -1, 9).transpose(2, 0, 1).copy()
        return self.z - y.reshape(9, n).T, J

    def noise(self, e: np.ndarray) -> np.ndarray:
        """Return the ML estimate of diag(R), shape (9,), from residuals (floored)."""
        return np.maximum(np.mean(e * e, axis=0), self.r_floor)


def _cost(e: np.ndarray, r_diag: np.ndarray) -> float:
    value = 0.5 * float(np.sum(e * e / r_diag))
    return value if math.isfinite(value) else math.inf


def _nll(e: np.ndarray, r_diag: np.ndarray) -> float:
    """Negative log-likelihood without constants: ``n/2 sum log R_jj + cost``."""
    return _cost(e, r_diag) + 0.5 * e.shape[0] * float(np.sum(np.log(r_diag)))


def _fisher(J: np.ndarray, e: np.ndarray, r_diag: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the Fisher information ``sum J^T R^-1 J`` and gradient ``sum J^T R^-1 e``."""
    w = 1.0 / np.sqrt(r_diag)
    Jw = (J * w[:, None, None]).reshape(-1, J.shape[-1])
    ew = (e * w[None, :]).T.reshape(-1)
    return Jw.T @ Jw, Jw.T @ ew


@dataclass(frozen=True)
class _Fit:
    p: np.ndarray
    e: np.ndarray
    J: np.ndarray
    r_diag: np.ndarray
    nll: float
    history_p: list
    history_cost: list
    n_iterations: int
    n_evaluations: int
    converged: bool
    message: str


@dataclass(frozen=True, kw_only=True)
class OutputErrorEstimator(Estimator):
    """Output-error maximum likelihood (Gauss-Newton, CasADi AD, Cramér-Rao bounds).

    Starts from the airframe's prior coefficients and the first measured sample.

    Attributes
    ----------
    estimate_initial_state : bool
        Also estimate the body rates ``p, q, r`` at the first sample (default True: the
        measured rates carry the sensor noise; a wrong initial roll rate puts the whole
        predicted record out of phase).
    estimate_initial_velocity : bool
        Also estimate ``u, v, w`` at the first sample (default False: the flight's
        velocity channels are used as measured, clean in the paper's noise model).
        Decision: off by default because every force and moment scales with ``V^2``, so
        a free initial speed trades against all nine coefficients at once; on the
        reference flight it inflated the Cramér-Rao sd of Cx, Cza, Cma, Cmd from ~0.1 %
        to ~1.6 % (measured). The attitude is always taken as measured.
    estimate_rx1, estimate_rx2 : bool
        Also estimate the x position of triad 1 / triad 2 (default False); reported in
        ``info['rx1_m']`` / ``info['rx2_m']``. One position is identifiable when the
        other is right (tested on noise-free data). Finding: the paper's 10 % error on
        the given positions biases Cza and Czd (mean |error| over 10 paper-noise
        flights: Cza 2.6 %, Czd 15 % with the given positions; 0.14 %, 0.25 % with the
        true ones), and because both x positions are perturbed, estimating rx1 alone
        barely helps (2.3 %, 13 %) and estimating both does not either (Czd 16 %): at
        each relay step both triads see ``dAz_i = (Czd Q S / m - Cmd Q S D rx_i / Iy)
        d_delta``, two equations for Czd, rx1 and rx2 (measured; pitch rate pins Cmd).
    substeps : int
        RK4 steps per sample interval (default 2: the outputs then match the 0.25 ms
        truth integration of the reference flight to ~1e-6 relative and a noise-free fit
        recovers the coefficients to ~5e-6; with 1 substep, ~1e-5 and 1.2e-4 (Clp) at
        half the cost per iteration, measured).
    max_iterations : int
        Gauss-Newton iterations per start (default 50).
    tol : float
        Convergence: the largest parameter step, in Cramér-Rao standard deviations of
        the current iterate, is below ``tol`` (default 1e-3) and R has settled.
    n_starts : int
        Starts: the prior, then ``n_starts - 1`` draws ``prior * (1 + 0.2 N(0, 1))``
        from ``rng`` (default 1); the start with the lowest likelihood cost wins.
    pso_warm_start : bool
        Replace the prior start by the best point of a short run of
        :func:`aeroid.estimation.minimize` on the concentrated likelihood
        ``sum_j log mean_k e_kj^2`` within :func:`aeroid.prior_bounds` (default False).
    pso_particles, pso_iterations : int
        Budget of that warm start (defaults 30 and 40).
    compile_model : bool
        Compile the per-step model and sensitivity functions to C with the system
        compiler (default True; CasADi code generation, the library cached on disk in
        ``~/.cache/aeroid/casadi`` or ``$AEROID_CASADI_CACHE``; the first fit of a new
        parameter set compiles for ~3-5 s, then a Jacobian costs ~4x less). Without a
        working compiler it falls back to CasADi's virtual machine (same numbers);
        ``info['compiled']`` says which ran.

    Notes
    -----
    ``cost`` is the negative log-likelihood without constants,
    ``n/2 sum_j log R_jj + 1/2 sum_k e_k^T R^-1 e_k``. ``info`` holds ``R`` (9,),
    ``fisher`` (n_p, n_p), ``parameter_names``, ``parameters`` and ``parameter_stderr``
    (initial-state offsets and rx1 included), ``iterations``. Per-sample mass and
    thrust channels are not used: the airframe's constants are.
    """

    name: ClassVar[str] = "output-error"
    description: ClassVar[str] = (
        "output-error maximum likelihood: Gauss-Newton with CasADi AD, Cramer-Rao bounds")

    estimate_initial_state: bool = True
    estimate_initial_velocity: bool = False
    estimate_rx1: bool = False
    estimate_rx2: bool = False
    substeps: int = 2
    max_iterations: int = 50
    tol: float = 1e-3
    n_starts: int = 1
    pso_warm_start: bool = False
    pso_particles: int = 30
    pso_iterations: int = 40
    compile_model: bool = True

    def __post_init__(self) -> None:
        for name in ("substeps", "max_iterations", "n_starts", "pso_particles"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.pso_iterations < 0:
            raise ValueError(f"pso_iterations must be >= 0, got {self.pso_iterations}")
        if not self.tol > 0:
            raise ValueError(f"tol must be > 0, got {self.tol}")

    # ----------------------------------------------------------------------------------
    def parameter_names(self) -> tuple[str, ...]:
        """Names of the estimated parameters, in the order of ``info['parameters']``."""
        names = list(aeroid.NAMES) + [X0_NAMES[i] for i in self.x0_free()]
        return tuple(names + [f"rx{t + 1}" for t in self.rx_free()])

    def rx_free(self) -> tuple[int, ...]:
        """Triads (0, 1) whose x position is estimated."""
        return tuple(t for t, on in enumerate((self.estimate_rx1, self.estimate_rx2)) if on)

    def x0_free(self) -> tuple[int, ...]:
        """State indices of the estimated initial-state components."""
        free = (X0_VELOCITIES if self.estimate_initial_velocity else ()) + (
            X0_RATES if self.estimate_initial_state else ())
        return tuple(sorted(free))

    def problem(self, flight: Flight) -> _Problem:
        """Return the flight's arrays and cached CasADi functions."""
        const = aeroid.constants(flight.airframe)
        n = flight.n_samples
        simulate, jacobian, is_compiled = output_functions(
            const, flight.dt, self.substeps, n, self.x0_free(), self.rx_free(),
            self.compile_model)
        prior = flight.airframe.prior_vector()
        pos = flight.airframe.accel_positions.ravel()
        scale = [np.where(prior != 0.0, prior, 1.0)]
        scale.append(np.ones(len(self.x0_free())))
        scale.append([max(abs(pos[3 * t]), 0.1) for t in self.rx_free()])
        z = _common.measurements(flight)
        r_floor = R_FLOOR_REL * np.mean(z * z, axis=0) + 1e-300
        x0 = flight.states()[0]
        x0[3:6] = _common.smoothed_start(z[:, 6:9])
        scale = np.concatenate(scale)
        delta = flight["delta"][None, :]
        inputs = [np.zeros(scale.size), scale, x0, delta, pos]
        return _Problem(z=z, scale=scale, x0_meas=x0, delta=delta, pos=pos,
                        simulate=_Buffered(simulate, inputs),
                        jacobian=_Buffered(jacobian, inputs), r_floor=r_floor,
                        compiled=is_compiled)

    def gauss_newton(self, prob: _Problem, p0: np.ndarray) -> _Fit:
        """Run damped Gauss-Newton with the R relaxation from scaled parameters ``p0``.

        Each iteration: the Fisher information ``M`` and gradient ``g`` at the current
        point with the current ``R``; if the undamped Gauss-Newton step ``M^-1 g`` is
        below ``tol`` Cramér-Rao standard deviations in every parameter, ``R`` is
        re-estimated and the fit has converged once ``R`` has settled (relative change
        below :data:`R_SETTLED_RTOL`); otherwise a Levenberg-damped step that lowers the
        cost (damping x10 per rejected trial, /10 after a success) is taken and ``R`` is
        re-estimated from the new residuals (relaxation at every step: holding ``R``
        until Gauss-Newton converged, Klein & Morelli's textbook variant, took 2-3x more
        iterations on the reference flight).
        """
        p = np.array(p0, dtype=float)
        e, J = prob.residuals_jacobian(p)
        n_eval = 1
        if not np.all(np.isfinite(e)):
            raise FloatingPointError("the model diverges at the starting point")
        r_diag = prob.noise(e)
        damping = 1e-3
        history_p = [p.copy()]
        history_cost = [_nll(e, r_diag)]
        converged, message, it = False, "", 0
        for it in range(1, self.max_iterations + 1):
            cost = _cost(e, r_diag)
            M, g = _fisher(J, e, r_diag)
            try:
                cov_now = np.linalg.inv(M)
                ratio = np.abs(cov_now @ g) / np.sqrt(np.abs(np.diag(cov_now)) + 1e-300)
                small = bool(np.all(np.isfinite(ratio)) and np.max(ratio) < self.tol)
            except np.linalg.LinAlgError:
                ratio = np.full(p.size, np.inf)
                small = False
            if small:
                r_new = prob.noise(e)
                settled = bool(np.max(np.abs(r_new / r_diag - 1.0)) < R_SETTLED_RTOL)
                r_diag = r_new
                history_cost[-1] = _nll(e, r_diag)
                if settled:
                    converged = True
                    message = f"converged after {it} iterations"
                    break
                continue
            diag = np.diag(M).copy()
            diag[diag <= 0] = 1.0
            while True:
                try:
                    step = np.linalg.solve(M + damping * np.diag(diag), g)
                except np.linalg.LinAlgError:
                    step = np.full_like(p, np.nan)
                if np.all(np.isfinite(step)):
                    longest = float(np.max(np.abs(step)))
                    if longest > MAX_STEP:
                        step *= MAX_STEP / longest
                    e_new = prob.residuals(p + step)
                    n_eval += 1
                    if _cost(e_new, r_diag) <= cost * (1.0 + COST_RTOL):
                        break
                damping *= 10.0
                if damping > MAX_DAMPING:
                    break
            if damping > MAX_DAMPING:
                # no step lowers the cost: a numerical minimum (noise-free data end here,
                # the cost being at rounding level); accepted when the Gauss-Newton step
                # is within one standard deviation
                converged = bool(np.all(np.isfinite(ratio)) and np.max(ratio) < 1.0)
                message = ("converged: no cost-decreasing step (numerical minimum)"
                           if converged else "no cost-decreasing step (damping limit reached)")
                break
            near_gauss_newton = damping <= 1e-2
            damping = max(damping / 10.0, 1e-12)
            p = p + step
            e, J = prob.residuals_jacobian(p)
            n_eval += 1
            r_new = prob.noise(e)
            settled = bool(np.max(np.abs(r_new / r_diag - 1.0)) < R_SETTLED_RTOL)
            r_diag = r_new
            history_p.append(p.copy())
            history_cost.append(_nll(e, r_diag))
            if settled and near_gauss_newton and float(np.max(np.abs(step))) < STALL_STEP:
                # noise-free data: the residuals are the model's own discretisation error,
                # the standard deviations shrink with them and the sd-relative test is
                # never met; nearly undamped steps have stopped moving the parameters
                converged = True
                message = f"converged after {it} iterations (parameters stalled)"
                break
        else:
            message = f"max_iterations ({self.max_iterations}) reached"
        return _Fit(p, e, J, r_diag, history_cost[-1], history_p, history_cost, it, n_eval,
                    converged, message)

    def warm_start(self, prob: _Problem, flight: Flight, rng: np.random.Generator
                   ) -> tuple[np.ndarray, int]:
        """Return the best coefficients of a short PSO run and its evaluation count."""
        from aeroid.estimation._pso import minimize

        const = aeroid.constants(flight.airframe)
        delta = flight["delta"]
        positions = flight.airframe.accel_positions

        def cost(thetas: np.ndarray) -> np.ndarray:
            states = aeroid.propagate(prob.x0_meas, thetas, delta[:-1], flight.dt, const,
                                      substeps=self.substeps)
            acc = aeroid.accelerometers(states, delta[None, :], thetas[:, None, :], const,
                                        positions).reshape(len(thetas), -1, 6)
            y = np.concatenate([acc, states[:, :, 3:6]], axis=2)
            ms = np.mean((prob.z[None] - y) ** 2, axis=1)
            with np.errstate(all="ignore"):
                out = np.sum(np.log(np.maximum(ms, prob.r_floor)), axis=1)
            return np.where(np.isfinite(out), out, np.inf)

        res = minimize(cost, aeroid.prior_bounds(flight.airframe),
                       n_particles=self.pso_particles, n_iterations=self.pso_iterations,
                       rng=rng, x0=flight.airframe.prior_vector()[None, :])
        return np.asarray(res.x), int(res.n_evaluations)

    def run(self, flight: Flight, rng: np.random.Generator) -> EstimationResult:
        """Fit the flight; random draws only for extra starts and the PSO warm start."""
        prob = self.problem(flight)
        n_p = prob.scale.size
        prior = flight.airframe.prior_vector()
        first = np.zeros(n_p)
        first[:9] = prior / prob.scale[:9]
        extra_evals = 0
        if self.pso_warm_start:
            theta_pso, extra_evals = self.warm_start(prob, flight, rng)
            first[:9] = theta_pso / prob.scale[:9]
        starts = [first]
        for _ in range(self.n_starts - 1):
            p = first.copy()
            p[:9] = prior * (1.0 + 0.2 * rng.standard_normal(9)) / prob.scale[:9]
            starts.append(p)
        fits, failures = [], []
        for p0 in starts:
            try:
                fits.append(self.gauss_newton(prob, p0))
            except FloatingPointError as exc:
                failures.append(str(exc))
        if not fits:
            return aeroid.failed_result(self.name, failures[0])
        best = min(fits, key=lambda f: f.nll)
        n_evals = extra_evals + sum(f.n_evaluations for f in fits)
        n_iter = sum(f.n_iterations for f in fits)
        M, _ = _fisher(best.J, best.e, best.r_diag)
        try:
            cov_p = np.linalg.inv(M)
        except np.linalg.LinAlgError:
            cov_p = np.full_like(M, np.nan)
        cov_phys = cov_p * np.outer(prob.scale, prob.scale)
        phys = best.p * prob.scale
        theta = phys[:9]
        cov = cov_phys[:9, :9]
        hist_p = np.array(best.history_p)
        history = {"axis": "iteration", "step": np.arange(len(hist_p)),
                   "theta": hist_p[:, :9] * prob.scale[:9],
                   "cost": np.array(best.history_cost)}
        stderr_phys = np.sqrt(np.abs(np.diag(cov_phys)))
        info = {"R": best.r_diag, "fisher": M, "parameter_names": self.parameter_names(),
                "parameters": phys, "parameter_stderr": stderr_phys,
                "parameter_covariance": cov_phys, "iterations": best.n_iterations,
                "starts": len(starts), "failed_starts": failures, "compiled": prob.compiled,
                "start_costs": [f.nll for f in fits]}
        n_rx = len(self.rx_free())
        for j, t in enumerate(self.rx_free()):
            info[f"rx{t + 1}_m"] = prob.pos[3 * t] + phys[phys.size - n_rx + j]
        return EstimationResult(
            estimator=self.name, theta=theta, stderr=np.sqrt(np.abs(np.diag(cov))),
            covariance=cov, cost=best.nll, success=best.converged, message=best.message,
            n_evaluations=n_evals, n_iterations=n_iter, history=history, info=info)
