"""Aiding in output-error's likelihood: GNSS velocity and position, baro, INS (private).

``aiding = "gnss-velocity"`` adds the flight's GNSS velocity samples
(``metadata["aiding"]["gnss"]``: :meth:`aeroid.reconstruction.Reconstruction.to_flight`
with ``aiding=True``) as three more measured outputs ``vn ve vd`` of the record model;
``"gnss-velocity+ins-attitude"`` also the INS's Euler angles (``metadata["aiding"]["ins"]``)
as ``ins_phi ins_theta ins_psi`` at their own samples, the model's ``phi theta psi``
compared on the circle (:func:`on_circle`: the residual wrapped to (-pi, pi], the logged
roll is wrapped) with the log's stated sd [rad]; GNSS position and barometric altitude:
:mod:`baselines._oe_position`; skews: :mod:`baselines._oe_skew`. Each source is an
:class:`AidingSamples`; the machinery below (mask, fixed variances, sensitivities) is one:

- **Prediction**: the model's body velocity rotated by its attitude,
  ``v_ned = C_nb(phi, theta, psi) [u v w]`` (:func:`aeroid.flights.body_to_ned`), at the
  flight sample of each GNSS time. The record's grid is the IMU's, so a GNSS time must be on
  it (to :data:`GRID_RTOL` of the interval): one that is not is refused in one line
  (nothing resampled, nothing interpolated).
- **Sensitivities**: exact. The states and their forward sensitivities to the
  coefficients and the free initial-state components are propagated through the model's
  own RK4 interval step (:func:`aeroid.model.symbolic.interval_step_symbolic`, the step of
  the record), ``S_{k+1} = dF/dx S_k + dF/dtheta``; the rotation's derivative by complex
  step of :func:`~aeroid.flights.body_to_ned`. The delay's column is a difference of the
  states like the record's (:data:`baselines._oe_record.DELAY_STEP_S`). Positions and IMU
  errors do not move the states: zero columns.
- **Likelihood**: the GNSS entries are in the mask only at their samples
  (:class:`~baselines._gauss_newton.Problem`'s mask), their noise variance is the log's
  stated sd squared (``metadata["aiding"]["gnss"]["sd"]``), **not estimated** (ten
  samples a second would estimate it poorly); the IMU channels' variances are estimated
  as before.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

import aeroid
from aeroid.flights import Flight, body_to_ned, wrap_angle
from aeroid.model import (
    EXOGENOUS,
    N_COEFFICIENTS,
    N_STATE,
    OUTPUT_CHANNELS,
    PHI,
    PSI,
    THETA,
    U,
    W,
    symbolic,
)
from baselines._gauss_newton import Problem
from baselines._oe_aiding_report import aiding_info, aiding_warnings  # noqa: F401 - re-exported
from baselines._oe_aiding_samples import (  # noqa: F401 - re-exported: the sources' face
    AIDING,
    AIDING_CHANNELS,
    CHANNELS,
    GRID_RTOL,
    LABELS,
    OE_AIDING,
    RESIDUAL_NAMES,
    SOURCES,
    UNITS,
    AidingSamples,
    aiding_samples,
    aiding_sources,
    source_columns,
)
from baselines._oe_position import (
    BARO_NAME,
    BARO_SOURCE,
    ORIGIN_NAMES,
    ORIGIN_SCALE_M,
    POSITION_SOURCE,
    integrated,
    origin_starts,
)
from baselines._oe_record import DELAY_STEP_S
from baselines._oe_skew import check_skew_option, hermite_weights, skew_names, skew_sources

#: Initial-state components estimated with aiding (no prior): pitch and heading. The
#: GNSS velocity's direction in NED depends on them: the reconstruction's 0.3 mrad sd is
#: 0.15 m/s at the reference flight's 500 m/s, more than the GNSS's 0.1 m/s sd; held at
#: the reconstruction's, the ve residual was 1.6x its sd (seed 1). The roll angle moves
#: the NED velocity only through v and w (~15 m/s: 5 mm/s per 0.3 mrad) and is held as
#: before: freed too, it traded against the lateral biases and a noise-free fit crept
#: (300 iterations, coefficients 3.5e-3 off).
X0_ANGLES = (THETA, PSI)
#: With the INS attitude in, all three initial angles are estimated: the INS measures
#: the roll angle itself (held, the roll residual carries the reconstruction's error).
ATTITUDE = (PHI, THETA, PSI)
#: The clock group of a source whose skew is another's: the GNSS position's is the GNSS's.
GROUP = {POSITION_SOURCE: "gnss"}
#: Complex step of the rotation's derivative [rad] (exact to rounding).
COMPLEX_STEP = 1e-20


def aiding_x0(aiding: str) -> tuple[int, ...]:
    """The initial-state components ``aiding`` frees (:data:`X0_ANGLES`, :data:`ATTITUDE`
    with the INS, or none)."""
    sources = aiding_sources(aiding)
    return ATTITUDE if "ins" in sources else X0_ANGLES if "gnss" in sources else ()


def aiding_names(aiding: str, skew: str) -> list[str]:
    """The aiding's own parameters, after the record model's: the skews
    (:func:`~baselines._oe_skew.skew_names`), then the GNSS position's origin."""
    sources = aiding_sources(aiding)
    return (skew_names(skew) + (list(ORIGIN_NAMES) if POSITION_SOURCE in sources else [])
            + ([BARO_NAME] if BARO_SOURCE in sources else []))



def ned_velocity(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``C_nb [u v w]`` of states ``x`` (k, >= 9) (k, 3) and its derivative in the first
    nine state components (k, 3, 9): ``C_nb`` itself and, for the angles, the complex step
    of :func:`~aeroid.flights.body_to_ned`."""
    uvw = x[:, U:W + 1]
    angles = x[:, [PHI, THETA, PSI]]
    v = np.einsum("kij,kj->ki", body_to_ned(*angles.T), uvw)
    dv = np.zeros((x.shape[0], 3, N_STATE))
    dv[:, :, U:W + 1] = body_to_ned(*angles.T)
    for j, i in enumerate((PHI, THETA, PSI)):
        a = angles.astype(complex)
        a[:, j] += 1j * COMPLEX_STEP
        dv[:, :, i] = np.einsum("kij,kj->ki", body_to_ned(*a.T).imag / COMPLEX_STEP, uvw)
    return v, dv


def predicted(source: str, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A source's prediction from states ``x`` (k, >= 9), (k, 3), and its derivative in
    the first nine state components (k, 3, 9): :func:`ned_velocity`, or the attitude."""
    if source == "gnss":
        return ned_velocity(x)
    dy = np.zeros((x.shape[0], 3, N_STATE))
    dy[:, range(3), list(ATTITUDE)] = 1.0
    return x[:, list(ATTITUDE)], dy


def on_circle(samples: AidingSamples, y: np.ndarray) -> np.ndarray:
    """The INS prediction ``y`` (n_a, 3) [rad] moved by whole turns to the branch nearest
    its sample, ``z - wrap(z - y)``: the residual ``z - y`` is then ``wrap(z - y)`` in
    (-pi, pi] and the derivative unchanged; other sources' ``y`` as they are."""
    return samples.z - wrap_angle(samples.z - y) if samples.source == "ins" else y


class AidedModel:
    """The record model with each aiding source's outputs appended, shape (n, m + 3 n_src).

    Everything else (layout, the delay's smooth region) is the record model's; with
    ``skew_free`` (sources whose time skew is estimated: :mod:`baselines._oe_skew`) one
    parameter per source after the record model's, scaled by the sample interval.
    """

    def __init__(self, base: Any, samples: tuple[AidingSamples, ...],
                 skew_free: tuple[str, ...] = ()) -> None:
        self.base, self.samples = base, samples
        self.skew_free = tuple(skew_free)
        self.n_base = base.scale.size  # the record model's parameters, the skews, the origin
        self.origin = next((j for j, s in enumerate(samples) if s.source == POSITION_SOURCE), None)
        self.baro = next((j for j, s in enumerate(samples) if s.source == BARO_SOURCE), None)
        self.i_origin = self.n_base + len(skew_free)
        self.scale = np.concatenate([base.scale, np.full(len(skew_free), base.t[1] - base.t[0]),
                                     np.full(3 * (self.origin is not None), ORIGIN_SCALE_M),
                                     np.full(int(self.baro is not None), ORIGIN_SCALE_M)])
        self.i_baro = self.i_origin + 3 * (self.origin is not None)
        self.origin_start = np.zeros(3)  # set by aided_problem: the first sample's
        self.baro_start = 0.0  # the same for the barometer's origin altitude
        n, m = base.t.size, len(OUTPUT_CHANNELS)
        mask = np.ones((n, m), bool) if base.mask is None else base.mask
        self.cols = source_columns(samples)
        aid = np.zeros((n, self.cols[-1].stop), bool)
        for s, c in zip(samples, self.cols, strict=True):
            aid[s.index, c] = True
        self.mask = np.hstack([mask, aid])
        self.n_x0 = len(base.x0_free)
        self.n_s = N_COEFFICIENTS + self.n_x0  # the parameters that move the states
        self.varying = base.exogenous is not None
        const = base.const
        if self.varying:  # as the record: per-sample values replace these
            const = const._replace(**dict.fromkeys(EXOGENOUS, 0.0))
        self.const = const
        self._graphs: dict[int, tuple[ca.Function, ca.Function]] = {}

    @property
    def phys_offset(self) -> np.ndarray:
        """Added to ``p * scale`` for the physical parameters: the origin's start [m]."""
        offset = np.zeros(self.scale.size)
        if self.origin is not None:
            offset[self.i_origin:self.i_origin + 3] = self.origin_start
        if self.baro is not None:
            offset[self.i_baro] = self.baro_start
        return offset

    def __getattr__(self, name: str) -> Any:
        return getattr(self.base, name)

    def _graph(self, n_pieces: int, sensitivities: bool = True) -> ca.Function:
        """The states over the record (with their sensitivities), per-step functions
        compiled to C like the record's when asked (``compile_model``)."""
        if n_pieces not in self._graphs:
            x = ca.SX.sym("x", N_STATE)
            sens = ca.SX.sym("S", N_STATE, self.n_s)
            p9, s9 = ca.SX.sym("p9", N_COEFFICIENTS), ca.SX.sym("s9", N_COEFFICIENTS)
            sym = symbolic.interval_symbols(n_pieces, self.varying)
            dtheta = ca.horzcat(ca.SX.eye(N_COEFFICIENTS),
                                ca.SX.zeros(N_COEFFICIENTS, self.n_x0))
            x_next = symbolic.interval_step_symbolic(x, p9 * s9, sym, self.const,
                                                     float(self.base.t[1] - self.base.t[0]),
                                                     self.base.substeps)
            s_next = ca.jtimes(x_next, ca.vertcat(x, p9), ca.vertcat(sens, dtheta))
            tag = hashlib.sha256(repr((tuple(self.const), self.base.t[1] - self.base.t[0],
                                       self.base.substeps, self.n_s, n_pieces,
                                       self.varying)).encode()).hexdigest()[:12]
            steps = [ca.Function(f"aiding_step_{tag}", [x, sens, p9, s9, *sym],
                                 [x_next, s_next]),
                     ca.Function(f"aiding_plain_{tag}", [x, p9, s9, *sym], [x_next])]
            if self.base.compiled_requested:
                steps = symbolic.compile_functions(steps, f"aeroid_aiding_{tag}") or steps
            m = self.base.t.size - 1
            self._graphs[n_pieces] = (steps[0].mapaccum("aiding_record", m, 2),
                                      steps[1].mapaccum("aiding_states", m))
        return self._graphs[n_pieces][0 if sensitivities else 1]

    def states(self, p: np.ndarray, tau: float, sensitivities: bool = True
               ) -> tuple[np.ndarray, np.ndarray | None]:
        """States (n, 9) and their sensitivities (9, n, n_s) (or None) at ``p``, delay ``tau``."""
        base, n = self.base, self.base.t.size
        record = base.record(tau)
        _, pieces, exo = record.symbolic_inputs()
        x0, s0 = base.x0.copy(), np.zeros((N_STATE, self.n_s))
        free = slice(N_COEFFICIENTS, N_COEFFICIENTS + self.n_x0)
        x0[list(base.x0_free)] += p[free] * base.scale[free]
        s0[list(base.x0_free), range(N_COEFFICIENTS, self.n_s)] = base.scale[free]
        m = n - 1
        rep = [np.tile(v[:, None], (1, m)) for v in (p[:N_COEFFICIENTS],
                                                      base.scale[:N_COEFFICIENTS])]
        if not sensitivities:
            xs = self._graph(record.n_pieces, False)(x0, *rep, pieces, exo[:, :m], exo[:, 1:])
            return np.hstack([x0[:, None], np.asarray(xs)]).T, None
        xs, ss = self._graph(record.n_pieces)(x0, s0, *rep, pieces, exo[:, :m], exo[:, 1:])
        blocks = np.asarray(ss).reshape(N_STATE, m, self.n_s)  # block k: S_{k+1}
        return (np.hstack([x0[:, None], np.asarray(xs)]).T,
                np.concatenate([s0[:, None, :], blocks], axis=1))

    def skew_index(self, source: str) -> int | None:
        """The parameter of ``source``'s skew (the GNSS position's is the GNSS's), or None."""
        group = GROUP.get(source, source)
        return self.n_base + self.skew_free.index(group) if group in self.skew_free else None

    def on_grid(self, s: AidingSamples, p: np.ndarray, xs: np.ndarray, ss: np.ndarray | None,
                index: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """A source's prediction at record samples ``index`` (k,), (k, 3), and its
        sensitivities (3, k, n_s) (or None, as ``ss``): a function of the states there, or
        for the GNSS position the origin plus the NED velocity's integral
        (:mod:`baselines._oe_position`)."""
        if s.source in (POSITION_SOURCE, BARO_SOURCE):
            v, dv = ned_velocity(xs)
            y, dy = integrated(self.base.t, v, None if ss is None else
                               np.einsum("kcx,xkp->ckp", dv, ss), index)
            if self.origin is not None:
                cols = slice(self.i_origin, self.i_origin + 3)
                y = y + self.origin_start + p[cols] * self.scale[cols]
            if s.source == POSITION_SOURCE:
                return y, dy
            h0 = self.baro_start + p[self.i_baro] * self.scale[self.i_baro]
            return h0 - y[:, 2:], None if dy is None else -dy[2:]  # altitude = h0 - pd
        v, dv = predicted(s.source, xs[index])
        return v, None if ss is None else np.einsum("kcx,xkp->ckp", dv, ss[:, index])

    def at_samples(self, s: AidingSamples, p: np.ndarray, xs: np.ndarray,
                   ss: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None,
                                                   np.ndarray | None]:
        """A source's prediction at its (skewed) sample times (n_a, 3), as the states give
        it (the INS not yet on the circle), its sensitivities (3, n_a, n_s) (or None, as
        ``ss``) and, with its skew free, to the scaled skew (3, n_a): the cubic Hermite
        interpolant of :meth:`on_grid` (:func:`~baselines._oe_skew.hermite_weights`)."""
        i = self.skew_index(s.source)
        if i is None:
            return (*self.on_grid(s, p, xs, ss, s.index), None)
        t, dt = self.base.t, self.scale[i]
        index, w, dw = hermite_weights(t[s.index] + p[i] * dt, t[0], dt, t.size)
        v, d = self.on_grid(s, p, xs, ss, index.ravel())
        v = v.reshape(*index.shape, -1)
        y, d_skew = np.einsum("ac,acj->aj", w, v), np.einsum("ac,acj->ja", dw * dt, v)
        if d is None:
            return y, None, d_skew
        return y, np.einsum("ac,jacp->jap", w, d.reshape(len(d), *index.shape, -1)), d_skew

    def _aiding(self, p: np.ndarray, jacobian: bool) -> tuple[np.ndarray, np.ndarray | None]:
        n, tau = self.base.t.size, self.base.tau(p)
        xs, ss = self.states(p, tau, jacobian)
        y = np.zeros((n, self.cols[-1].stop))
        J = None if ss is None else np.zeros((y.shape[1], n, p.size))
        for j, (s, c) in enumerate(zip(self.samples, self.cols, strict=True)):
            v, dv, d_skew = self.at_samples(s, p, xs, ss)
            y[s.index, c] = on_circle(s, v)
            if J is not None and dv is not None:
                J[c, s.index, :self.n_s] = dv
                if d_skew is not None:
                    J[c, s.index, self.skew_index(s.source)] = d_skew
                if j == self.origin:
                    for k in range(3):
                        J[c.start + k, s.index, self.i_origin + k] = ORIGIN_SCALE_M
                if j == self.baro:
                    J[c, s.index, self.i_baro] = ORIGIN_SCALE_M
                    if self.origin is not None:  # altitude = h0 - pd: d/d pd0
                        J[c, s.index, self.i_origin + 2] = -ORIGIN_SCALE_M
        if J is not None and self.base.estimate_delay:
            J[:, :, self.base.n_graph] = self._delay_column(p, tau)
        return y, J

    def _raw(self, xs: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The predictions at their samples as the states give them, (n, 3 n_src), 0 between."""
        y = np.zeros((self.base.t.size, self.cols[-1].stop))
        for s, c in zip(self.samples, self.cols, strict=True):
            y[s.index, c] = self.at_samples(s, p, xs, None)[0]
        return y

    def _delay_column(self, p: np.ndarray, tau: float) -> np.ndarray:
        """d y_aiding / d(scaled delay), (3 n_src, n), 0 between samples: the record's rule
        (:meth:`baselines._oe_record.RecordModel._delay_column`), central inside the
        delay's smooth region, one-sided second order near its edge (of the predictions
        before :func:`on_circle`: continuous in the delay)."""
        region, i = self.base.smooth_region(p), self.base.n_graph
        up = (region.hi[i] - p[i]) * self.base.delay_scale
        down = (p[i] - region.lo[i]) * self.base.delay_scale
        h, central = DELAY_STEP_S, min(up, down) >= DELAY_STEP_S
        sign = 1.0 if up >= down else -1.0
        if not central:
            h = min(h, 0.5 * max(up, down))
        offsets = (h, -h) if central else (0.0, sign * h, 2.0 * sign * h)
        v = [self._raw(self.states(p, tau + o, False)[0], p) for o in offsets]
        self.base.record(tau)  # the record model's current delay again
        d = ((v[0] - v[1]) / (2.0 * h) if central
             else sign * (4.0 * v[1] - 3.0 * v[0] - v[2]) / (2.0 * h))
        return (d * self.base.delay_scale).T

    # OutputModel -------------------------------------------------------------------
    def outputs(self, p: np.ndarray) -> np.ndarray:
        """Return ``y(p)``, shape (n, m + 3 n_src): the IMU's outputs, then the sources'."""
        return np.hstack([self.base.outputs(p[:self.n_base]), self._aiding(p, False)[0]])

    def outputs_jacobian(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return ``y(p)`` (n, m + 3 n_src) and ``dy/dp`` (m + 3 n_src, n, n_p)."""
        y, J = self.base.outputs_jacobian(p[:self.n_base])
        J = np.concatenate([J, np.zeros((*J.shape[:2], p.size - self.n_base))], axis=2)
        ya, Ja = self._aiding(p, True)
        return np.hstack([y, ya]), np.concatenate([J, Ja], axis=0)


@dataclass(frozen=True)
class AidedProblem(Problem):
    """A :class:`~baselines._gauss_newton.Problem` whose aiding channels' variances are
    given (``known_var``, NaN where estimated), at their samples; 1 elsewhere."""

    known_var: np.ndarray | None = None

    def noise(self, e: np.ndarray) -> np.ndarray:
        """:meth:`Problem.noise`, the given variances in their channels."""
        var = np.array(np.broadcast_to(super().noise(e), e.shape))
        if self.known_var is None or self.mask is None:
            return var
        fixed = np.flatnonzero(np.isfinite(self.known_var))
        var[:, fixed] = np.where(self.mask[:, fixed], self.known_var[fixed], 1.0)
        return var


def aided_problem(aiding: str, flight: Flight, prob: Problem, skew: str = "none") -> Problem:
    """``prob`` with the aiding outputs of ``aiding`` (``"none"``: ``prob`` itself), the
    time skews of the sources ``skew`` names free (:mod:`baselines._oe_skew`)."""
    check_skew_option(aiding, skew)
    if aiding == "none":
        return prob
    base = prob.model
    if getattr(base, "tables", None) is not None or getattr(base, "wind_free", False):
        raise aeroid.EstimatorError(f"output-error: aiding = {aiding} with coefficient tables or "
                                    "estimate_wind is not built (the aiding outputs integrate the "
                                    "nine constant coefficients in still air)")
    samples = tuple(aiding_samples(flight, source) for source in aiding_sources(aiding))
    model = AidedModel(prob.model, samples, skew_sources(skew))
    model.origin_start, model.baro_start = origin_starts(  # from their first samples
        flight.t, ned_velocity(flight.states())[0],
        *(None if j is None else samples[j] for j in (model.origin, model.baro)))
    z = np.zeros((flight.n_samples, model.cols[-1].stop))
    for s, c in zip(samples, model.cols, strict=True):
        z[s.index, c] = s.z
    var = np.concatenate([s.sd ** 2 for s in samples])
    more = np.zeros(model.scale.size - model.n_base)  # the skews: no prior

    def extended(a: np.ndarray | None) -> np.ndarray | None:
        return None if a is None else np.concatenate([a, more])
    return AidedProblem(z=np.hstack([prob.z, z]), model=model,
                        r_floor=np.concatenate([prob.r_floor, var]),
                        noise_model=prob.noise_model, prior_mean=extended(prob.prior_mean),
                        prior_weight=extended(prob.prior_weight),
                        known_var=np.concatenate([np.full(prob.z.shape[1], np.nan), var]))
