"""The augmented-state model of the EKF and UKF: ``[x, theta, d]`` over a flight (private)."""

from __future__ import annotations

import numpy as np

import aeroid
from aeroid.flights import Flight, flight_record, model_constants
from aeroid.model import Buffered, Pieces, Record, symbolic
from baselines import _kalman

#: The filters' augmented state ``[x, theta, d]``: the model's states, its coefficients,
#: then the offsets of the free position components (sizes from the model).
STATES = slice(0, aeroid.model.N_STATE)
COEFFICIENTS = slice(aeroid.model.N_STATE, aeroid.model.N_STATE + aeroid.model.N_COEFFICIENTS)


def buffered_steps(f, h, n_aug: int, delta: np.ndarray, pieces_table: np.ndarray,
                   exo_table: np.ndarray, pos_flat: np.ndarray):
    """Return the filters' ``transition(z, k)`` and ``observe(z, k)`` (value, Jacobian)
    from the CasADi step ``f`` and output ``h`` of an augmented state of ``n_aug``, fed
    sample k's inputs (:meth:`aeroid.model.Record.symbolic_inputs`) through numpy
    buffers shared with CasADi: no DM conversion per step (half the call's cost)."""
    f_buf = Buffered(f, [np.zeros(n_aug), pieces_table[:, 0], exo_table[:, 0],
                         exo_table[:, 1]])
    h_buf = Buffered(h, [np.zeros(n_aug), delta[:1], exo_table[:, 0], pos_flat])

    def transition(z: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        f_buf.set(1, pieces_table[:, k])
        f_buf.set(2, exo_table[:, k])
        f_buf.set(3, exo_table[:, k + 1])
        z_next, F = f_buf(z)
        return z_next.copy(), F.reshape(n_aug, n_aug).T.copy()  # column-major buffer

    def observe(z: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        h_buf.set(1, delta[k:k + 1])
        h_buf.set(2, exo_table[:, k])
        y, H = h_buf(z)
        return y.copy(), H.reshape(n_aug, -1).T.copy()

    return transition, observe


def augmented_model(flight: Flight, substeps: int, record: Record | None = None,
                    position_free: tuple[int, ...] = ()) -> _kalman.DiscreteModel:
    """Return the augmented model ``[x, theta, d]`` of ``flight`` for the filters.

    The transition from sample k to k+1 is one interval of the model's record
    (``record``, default the logged deflection held; ``substeps`` RK4 steps per piece);
    the coefficients and the offsets ``d`` of the position components ``position_free``
    (indices into ``[x1, y1, z1, x2, y2, z2]``) are constant. Jacobians come from CasADi
    AD (:func:`aeroid.model.symbolic.augmented_functions`); the batched versions (UKF)
    evaluate the same equations with numpy.
    """
    const = model_constants(flight)
    record = record or flight_record(flight)
    delta, pieces_table, exo_table = record.symbolic_inputs()
    delta = delta[0]
    pos_flat = flight.airframe.accel_positions.ravel()
    varying = record.exogenous is not None
    free = tuple(position_free)
    n_aug = COEFFICIENTS.stop + len(free)
    f, h = symbolic.augmented_functions(const, record.dt, substeps, record.n_pieces, varying,
                                        free)

    transition, observe = buffered_steps(f, h, n_aug, delta, pieces_table, exo_table, pos_flat)

    def transition_batch(Z: np.ndarray, k: int) -> np.ndarray:
        # numba's serial kernel (numpy without numba): one RK4 step of 37-45 sets is too
        # little work for the threaded kernel, whose launch cost more than the step on a
        # busy 2-core machine; serial, the step costs 0.04 ms against numpy's 0.5 ms
        # (measured, 45 sigma points; equal to 2e-16)
        interval = Pieces(*(a[k:k + 1] for a in record.pieces))
        exo = None if not varying else record.exogenous[k:k + 2]
        x_next = aeroid.model.propagate(Z[:, STATES], Z[:, COEFFICIENTS], interval, record.dt,
                                        const,
                                        substeps=substeps, exogenous=exo,
                                        parallel=False)[:, 1]
        return np.concatenate([x_next, Z[:, STATES.stop:]], axis=1)

    def observe_batch(Z: np.ndarray, k: int) -> np.ndarray:
        const_k = const if not varying else aeroid.model.with_exogenous(
            const, record.exogenous[k])
        pos = np.tile(pos_flat, (len(Z), 1))  # per sigma point
        for j, c in enumerate(free):
            pos[:, c] += Z[:, COEFFICIENTS.stop + j]
        eq = aeroid.model.equations
        x = aeroid.model.as_state(Z[:, STATES])
        loads = eq.aerodynamic_loads(x, aeroid.model.as_coefficients(Z[:, COEFFICIENTS]),
                                     delta[k], const_k)
        # channel-major, returned as its transpose (n_points, m): the layout of the former
        # column_stack, so filterpy's products sum in the same order (a C-ordered result
        # moved the UKF's estimates by ~1e-13 relative)
        y = np.empty((len(aeroid.model.OUTPUT_CHANNELS), len(Z)))
        eq.outputs(y, x, loads, const_k, pos.T.reshape(-1, 3, len(Z)))  # (triad, axis, point)
        return y.T

    return _kalman.DiscreteModel(n_aug, len(aeroid.model.OUTPUT_CHANNELS), transition, observe,
                                 transition_batch,
                                 observe_batch)
