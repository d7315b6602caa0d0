"""numba kernels built from the one definition of the equations (:mod:`aeroid.model._equations`).

Every element-wise equation is registered as a numba overload of itself
(``numba.extending.overload`` with ``inline="always"``), so compiled code calls the very
Python functions numpy and CasADi evaluate, and numba inlines them. Two hooks take faster
paths that give the same values:

* ``atan2`` is compiled as ``atan(y / x)`` for ``x > 0`` (~10 % of the RK4 pass, measured);
* the RK4 stages get sin/cos of phi and theta from the step's start by the addition
  theorem (:func:`sincos_shift`): one sin/cos pair per angle and step instead of four.

Kernels (each coefficient set is integrated by one thread with its state in registers,
no per-set allocation): :func:`propagate_serial` / :func:`propagate_parallel` (RK4 over a
record with the fin deflection held over each sample interval) and
:func:`weighted_cost` (the output-error cost of many trajectories, eq. 28 fused with the
residual sum). ``parallel=True`` (``prange`` over the sets, numba's default thread count,
never changed here) is used from :data:`PARALLEL_MIN_SETS` sets on.

Fast-math flags (:data:`FASTMATH_FLAGS`): reassociation, contraction (FMA), reciprocals,
approximate functions, signed zeros; NOT ``nnan``/``ninf``, so a diverging trajectory
still yields inf/NaN (the estimators' costs rely on it). Agreement with the numpy path is
tested to 1e-12 relative.

Each kernel called from Python is compiled for one set of argument types
(:class:`OneSignature`: read-only C float64 arrays, Python scalars), and
:func:`rk4_substep` is compiled once and called from the four sites of
:func:`integrate_set`: a fresh install compiles the serial RK4 kernel in ~12 s of CPU
instead of three specialisations of ~41 s (``benchmarks/profile_compile.py``).

numba's disk cache checks only the file that defines a kernel, not what it inlines, so
:func:`cached_kernel` adds the SHA-256 of every inlined source (:data:`INLINED_SOURCES`) to
the cache's stamp: an edit of the equations recompiles the kernels, overwriting their old
cache files.
"""

from __future__ import annotations

import hashlib
import inspect
import math
import sys
from collections.abc import Callable
from typing import Any

import numpy as np

from aeroid.model import _equations as eq
from aeroid.model import _inputs as inputs

try:  # numba is a runtime dependency, but the numpy path must work without it
    import numba
    from numba.core.caching import FunctionCache
    from numba.extending import overload

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover - exercised only where numba is missing
    HAVE_NUMBA = False

#: numba fast-math flags of the kernels (module docstring).
FASTMATH_FLAGS = {"nsz", "arcp", "contract", "afn", "reassoc"}
#: Below this many coefficient sets the serial kernel is used: starting the thread pool
#: costs ~0.1-1 ms per call, more than integrating a few sets (the simulator integrates
#: one set per sample).
PARALLEL_MIN_SETS = 16


def _fast_atan2(y: float, x: float) -> float:
    # atan(y / x) equals atan2(y, x) for x > 0 and is ~10 % cheaper in the RK4 pass
    return math.atan(y / x) if x > 0.0 else math.atan2(y, x)


def _generated(name: str, body: str, namespace: dict[str, Any]) -> Callable[..., Any]:
    """Return a function compiled from source text (helpers written from field names)."""
    exec(body, namespace)  # noqa: S102 - source built here from tuple field names only
    return namespace[name]  # type: ignore[no-any-return]


def _state_helpers() -> tuple[Callable[..., Any], ...]:
    """Return ``from_array(a)``, ``coefficients_from_array(a)``, ``axpy(x, h, d)`` and
    ``rk4_combine(x, h6, a, b, e, f)``.

    Written from the field names of :class:`~aeroid.model._equations.State` and
    :class:`~aeroid.model._equations.Coefficients`, so a new state or coefficient needs
    no change here.
    """
    names = eq.STATE_NAMES
    ns: dict[str, Any] = {"State": eq.State, "Coefficients": eq.Coefficients}
    from_array = _generated("from_array", "def from_array(a):\n    return State("
                            + ", ".join(f"a[{i}]" for i in range(len(names))) + ")\n", ns)
    coefficients = _generated(
        "coefficients_from_array", "def coefficients_from_array(a):\n    return Coefficients("
        + ", ".join(f"a[{i}]" for i in range(len(eq.Coefficients._fields))) + ")\n", ns)
    axpy = _generated("axpy", "def axpy(x, h, d):\n    return State("
                      + ", ".join(f"x.{n} + h * d.{n}" for n in names) + ")\n", ns)
    combine = _generated(
        "rk4_combine", "def rk4_combine(x, h6, a, b, e, f):\n    return State("
        + ", ".join(f"x.{n} + h6 * (a.{n} + 2.0 * b.{n} + 2.0 * e.{n} + f.{n})"
                    for n in names) + ")\n", ns)
    return from_array, coefficients, axpy, combine


from_array, coefficients_from_array, axpy, rk4_combine = _state_helpers()


def _register(fn: Callable[..., Any], impl: Callable[..., Any]) -> None:
    """Register ``impl`` as the numba implementation of ``fn`` (same signature), inlined."""
    params = ", ".join(inspect.signature(fn).parameters)
    typer = _generated("typer", f"def typer({params}):\n    return impl\n", {"impl": impl})
    typer.__signature__ = inspect.signature(impl)  # numba compares typer and impl signatures
    overload(fn, inline="always")(typer)


#: The source files the kernels inline: this module, the equations and the inputs (whose
#: generated helpers are written from their definitions), and the module of every
#: registered element-wise function.
INLINED_SOURCES: tuple[str, ...] = tuple(sorted(
    {inspect.getfile(module) for module in (sys.modules[__name__], eq, inputs)}
    | {inspect.getfile(fn) for fn in eq.ELEMENT_WISE}))


def sources_digest(paths: tuple[str, ...] = INLINED_SOURCES) -> str:
    """Return the SHA-256 (hex) of the contents of ``paths``, in order."""
    digest = hashlib.sha256()
    for path in paths:
        with open(path, "rb") as f:
            digest.update(f.read())
    return digest.hexdigest()


def one_type(value: Any) -> Any:
    """Return ``value`` as the one numba type its kernel argument is compiled for.

    Arrays: read-only, C-contiguous float64 (a view when they already are C float64: no
    copy); numpy scalars: Python ``bool``, ``int`` or ``float``; named tuples of numbers:
    the same tuple of Python floats. numba compiles one specialisation per argument type,
    and the readonly flag, the memory layout and the scalar kind are each part of the
    type: the serial RK4 kernel was compiled three times (~40 s each) in the quick study,
    for read-only and writable views of the same arrays.
    """
    if isinstance(value, np.ndarray):
        value = np.ascontiguousarray(value, dtype=np.float64)
        if value.flags.writeable:
            value = value.view()
            value.flags.writeable = False
        return value
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        return float(value)
    if isinstance(value, tuple) and hasattr(value, "_fields"):
        return type(value)(*(float(v) for v in value))
    return value


class OneSignature:
    """A numba kernel called from Python with its arguments in one type (:func:`one_type`).

    Attributes other than the call (``stats``, ``py_func``, numba's cache) are the
    kernel's. The kernel itself is :attr:`kernel`.
    """

    def __init__(self, kernel: Any) -> None:
        self.kernel = kernel
        self.__doc__ = kernel.__doc__
        self.__name__ = kernel.__name__

    def __call__(self, *args: Any) -> Any:
        """Call the kernel with every argument in its one type."""
        return self.kernel(*(one_type(a) for a in args))

    def __getattr__(self, name: str) -> Any:
        return getattr(self.kernel, name)


if HAVE_NUMBA:
    try:
        _DIGEST: str | None = sources_digest()
    except OSError:  # the sources are no readable files (a zipped install): no disk cache
        _DIGEST = None

    class _SourcesKeyedCache(FunctionCache):  # type: ignore[misc]
        """numba's disk cache of one kernel, stamped with every source the kernel inlines.

        numba stamps a cache index with the hash of the defining file and treats an index
        with another stamp as empty, so the kernel is recompiled and its files rewritten.
        The stamp here is numba's paired with :func:`sources_digest` (read once, when the
        kernel is defined).
        """

        def __init__(self, py_func: Callable[..., Any]) -> None:
            super().__init__(py_func)
            # numba keeps the stamp on its index file object (numba/core/caching.py)
            self._cache_file._source_stamp = (self._cache_file._source_stamp, _DIGEST)

    def cached_kernel(*, entry: bool = False, **options: Any
                      ) -> Callable[[Callable[..., Any]], Any]:
        """Return ``numba.njit(**options)`` with the disk cache of :class:`_SourcesKeyedCache`.

        Used in place of ``cache=True`` (which would stamp the cache with this file only).
        Without readable sources the kernels are compiled in every process, never cached.
        ``entry``: a kernel called from Python, wrapped in :class:`OneSignature` so every
        caller reaches the same compiled specialisation.
        """
        def decorate(fn: Callable[..., Any]) -> Any:
            kernel = numba.njit(**options)(fn)
            if _DIGEST is not None:  # what numba's Dispatcher.enable_caching does, restamped
                kernel._cache = _SourcesKeyedCache(kernel.py_func)
            return OneSignature(kernel) if entry else kernel
        return decorate

    for _fn in eq.ELEMENT_WISE:
        _register(_fn, _fast_atan2 if _fn is eq.atan2 else eq.KERNEL_HOOKS.get(_fn, _fn))
    for _fn in (eq.outputs, from_array, coefficients_from_array, axpy, rk4_combine,
                inputs.with_exogenous, inputs.lerp):
        _register(_fn, _fn)

    jit_inline = numba.njit(inline="always", fastmath=FASTMATH_FLAGS)

    @jit_inline
    def sincos_shift(s0, c0, d):  # pragma: no cover - compiled
        """Return sin(a + d), cos(a + d) from s0 = sin(a), c0 = cos(a).

        sin(d), cos(d) from their Taylor series when |d| < 0.1 (terms to d^11 and d^12:
        truncation < 1e-19, rounding level), from libm otherwise. The RK4 stages move phi
        and theta by a small d = h/2 * rate.
        """
        if abs(d) < 0.1:
            d2 = d * d
            sd = d * (1.0 - d2 / 6.0 * (1.0 - d2 / 20.0 * (1.0 - d2 / 42.0 * (
                1.0 - d2 / 72.0 * (1.0 - d2 / 110.0)))))
            cd = 1.0 - d2 / 2.0 * (1.0 - d2 / 12.0 * (1.0 - d2 / 30.0 * (1.0 - d2 / 56.0 * (
                1.0 - d2 / 90.0 * (1.0 - d2 / 132.0)))))
        else:
            sd = math.sin(d)
            cd = math.cos(d)
        return s0 * cd + c0 * sd, c0 * cd - s0 * sd

    @jit_inline
    def shifted(t, dphi, dtheta):  # pragma: no cover - compiled
        """Return the attitude trigonometry with phi and theta moved by small angles."""
        sphi, cphi = sincos_shift(t.sphi, t.cphi, dphi)
        sth, cth = sincos_shift(t.stheta, t.ctheta, dtheta)
        return eq.Trig(sphi, cphi, sth, cth)

    # one compiled function that integrate_set calls from its four call sites (LLVM may
    # inline it): inlined by numba into each of them, the kernel took 41 s of CPU to
    # compile instead of 12 s (benchmarks/profile_compile.py); the states differ by
    # rounding only (1.4e-12 m/s at most on the reference flight, 40 sets)
    @numba.njit(fastmath=FASTMATH_FLAGS)
    def rk4_substep(x, c, d0, d1, d2, k0, k1, k2, h):  # pragma: no cover - compiled
        """Return the state after one classical RK4 step of ``h``.

        ``d0, d1, d2`` and ``k0, k1, k2`` are the fin deflection and the constants at the
        start, the middle and the end of the step.
        """
        hh = 0.5 * h
        t = eq.Trig(math.sin(x.phi), math.cos(x.phi), math.sin(x.theta), math.cos(x.theta))
        a = eq.state_derivative(x, c, d0, k0, t)
        b = eq.state_derivative(axpy(x, hh, a), c, d1, k1, shifted(t, hh * a.phi,
                                                                   hh * a.theta))
        e = eq.state_derivative(axpy(x, hh, b), c, d1, k1, shifted(t, hh * b.phi,
                                                                   hh * b.theta))
        f = eq.state_derivative(axpy(x, h, e), c, d2, k2, shifted(t, h * e.phi,
                                                                  h * e.theta))
        return rk4_combine(x, h / 6.0, a, b, e, f)

    @cached_kernel(fastmath=FASTMATH_FLAGS)
    def integrate_set(x0, c0, end, start, stop, exo, varying, dt, substeps, base,
                      out):  # pragma: no cover - compiled
        """Integrate one coefficient set over the record into ``out`` (n_samples, N_STATE).

        Interval ``s`` is cut into the pieces ``end[s]`` (fractions; the deflection goes
        linearly from ``start`` to ``stop`` within a piece, constant when they are
        equal), each integrated with ``substeps`` RK4 steps; with ``varying`` the
        exogenous table ``exo`` (n, len(EXOGENOUS)) is interpolated linearly within the interval,
        otherwise the constants ``base`` hold.
        """
        c = coefficients_from_array(c0)
        x = from_array(x0)
        for j in range(x0.shape[0]):
            out[0, j] = x0[j]
        if end.shape[1] == 1 and end[-1, 0] == 1.0 and not varying:  # one piece per interval:
            # the hot path (same arithmetic as below, without the piece bookkeeping)
            h = dt / substeps
            for s in range(end.shape[0]):
                d = start[s, 0]
                if stop[s, 0] == d:
                    for _ in range(substeps):
                        x = rk4_substep(x, c, d, d, d, base, base, base, h)
                    for j in range(len(x)):
                        out[s + 1, j] = x[j]
                    continue
                d_span = stop[s, 0] - d
                for sub in range(substeps):
                    u0, u1, u2 = sub / substeps, (sub + 0.5) / substeps, (sub + 1.0) / substeps
                    x = rk4_substep(x, c, d + d_span * u0, d + d_span * u1, d + d_span * u2,
                                    base, base, base, h)
                for j in range(len(x)):
                    out[s + 1, j] = x[j]
            return
        k_a = base
        k_b = base
        for s in range(end.shape[0]):
            if varying:
                k_a = inputs.with_exogenous(base, exo[s])
                k_b = inputs.with_exogenous(base, exo[s + 1])
            f_start = 0.0
            for piece in range(end.shape[1]):
                f_end = end[s, piece]
                length = f_end - f_start
                if length > 0.0:
                    d_start = start[s, piece]
                    d_span = stop[s, piece] - d_start
                    h = length * dt / substeps
                    for sub in range(substeps):
                        # stage points as fractions of the piece: no division by length
                        u0, u1, u2 = sub / substeps, (sub + 0.5) / substeps, (sub + 1.0) / substeps
                        d0 = d_start + d_span * u0
                        d1 = d_start + d_span * u1
                        d2 = d_start + d_span * u2
                        if varying:
                            x = rk4_substep(x, c, d0, d1, d2,
                                            inputs.lerp(k_a, k_b, f_start + length * u0),
                                            inputs.lerp(k_a, k_b, f_start + length * u1),
                                            inputs.lerp(k_a, k_b, f_start + length * u2), h)
                        else:
                            x = rk4_substep(x, c, d0, d1, d2, base, base, base, h)
                f_start = f_end
            for j in range(len(x)):
                out[s + 1, j] = x[j]

    @cached_kernel(entry=True, parallel=True)
    def propagate_parallel(state0, coefficients, end, start, stop, exo, varying, dt,
                           substeps, base):  # pragma: no cover - compiled
        """Integrate many sets, one thread per set (``prange``)."""
        out = np.empty((state0.shape[0], end.shape[0] + 1, state0.shape[1]))
        for i in numba.prange(state0.shape[0]):
            integrate_set(state0[i], coefficients[i], end, start, stop, exo, varying, dt,
                          substeps, base, out[i])
        return out

    @cached_kernel(entry=True)
    def propagate_serial(state0, coefficients, end, start, stop, exo, varying, dt,
                         substeps, base):  # pragma: no cover - compiled
        """Integrate many sets in one thread."""
        out = np.empty((state0.shape[0], end.shape[0] + 1, state0.shape[1]))
        for i in range(state0.shape[0]):
            integrate_set(state0[i], coefficients[i], end, start, stop, exo, varying, dt,
                          substeps, base, out[i])
        return out

    @cached_kernel(entry=True, parallel=True, fastmath=False)
    def weighted_cost(states, delta, theta, base, exo, varying, positions, z,
                      w):  # pragma: no cover - compiled
        """Return ``(1/n) sum_k sum_c w_kc (z_kc - y_kc)^2`` for every set, shape (n_sets,).

        ``y`` are the model outputs (:func:`aeroid.model._equations.outputs`: eq. 28 at
        each triad position, then the rate gyros) of the trajectories ``states``
        (n_sets, n, N_STATE) with the deflection ``delta`` (n,) and the constants
        (``base``, or the rows of ``exo`` with ``varying``) at the samples; ``z``, ``w``
        (n, n_outputs), columns :func:`aeroid.model._equations.output_names`.
        """
        n_sets, n = states.shape[0], states.shape[1]
        out = np.empty(n_sets)
        for i in numba.prange(n_sets):
            c = coefficients_from_array(theta[i])
            y = np.empty(z.shape[1])  # one set's outputs at a sample (scratch)
            total = 0.0
            const = base
            for s in range(n):
                if varying:
                    const = inputs.with_exogenous(base, exo[s])
                x = from_array(states[i, s])
                eq.outputs(y, x, eq.aerodynamic_loads(x, c, delta[s], const), const, positions)
                for col in range(y.shape[0]):
                    e = z[s, col] - y[col]
                    total += w[s, col] * e * e
            out[i] = total / n
        return out


def kernels_cached() -> bool:
    """Return whether the compiled kernels are in numba's on-disk cache (no compilation due).

    Reads numba's cache index of each kernel (private numba attributes: on any surprise
    the answer is True, i.e. no notice); an index stamped with other sources counts as
    missing. The first run after an install or an edit of the equations compiles them
    (the command line names each compilation as it happens:
    :func:`aeroid.model.compile_clock`).
    """
    if not HAVE_NUMBA:
        return True
    try:
        return all(bool(kernel._cache._cache_file._load_index())
                   for kernel in (integrate_set, propagate_parallel, propagate_serial,
                                  weighted_cost))
    except AttributeError:  # pragma: no cover - a numba without this layout
        return True
