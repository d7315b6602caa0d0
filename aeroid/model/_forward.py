"""The output-error forward model of a record, written once (PINTS' ForwardModel idea).

Given a record's inputs (the fin deflection at every sample, the sample interval, the
model constants and the accelerometer-triad positions) and parameters (coefficients, the
initial state, optionally free initial-state components and position components), the
forward model returns the predicted outputs at every sample and, where asked, their
sensitivities to the parameters::

    y_k(theta, x0) = [a_triad1 (3), ..., a_triadN (3), p, q, r]_k,   k = 0..n-1,

the state integrated with RK4 from ``x0`` with the fin deflection held over each sample
interval, the outputs from eq. 28 and the rate gyros (:mod:`aeroid.model._equations`).

Three evaluations share this definition:

* :class:`ForwardModel`: numpy/numba; many coefficient sets at once (a PSO swarm): the
  outputs, a fused weighted least-squares cost (the EAM hot path, numba kernel), and
  central-difference sensitivities (the Cramér-Rao floor);
* :func:`symbolic_record`: the same record as a CasADi graph with exact forward
  sensitivities (the output-error Gauss-Newton solver), built from the same equations.

Parameters of the symbolic record are scaled to order one (``theta = p[:9] scale[:9]``;
offsets of free initial-state and position components follow), see
:func:`symbolic_record`.
"""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Iterator, Sequence

import casadi as ca
import numpy as np

from aeroid.model import _compiled, _symbolic
from aeroid.model import _equations as eq
from aeroid.model import _inputs as inputs
from aeroid.model import _sensitivity as sensitivity
from aeroid.model._dynamics import (
    N_STATE,
    Constants,
    as_coefficients,
    as_state,
)
from aeroid.model._inputs import Record
from aeroid.model._integrate import propagate
from aeroid.model._sensitivity import DEFAULT_REL_STEP
from aeroid.model._tables import MachTables
from aeroid.model._wind import with_wind_symbols


class ForwardModel:
    """Predicted outputs of one record for many parameter sets (numpy/numba).

    Parameters
    ----------
    const : Constants
        Model constants (:func:`aeroid.model.constants`).
    record : Record
        The inputs in time: sample interval, deflection at and between the samples,
        exogenous quantities (:class:`aeroid.model.Record`).
    positions : ndarray, shape (n_triads, 3)
        Accelerometer-triad positions from the c.g. [m].
    substeps : int
        RK4 steps per sample interval.
    backend : {"auto", "numba", "numpy"}
        Integration and cost backend (same numbers, tested).

    Attributes
    ----------
    output_names : tuple of str
        ``ax1, ay1, az1, ...`` per triad, then ``p, q, r``.
    """

    def __init__(self, const: Constants, record: Record, positions: np.ndarray, *,
                 substeps: int = 1, backend: str = "auto") -> None:
        self.const = Constants(*(float(v) for v in const))
        self.record = record
        self.delta = record.delta
        self.dt = record.dt
        self.positions = np.ascontiguousarray(np.atleast_2d(np.asarray(positions, dtype=float)))
        if self.positions.ndim != 2 or self.positions.shape[1] != 3:
            raise ValueError(f"forward model: positions must have shape (n_triads, 3), "
                             f"got {self.positions.shape}")
        if int(substeps) < 1:
            raise ValueError(f"forward model: substeps must be >= 1, got {substeps}")
        self.substeps = int(substeps)
        if backend not in ("auto", "numba", "numpy"):
            raise ValueError(f"forward model: backend must be auto, numba or numpy, "
                             f"got {backend!r}")
        self.backend = ("numba" if _compiled.HAVE_NUMBA else "numpy") if backend == "auto" \
            else backend
        self.output_names = eq.output_names(self.positions.shape[0])

    @property
    def n_samples(self) -> int:
        """Samples in the record."""
        return int(self.delta.size)

    def states(self, state0: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """Return the integrated states, shape (n_sets, n, 9).

        ``state0`` is (9,) (shared) or (n_sets, 9); ``theta`` (9,) or (n_sets, 9).
        """
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        return propagate(state0, theta, self.record.pieces, self.dt, self.const,
                         substeps=self.substeps, backend=self.backend,
                         exogenous=self.record.exogenous)

    def outputs_of(self, states: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """Return the outputs of given trajectories ``states`` (n_sets, n, 9), (n_sets, n, m)."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        const = self.const if self.record.exogenous is None else inputs.with_exogenous(
            self.const, self.record.exogenous.T)  # fields (n,): the constants per sample
        x = as_state(states)
        y = np.empty((*states.shape[:2], len(self.output_names)))
        with np.errstate(all="ignore"):
            loads = eq.aerodynamic_loads(x, as_coefficients(theta[:, None, :]),
                                         self.delta[None, :], const)
            eq.outputs(np.moveaxis(y, -1, 0), x, loads, const, self.positions)
        return y

    def outputs(self, state0: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """Return the predicted outputs, shape (n_sets, n, m), columns :attr:`output_names`."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        return self.outputs_of(self.states(state0, theta), theta)

    def cost(self, state0: np.ndarray, theta: np.ndarray, measured: np.ndarray,
             weights: np.ndarray) -> np.ndarray:
        """Return ``(1/n) sum_k sum_c w_kc (z_kc - y_kc)^2`` per set, shape (n_sets,).

        Non-finite costs (a diverging trajectory) are returned as +inf.

        Parameters
        ----------
        state0 : ndarray, shape (9,) or (n_sets, 9)
        theta : ndarray, shape (n_sets, 9)
        measured, weights : ndarray, shape (n, m)
            The measured outputs ``z`` (columns :attr:`output_names`) and their weights.
        """
        theta = np.ascontiguousarray(np.atleast_2d(np.asarray(theta, dtype=float)))
        states = self.states(state0, theta)
        with np.errstate(all="ignore"):
            if self.backend == "numba":
                varying = self.record.exogenous is not None
                table = (self.record.exogenous if varying
                         else np.zeros((1, len(inputs.EXOGENOUS))))
                cost = _compiled.weighted_cost(states, self.delta, theta, self.const, table,
                                               varying, self.positions, measured, weights)
            else:
                pred = self.outputs_of(states, theta)
                cost = np.sum(weights * (measured - pred) ** 2, axis=(1, 2)) / self.n_samples
        return np.where(np.isfinite(cost), cost, np.inf)

    def sensitivities(self, state0: np.ndarray, theta: np.ndarray, *,
                      free_states: Sequence[str] = (), rel_step: float = DEFAULT_REL_STEP,
                      coefficients: Sequence[int] | None = None) -> np.ndarray:
        """Return ``d y_kc / d (theta, x0)`` by central differences, shape (n, m, c + f).

        Axes: sample, output channel, parameter (the nine coefficients, or those indexed
        by ``coefficients`` in that order, then the initial state components named in
        ``free_states``, e.g. ``("p", "q", "r")``). The step of
        coefficient j is ``rel_step |theta_j|`` (``rel_step`` when theta_j = 0), that of a
        state component ``rel_step max(|x0_i|, 1)``. The whole matrix: a sum over the
        samples (the Fisher information) takes :meth:`sensitivity_blocks` instead.
        """
        return sensitivity.whole(self, state0, theta, free_states, rel_step, coefficients)

    def sensitivity_blocks(self, state0: np.ndarray, theta: np.ndarray, *,
                           free_states: Sequence[str] = (), rel_step: float = DEFAULT_REL_STEP,
                           coefficients: Sequence[int] | None = None,
                           block_samples: int | None = None
                           ) -> Iterator[tuple[slice, np.ndarray]]:
        """Yield :meth:`sensitivities` block by block in time: ``(samples, d y / d params)``.

        The perturbed trajectories are integrated once, each block continuing from the
        previous one's last state: the same numbers (:mod:`aeroid.model._sensitivity`).
        ``block_samples`` (>= 2): default what :data:`SENSITIVITY_BLOCK_BYTES` allows.
        """
        return sensitivity.blocks(self, state0, theta, free_states, rel_step, coefficients,
                                  block_samples)


# --------------------------------------------------------------------------------------
# The same record as a CasADi graph with exact sensitivities
# --------------------------------------------------------------------------------------
def symbolic_record(const: Constants, dt: float, substeps: int, n_samples: int,
                    x0_free: tuple[int, ...] = (), position_free: tuple[int, ...] = (),
                    compiled: bool = False, n_pieces: int = 1, varying: bool = False,
                    tables: MachTables | None = None, wind_free: bool = False,
                    chained: bool = False) -> tuple[ca.Function, ca.Function, bool]:
    """Return the CasADi output model of a record (both triads, rates) and its Jacobian.

    Parameters ``p`` (order one): ``theta = p[:9] * scale[:9]``; the next
    ``len(x0_free)`` are offsets of those state components (indices into the state,
    increasing) from the given initial state (``x0 = x0_given + p * scale``); the last
    ``len(position_free)`` are offsets of those position components (indices into the
    flattened positions ``[x1, y1, z1, x2, y2, z2]``) from the given positions; with
    ``wind_free``, three more: a steady wind (north, east, down) [m/s] added to the
    constants' wind (or to each sample's, with ``varying``), ``wind = p * scale``.

    Inputs besides the parameters: the deflection at every sample (the outputs see it),
    the schedule's pieces per interval (``n_pieces`` per interval, rows ``end``,
    ``start``, ``stop``: :meth:`aeroid.model.Schedule.segments`) and, with ``varying``,
    the exogenous table (len(EXOGENOUS) rows, one column per sample).

    With ``tables`` (:class:`aeroid.model.MachTables`), the first parameters are the
    tables' (:meth:`~aeroid.model.MachTables.parameter_names`: constants and table
    points, ``n_c = tables.n_parameters`` of them instead of the 9 coefficients), the
    coefficients evaluated at each RK4 stage's and sample's Mach number (with
    ``tables.per_sample_temperature``, from the exogenous air temperature interpolated
    like the density: ``varying`` required).

    The Jacobian is propagated with the record (forward sensitivities): the interval
    step ``x_{k+1} = F(x_k, theta)`` is differentiated by CasADi AD in the directions
    ``S_k = dx_k/dp`` (``jtimes``), ``S_{k+1} = dF/dx S_k + dF/dtheta dtheta/dp``, and
    ``mapaccum`` carries ``(x, S)`` over the record; the outputs' Jacobian is
    ``dh/dx S_k + dh/dtheta dtheta/dp + dh/dpos dpos/dp``. This is exact (the chain rule
    through the discrete RK4 map) and several times faster than differentiating the
    ``mapaccum`` graph as a whole.

    Returns
    -------
    simulate : Function ``(p, scale, x0_given (9), delta (1, n), pieces (3 S, n - 1),
        exo (len(EXOGENOUS) or 0, n), pos (6)) -> Y (n, 9)``
    jacobian : Function ``(same) -> (Y (n, 9), dY (9, n n_p))``
        Columns ``k n_p .. (k + 1) n_p`` of ``dY`` are ``dy_k / dp``.
    is_compiled : bool
        With ``compiled``, the per-step SX functions are compiled to C
        (:func:`aeroid.model._symbolic.compile_functions`); False when that failed.

    With ``chained`` the record is one piece of a longer one (a long record evaluated
    piece by piece, memory and graph of one piece): both functions take two more inputs,
    the state ``x_start`` (9) and its sensitivity ``S_start`` (9, n_p) at the first
    sample (they replace ``x0_given`` with its free offsets and their sensitivity, so
    ``x0_given`` is unused), and return two more outputs, the state (9) and, for
    ``jacobian``, its sensitivity (9, n_p) at the last sample, to start the next piece.
    """
    if tables is not None and tables.per_sample_temperature and not varying:
        raise ValueError("symbolic_record: tables with a per-sample air temperature need "
                         "the exogenous table (varying=True) that carries it")
    return _symbolic_record(inputs.normalised(const, varying), float(dt), int(substeps),
                            int(n_samples), tuple(x0_free), tuple(position_free),
                            bool(compiled), int(n_pieces), bool(varying), tables,
                            bool(wind_free), bool(chained))


@functools.lru_cache(maxsize=16)
def _symbolic_record(const: Constants, dt: float, substeps: int, n_samples: int,
                     x0_free: tuple[int, ...], position_free: tuple[int, ...],
                     compiled: bool, n_pieces: int, varying: bool,
                     tables: MachTables | None = None, wind_free: bool = False,
                     chained: bool = False
                     ) -> tuple[ca.Function, ca.Function, bool]:
    n_pos = 6
    # the coefficient parameters: the 9 coefficients, or the tables' constants and points
    N_COEFFICIENTS = _symbolic.n_theta(tables)
    n_x0, n_free_pos, n_wind = len(x0_free), len(position_free), 3 * int(wind_free)
    n_p = N_COEFFICIENTS + n_x0 + n_free_pos + n_wind
    # one interval with sensitivities (SX)
    x = ca.SX.sym("x", N_STATE)
    sens = ca.SX.sym("S", N_STATE, n_p)
    p9 = ca.SX.sym("p9", N_COEFFICIENTS)
    scale9 = ca.SX.sym("scale9", N_COEFFICIENTS)
    sym = _symbolic.interval_symbols(n_pieces, varying)
    n_exo = sym.exo_a.shape[0]
    theta = p9 * scale9
    dtheta = ca.horzcat(ca.SX.eye(N_COEFFICIENTS), ca.SX.zeros(N_COEFFICIENTS,
                                                               n_p - N_COEFFICIENTS))
    pw, sw = ca.SX.sym("pw", n_wind), ca.SX.sym("sw", n_wind)  # wind parameters, scales
    dwind = ca.horzcat(ca.SX.zeros(n_wind, n_p - n_wind), ca.SX.eye(n_wind))
    const_w, sym_w, wind_row = with_wind_symbols(const, sym, pw * sw)
    x_next = _symbolic.interval_step_symbolic(x, theta, sym_w, const_w, dt, substeps,
                                                tables)
    s_next = ca.jtimes(x_next, ca.vertcat(x, p9, pw), ca.vertcat(sens, dtheta, dwind))
    # symbol names unique per configuration: several compiled libraries may be loaded in
    # one process
    tag = (f"p{n_p}x{''.join(map(str, x0_free)) or 'n'}"
           f"r{''.join(map(str, position_free)) or 'n'}s{substeps}S{n_pieces}"
           f"{'v' if varying else 'c'}{'w' if wind_free else ''}h"
           f"{hashlib.sha256(repr((tuple(const), dt, n_samples)).encode()).hexdigest()[:8]}"
           + ("" if tables is None else
              f"t{hashlib.sha256(repr(tables).encode()).hexdigest()[:8]}"))
    step = ca.Function(f"step_sens_{tag}", [x, sens, p9, scale9, pw, sw, *sym],
                       [x_next, s_next])
    # outputs with sensitivities (SX)
    d = ca.SX.sym("delta")
    exo = ca.SX.sym("exo", n_exo)
    ppos = ca.SX.sym("ppos", n_pos)  # scaled position offsets
    scale_pos = ca.SX.sym("scale_pos", n_pos)
    pos0 = ca.SX.sym("pos", n_pos)
    pos = pos0 + ppos * scale_pos
    y = _symbolic.measurement(x, d, theta, pos, _symbolic.sample_constants(const_w,
                                                                           exo + wind_row),
                              tables)
    dpos = ca.SX.zeros(n_pos, n_p)
    for j, component in enumerate(position_free):
        dpos[component, N_COEFFICIENTS + n_x0 + j] = 1.0
    dy = ca.jtimes(y, ca.vertcat(x, p9, pw, ppos), ca.vertcat(sens, dtheta, dwind, dpos))
    out = ca.Function(f"out_sens_{tag}", [x, sens, p9, scale9, pw, sw, d, exo, pos0, ppos,
                                          scale_pos], [y, dy])
    out_plain = ca.Function(f"out_{tag}", [x, p9, scale9, pw, sw, d, exo, pos0, ppos,
                                           scale_pos], [y])
    step_plain = ca.Function(f"step_{tag}", [x, p9, scale9, pw, sw, *sym], [x_next])
    is_compiled = False
    if compiled:
        built = _symbolic.compile_functions([step, out, step_plain, out_plain],
                                            f"aeroid_oe_{tag}")
        if built is not None:
            step, out, step_plain, out_plain = built
            is_compiled = True

    # the record (MX graph of mapped SX functions)
    p = ca.MX.sym("p", n_p)
    scale = ca.MX.sym("scale", n_p)
    x0_given = ca.MX.sym("x0_given", N_STATE)
    delta = ca.MX.sym("delta", 1, n_samples)
    pieces = ca.MX.sym("pieces", 3 * n_pieces, n_samples - 1)
    exo_table = ca.MX.sym("exo", n_exo, n_samples)
    pos_given = ca.MX.sym("pos", n_pos)
    pm, sm = p[:N_COEFFICIENTS], scale[:N_COEFFICIENTS]
    wm = [p[n_p - n_wind:], scale[n_p - n_wind:]]  # the wind parameters (empty without)
    ppos_parts, spos_parts = [ca.MX(0.0)] * n_pos, [ca.MX(0.0)] * n_pos
    for j, component in enumerate(position_free):
        ppos_parts[component] = p[N_COEFFICIENTS + n_x0 + j]
        spos_parts[component] = scale[N_COEFFICIENTS + n_x0 + j]
    ppos_m, spos_m = ca.vertcat(*ppos_parts), ca.vertcat(*spos_parts)
    x0 = x0_given
    s0 = ca.MX.zeros(N_STATE, n_p)
    if n_x0:
        select = np.zeros((N_STATE, n_x0))
        select[list(x0_free), np.arange(n_x0)] = 1.0  # state component <- parameter
        free = slice(N_COEFFICIENTS, N_COEFFICIENTS + n_x0)
        x0 = x0_given + ca.mtimes(ca.DM(select), p[free] * scale[free])
        s0 = ca.horzcat(ca.MX.zeros(N_STATE, N_COEFFICIENTS),
                        ca.mtimes(ca.DM(select), ca.diag(scale[free])),
                        ca.MX.zeros(N_STATE, n_p - N_COEFFICIENTS - n_x0))
    carry = [ca.MX.sym("x_start", N_STATE), ca.MX.sym("S_start", N_STATE, n_p)]
    if chained:  # a piece of a longer record: starts where the previous piece ended
        x0, s0 = carry
    m = n_samples - 1

    def rep(v: ca.MX, k: int) -> ca.MX:
        return ca.repmat(v, 1, k)

    interval_inputs = [pieces, exo_table[:, :m], exo_table[:, 1:]]
    xs = step_plain.mapaccum("record", m)(x0, rep(pm, m), rep(sm, m),
                                          *[rep(v, m) for v in wm], *interval_inputs)
    states = ca.horzcat(x0, xs)
    sample_inputs = [delta, exo_table, rep(pos_given, n_samples), rep(ppos_m, n_samples),
                     rep(spos_m, n_samples)]
    Y = out_plain.map(n_samples)(states, rep(pm, n_samples), rep(sm, n_samples),
                                 *[rep(v, n_samples) for v in wm], *sample_inputs)
    record_inputs = [p, scale, x0_given, delta, pieces, exo_table, pos_given]
    record_inputs += carry if chained else []
    simulate = ca.Function("oe_simulate", record_inputs, [ca.densify(Y.T)] + (
        [ca.densify(states[:, -1])] if chained else []))
    xs, ss = step.mapaccum("record_sens", m, 2)(x0, s0, rep(pm, m), rep(sm, m),
                                                *[rep(v, m) for v in wm], *interval_inputs)
    states = ca.horzcat(x0, xs)
    sens_all = ca.horzcat(s0, ss)  # 9 x (n_samples n_p), block k = S_k
    Y, dY = out.map(n_samples)(states, sens_all, rep(pm, n_samples), rep(sm, n_samples),
                               *[rep(v, n_samples) for v in wm], *sample_inputs)
    # dY: 9 x (n_samples n_p), block k = dy_k/dp -> rows j * n + k of the Jacobian
    jacobian = ca.Function("oe_jacobian", record_inputs, [ca.densify(Y.T), ca.densify(dY)] + (
        [ca.densify(states[:, -1]), ca.densify(sens_all[:, -n_p:])] if chained else []))
    return simulate, jacobian, is_compiled
