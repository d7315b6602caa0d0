"""The output-error model of a flight for the Gauss-Newton solver (private).

Outputs and exact sensitivities come from aeroid's CasADi record
(:func:`aeroid.model.symbolic_record`); the flight's deflection between samples is the
schedule of the estimator's ``input`` option (:func:`aeroid.flights.schedule`), with its
per-sample channels. An estimated actuator delay ``tau`` moves every knot of the schedule;
its sensitivity is a central difference of the record with the deflection at the sample
instants held at its value for the current ``tau`` (a knot crossing a sample would
otherwise make the accelerometers' deflection jump inside the difference).

IMU errors (``imu_errors``): the model's outputs pass through the sensor law of
:func:`aeroid.flights.simulate_suite`, ``y_meas = (1 + s) y_model + b`` per output
channel, with the biases ``b`` (and, with ``"bias+scale"``, the scale factors ``s``) as
parameters after the graph's (and the delay): exact sensitivities ``(1 + s) dy_model/dp``,
``dy/db = 1``, ``dy/ds = y_model``.
"""

from __future__ import annotations

import numpy as np

from aeroid.flights import (
    Flight,
    exogenous,
    imu_error_names,
    model_constants,
    schedule,
    used_samples,
)
from aeroid.model import NAMES, OUTPUT_CHANNELS, Buffered, MachTables, Record, symbolic_record
from baselines._gauss_newton import SmoothRegion

#: Central-difference step of the delay sensitivity [s]: 1 us, 5e-4 of a 2 ms sample; the
#: outputs are smooth in the delay while no knot crosses a sample within +-1 us.
DELAY_STEP_S = 1e-6
#: The delay's smooth region (:meth:`RecordModel.smooth_region`) stops this fraction of a
#: sample interval short of each edge, and "just across" is as far beyond it (rounding of
#: knot time + delay is ~1e-16 s; the record's knot snapping, 1e-9 of an interval, moves
#: no sample value).
EDGE_MARGIN = 1e-9
#: Samples per piece of a long record: a record longer than this is evaluated piece by
#: piece, each piece's CasADi graph started from the previous one's last state and
#: sensitivity (:func:`aeroid.model.symbolic_record` with ``chained``), so the graph, its
#: build and its memory are those of one piece whatever the record's length (a 20 000
#: sample record's graph: 4.4-5.7 s and +440 MB whole, 0.14-0.41 s and +0-3 MB in
#: pieces; benchmarks/results/oe_long.md). The numbers are the whole record's (the same
#: operations; tests/unit/test_oe_long.py). The last piece is padded with the last
#: interval's inputs (20 000 samples: 21 pieces, 5 % more work).
PIECE_SAMPLES = 1000


class RecordModel:
    """``y(p)`` and ``dy/dp`` of a flight's record in scaled parameters.

    ``mask``: the outputs in the likelihood (the flight's saturated samples out:
    :func:`aeroid.flights.used_samples`), or None; :class:`~baselines._gauss_newton.Problem`
    takes it.

    Parameters ``p``: the graph's parameters (coefficients, or with ``tables`` the
    tables' parameters; free initial-state and position components, with ``wind_free``
    the steady wind north, east, down;
    :func:`aeroid.model.symbolic_record`), then, with
    ``estimate_delay``, ``tau / delay_scale``, then the IMU errors
    (:func:`imu_error_names`), each over its entry of ``scale``.
    """

    #: What an edge of :meth:`smooth_region` is, for the solver's message.
    edge_note: str = ("the delay at an edge: a fin switch on a sample instant, where the "
                      "cost jumps up")

    def __init__(self, flight: Flight, *, input: str, substeps: int,  # noqa: A002
                 x0_free: tuple[int, ...], position_free: tuple[int, ...], compiled: bool,
                 x0: np.ndarray, scale: np.ndarray, delay_s: float,
                 estimate_delay: bool, imu_errors: str = "none",
                 tables: MachTables | None = None, wind_free: bool = False,
                 piece_samples: int = PIECE_SAMPLES) -> None:
        self.const = model_constants(flight)
        self.mask = used_samples(flight.metadata, OUTPUT_CHANNELS, flight.n_samples)
        self.schedule = schedule(flight, input)
        self.t = flight.t
        self.exogenous = exogenous(flight)
        self.substeps = substeps
        self.x0_free, self.position_free = tuple(x0_free), tuple(position_free)
        self.compiled_requested = compiled
        self.x0 = x0
        self.pos = flight.airframe.accel_positions.ravel()
        self.estimate_delay = estimate_delay
        self.delay_s = float(delay_s)
        self.delay_scale = flight.dt
        self.tables = tables  # coefficient tables in Mach (baselines/_tables_fit.py)
        self.n_theta = len(NAMES) if tables is None else tables.n_parameters
        self.wind_free = wind_free
        self.n_graph = self.n_theta + len(x0_free) + len(position_free) + 3 * int(wind_free)
        self.imu_errors = imu_errors
        self.n_imu = len(imu_error_names(imu_errors))
        self.scale = np.asarray(scale, dtype=float)
        expected = self.n_graph + int(estimate_delay) + self.n_imu
        if self.scale.size != expected:
            raise ValueError(f"record model: {self.scale.size} parameter scales for "
                             f"{expected} parameters")
        times, values = self.schedule.times, self.schedule.values
        jumps = (np.diff(times) == 0.0) & (np.diff(values) != 0.0)
        self.switches = np.unique(times[1:][jumps])  # knots where the deflection jumps
        if piece_samples < 2:
            raise ValueError(f"record model: piece_samples must be >= 2, got {piece_samples}")
        self.piece_samples = int(piece_samples)
        self.chained = self.t.size > self.piece_samples
        self._graphs: dict[int, tuple[Buffered, Buffered]] = {}
        self._last: tuple[float, Record] | None = None
        self.compiled = False
        self._inputs: tuple[np.ndarray, ...] = ()  # a chained record's padded inputs
        self._buffers(self.record(self.delay_s))  # build (and compile) the graph now

    # the record for a delay ----------------------------------------------------------
    def record(self, tau: float) -> Record:
        """The flight's record with every knot delayed by ``tau`` [s] (the last one kept)."""
        if self._last is not None and self._last[0] == tau:
            return self._last[1]
        sched = self.schedule.shifted(tau) if tau else self.schedule
        record = Record.scheduled(sched, self.t, self.exogenous)
        self._last = (tau, record)
        return record

    def tau(self, p: np.ndarray) -> float:
        """The delay [s] at parameters ``p`` (the fixed ``delay_s`` when not estimated)."""
        return (float(p[self.n_graph] * self.delay_scale) if self.estimate_delay
                else self.delay_s)

    def smooth_region(self, p: np.ndarray) -> SmoothRegion:
        """Where the outputs are smooth in ``p`` (:class:`baselines._gauss_newton.SmoothRegion`).

        Everything but the delay is smooth everywhere. A sample sees a switch's new value
        when the delayed switch is at or before it (:meth:`aeroid.model.Schedule.at`), so
        the outputs jump where a switch crosses a sample instant: the delay is smooth
        until the first switch reaches the next sample (``hi``) or leaves for the
        previous one (``lo``).
        """
        lo, hi = np.full(p.size, -np.inf), np.full(p.size, np.inf)
        below, above = lo.copy(), hi.copy()
        if not self.estimate_delay or self.switches.size == 0:
            return SmoothRegion(lo, hi, below, above)
        i, scale = self.n_graph, self.delay_scale
        s = self.schedule.shifted(self.tau(p)).times[np.searchsorted(
            self.schedule.times, self.switches)]  # as the record computes them
        k = np.searchsorted(self.t, s, side="left")  # the first sample at or after each
        margin = EDGE_MARGIN * scale
        ahead = self.t[k[k < self.t.size]] - s[k < self.t.size]
        behind = s[k > 0] - self.t[k[k > 0] - 1]
        if ahead.size:
            up = float(np.min(ahead))
            hi[i] = p[i] + max(up - margin, 0.0) / scale
            above[i] = p[i] + (up + margin) / scale
        if behind.size:
            down = float(np.min(behind))
            lo[i] = p[i] - max(down - margin, 0.0) / scale
            below[i] = p[i] - (down + margin) / scale
        return SmoothRegion(lo, hi, below, above)

    def sensor(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return the biases ``b`` and scale factors ``s`` at ``p``, shape (m,) each."""
        m = len(OUTPUT_CHANNELS)
        first = p.size - self.n_imu
        values = p[first:] * self.scale[first:]
        b = values[:m] if self.n_imu >= m else np.zeros(m)
        s = values[m:2 * m] if self.n_imu >= 2 * m else np.zeros(m)
        return b, s

    def _buffers(self, record: Record, delta: np.ndarray | None = None
                 ) -> tuple[Buffered, Buffered]:
        """The graph for at least ``record.n_pieces`` pieces, its inputs set to the record."""
        fitting = [s for s in self._graphs if s >= record.n_pieces]
        if fitting:
            n_pieces = min(fitting)
        else:
            n_pieces = record.n_pieces
            n = self.piece_samples if self.chained else record.n_samples
            simulate, jacobian, self.compiled = symbolic_record(
                self.const, record.dt, self.substeps, n, self.x0_free,
                self.position_free, self.compiled_requested, n_pieces,
                record.exogenous is not None, tables=self.tables, wind_free=self.wind_free,
                chained=self.chained)
            d, pieces, exo = record.symbolic_inputs()
            inputs = [np.zeros(self.n_graph), self.scale[:self.n_graph], self.x0, d[:, :n],
                      pieces[:, :n - 1], exo[:, :n], self.pos]
            inputs += [self.x0, np.zeros((self.x0.size, self.n_graph))] if self.chained else []
            self._graphs[n_pieces] = (Buffered(simulate, inputs), Buffered(jacobian, inputs))
        sim, jac = self._graphs[n_pieces]
        d, pieces, exo = _padded(record, n_pieces).symbolic_inputs()
        if delta is not None:
            d = np.asarray(delta, dtype=float)[None, :]
        if self.chained:  # set piece by piece (:meth:`_chained`)
            self._inputs = _pad_columns(d, pieces, exo, self.piece_samples)
            return sim, jac
        for buffered in (sim, jac):
            buffered.set(3, d)
            buffered.set(4, pieces)
        return sim, jac

    def _chained(self, buffered: Buffered, p: np.ndarray, jacobian: bool
                 ) -> tuple[np.ndarray, np.ndarray | None]:
        """The record piece by piece: ``y`` (n, m) and, with ``jacobian``, ``dy/dp``.

        ``dy/dp`` of the graph's parameters, shape (m, n, n_graph).

        Piece ``c`` covers samples ``c (L - 1) .. c (L - 1) + L - 1`` (``L`` =
        :attr:`piece_samples`; consecutive pieces share a sample), starting from the
        state and sensitivity the previous piece ended with; the first from the initial
        state with its free offsets, as the whole record's graph.
        """
        m, n, n_g, size = len(OUTPUT_CHANNELS), self.t.size, self.n_graph, self.piece_samples
        d, pieces, exo = self._inputs
        x = self.x0.copy()
        sens = np.zeros((x.size, n_g))
        for j, i in enumerate(self.x0_free):
            k = self.n_theta + j  # after the coefficients (or the tables' parameters)
            x[i] = x[i] + p[k] * self.scale[k]
            sens[i, k] = self.scale[k]
        y = np.empty((n, m))
        J = np.empty((m, n, n_g)) if jacobian else None
        for a in range(0, n - 1, size - 1):
            buffered.set(3, d[:, a:a + size])
            buffered.set(4, pieces[:, a:a + size - 1])
            buffered.set(5, exo[:, a:a + size])
            buffered.set(7, x)
            buffered.set(8, sens)
            out = buffered(p[:n_g])
            v = min(size, n - a)  # samples of the record in this piece
            y[a:a + v] = out[0].reshape(m, size).T[:v]
            x = out[-2 if jacobian else -1].copy()
            if J is not None:
                J[:, a:a + v] = out[1].reshape(size, n_g, m).transpose(2, 0, 1)[:, :v]
                sens = out[-1].reshape(n_g, -1).T.copy()
        return y, J

    # OutputModel -------------------------------------------------------------------
    def outputs(self, p: np.ndarray) -> np.ndarray:
        """Return ``y(p)``, shape (n, m)."""
        sim, _ = self._buffers(self.record(self.tau(p)))
        if self.chained:
            y = self._chained(sim, p, jacobian=False)[0]
        else:
            (y,) = sim(p[:self.n_graph])
            y = y.reshape(len(OUTPUT_CHANNELS), -1).T.copy()
        if not self.n_imu:
            return y
        b, s = self.sensor(p)
        return (1.0 + s) * y + b

    def outputs_jacobian(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return ``y(p)`` (n, m) and ``dy/dp`` (m, n, n_p)."""
        tau = self.tau(p)
        record = self.record(tau)
        _, jac = self._buffers(record)
        if self.chained:
            y, J = self._chained(jac, p, jacobian=True)
        else:
            y, dy = jac(p[:self.n_graph])
            n = self.t.size
            y = y.reshape(len(OUTPUT_CHANNELS), n).T.copy()
            # dY (m, n n_p) column-major: entry (j, k n_p + i) at (k n_p + i) m + j
            J = dy.reshape(n, -1, len(OUTPUT_CHANNELS)).transpose(2, 0, 1).copy()
        if self.estimate_delay:
            J = np.concatenate([J, self._delay_column(p, tau, record)], axis=2)
        if not self.n_imu:
            return y, J
        return self._sensor_layer(p, y, J)

    def _sensor_layer(self, p: np.ndarray, y: np.ndarray, J: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
        """``(1 + s) y + b`` and its Jacobian, the IMU-error columns appended."""
        m, n = len(OUTPUT_CHANNELS), self.t.size
        b, s = self.sensor(p)
        first = p.size - self.n_imu
        extra = np.zeros((m, n, self.n_imu))
        for c in range(m):
            extra[c, :, c] = self.scale[first + c]  # dy_c / db_c
            if self.n_imu >= 2 * m:
                extra[c, :, m + c] = y[:, c] * self.scale[first + m + c]  # dy_c / ds_c
        J = np.concatenate([J * (1.0 + s)[:, None, None], extra], axis=2)
        return (1.0 + s) * y + b, J

    def _delay_column(self, p: np.ndarray, tau: float, record: Record) -> np.ndarray:
        """The outputs' sensitivity to the scaled delay, shape (m, n, 1).

        A central difference of :data:`DELAY_STEP_S` where the delay's smooth region
        (:meth:`smooth_region`) holds it; nearer an edge, a one-sided second-order
        difference into the region (the state at a sample a switch crosses has a kink
        there: the switch leaves the interval before it; a difference across the edge
        averaged the two slopes, 3 % off on a suite log, and Gauss-Newton stalled).
        """
        n = self.t.size
        region = self.smooth_region(p)
        i = self.n_graph
        room_up = (region.hi[i] - p[i]) * self.delay_scale
        room_down = (p[i] - region.lo[i]) * self.delay_scale
        h = DELAY_STEP_S
        central = min(room_up, room_down) >= h
        sign = 1.0 if room_up >= room_down else -1.0
        if not central:
            h = min(h, 0.5 * max(room_up, room_down))
        columns = []
        for offset in (h, -h) if central else (0.0, sign * h, 2.0 * sign * h):
            sim, _ = self._buffers(self.record(tau + offset), record.delta)
            if self.chained:
                columns.append(self._chained(sim, p, jacobian=False)[0])
                continue
            (ys,) = sim(p[:self.n_graph])
            columns.append(ys.reshape(len(OUTPUT_CHANNELS), n).T.copy())  # buffer is reused
        self._buffers(record)  # restore the inputs of the current delay
        if central:
            d_tau = (columns[0] - columns[1]) / (2.0 * h) * self.delay_scale
        else:
            d_tau = (sign * (4.0 * columns[1] - 3.0 * columns[0] - columns[2]) / (2.0 * h)
                     * self.delay_scale)
        return d_tau.T[:, :, None]


def _padded(record: Record, n_pieces: int) -> Record:
    """The record with zero-length pieces appended up to ``n_pieces`` per interval."""
    extra = n_pieces - record.n_pieces
    if extra <= 0:
        return record
    end, start, stop = record.pieces
    pad = np.repeat(stop[:, -1:], extra, axis=1)
    return Record(record.dt, record.delta,
                  type(record.pieces)(np.concatenate([end, np.ones_like(pad)], axis=1),
                                      np.concatenate([start, pad], axis=1),
                                      np.concatenate([stop, pad], axis=1)),
                  record.exogenous)


def _pad_columns(d: np.ndarray, pieces: np.ndarray, exo: np.ndarray, size: int
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The record's inputs with their last column repeated to fill the last piece.

    Pieces of ``size`` samples sharing one sample start every ``size - 1``; the samples
    after the record's last are integrated on its last interval's schedule and dropped.
    """
    n = d.shape[1]
    last = (n - 2) // (size - 1) * (size - 1)  # first sample of the last piece
    extra = last + size - n

    def pad(a: np.ndarray) -> np.ndarray:
        return np.concatenate([a, np.repeat(a[:, -1:], extra, axis=1)], axis=1)
    return pad(d), pad(pieces), pad(exo)
