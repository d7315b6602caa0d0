"""Each numba kernel is compiled for one set of argument types, whoever calls it.

numba compiles a specialisation per argument type, and an array's read-only flag and
layout are part of its type: the quick study compiled the serial RK4 kernel three
times (~40 s each) for read-only views (``np.broadcast_to``), a UKF's writable sigma
points and the simulator's arrays. :class:`aeroid.model._compiled.OneSignature` gives
every call the same types.
"""

from __future__ import annotations

import numpy as np
import pytest

from aeroid.flights import model_constants
from aeroid.model import HAVE_NUMBA, exogenous_table, nominal, propagate

pytestmark = pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")


def test_every_caller_reaches_one_specialisation(clean_flight):
    from aeroid.model import _compiled

    const = model_constants(clean_flight)
    delta = clean_flight["delta"][:-1]
    state0 = clean_flight.states()[0]
    theta = nominal()
    outs = []
    for parallel in (False, True):
        # a read-only broadcast view, writable copies, a Fortran-ordered table, numpy
        # scalars in the constants, a read-only deflection
        frozen = delta.copy()
        frozen.flags.writeable = False
        outs.append(propagate(state0, theta, frozen, clean_flight.dt, const,
                              parallel=parallel))
        outs.append(propagate(np.tile(state0, (3, 1)), np.tile(theta, (3, 1)), delta,
                              np.float64(clean_flight.dt),
                              type(const)(*(np.float64(v) for v in const)),
                              parallel=parallel))
        # constants given as a per-sample table, Fortran-ordered: the same trajectory
        table = np.asfortranarray(exogenous_table(const, delta.size + 1))
        outs.append(propagate(state0, theta, delta, clean_flight.dt, const,
                              exogenous=table, parallel=parallel))
    for kernel in (_compiled.propagate_serial, _compiled.propagate_parallel):
        assert len(kernel.signatures) == 1, kernel.signatures
    # the callee: compiled once with its callers, or not at all when they came from the
    # disk cache (a cached kernel carries the code it calls)
    assert len(_compiled.integrate_set.signatures) <= 1, _compiled.integrate_set.signatures
    # the same numbers whatever the caller passed; the table takes the kernel's other
    # branch (interpolating equal values): equal to rounding
    for k, out in enumerate(outs):
        if k % 3 == 2:
            np.testing.assert_allclose(out[0], outs[0][0], rtol=1e-13, atol=1e-13)
        else:
            np.testing.assert_array_equal(out[0], outs[0][0])


def test_one_type_makes_views_not_copies():
    from aeroid.model._compiled import one_type

    a = np.arange(6.0).reshape(2, 3)
    b = one_type(a)
    assert not b.flags.writeable and b.flags.c_contiguous and np.shares_memory(a, b)
    assert a.flags.writeable  # the caller's array is untouched
    f = one_type(np.asfortranarray(a))
    assert f.flags.c_contiguous and not f.flags.writeable
    np.testing.assert_array_equal(f, a)
    assert type(one_type(np.float64(2.0))) is float and type(one_type(np.int64(2))) is int
    assert type(one_type(np.bool_(True))) is bool
