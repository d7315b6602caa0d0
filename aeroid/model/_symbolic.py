"""The model on CasADi symbols, for exact derivatives (algorithmic differentiation).

The equations are not written here: :mod:`aeroid.model._equations` is evaluated on CasADi
``SX`` symbols (numpy's element-wise functions dispatch to CasADi objects in CasADi's
numpy mode, set once below), so the baselines differentiate exactly the model the
simulator integrates. Tests check these functions against the numpy evaluation.

Built CasADi functions are cached per (constants, dt, substeps) with
:func:`functools.lru_cache`, so repeated fits on flights of the same airframe and sample
interval never rebuild them. :func:`compile_functions` turns CasADi functions into C
(CasADi code generation), compiles them with the system C compiler and caches the shared
library on disk.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import casadi as ca

from aeroid.model import _equations as eq
from aeroid.model import _inputs as inputs
from aeroid.model._coefficients import N_COEFFICIENTS
from aeroid.model._compile_clock import compiling
from aeroid.model._dynamics import N_STATE, OUTPUT_CHANNELS, Constants
from aeroid.model._integrate import rk4_stages
from aeroid.model._tables import MachTables

# numpy functions on CasADi symbols return CasADi values (not the legacy behaviour, which
# CasADi 3.8 announces with a FutureWarning); older CasADi versions lack the setting.
with contextlib.suppress(AttributeError):  # pragma: no branch - absent before CasADi 3.8
    ca.GlobalOptions.setNumpyMode(1)

N_OUTPUTS = len(OUTPUT_CHANNELS)


def _state(x) -> eq.State:
    return eq.State(*(x[i] for i in range(N_STATE)))


def _coefficients(theta) -> eq.Coefficients:
    return eq.Coefficients(*(theta[i] for i in range(N_COEFFICIENTS)))


def n_theta(tables: MachTables | None = None) -> int:
    """Length of the coefficient parameters: the coefficients, or the tables' parameters."""
    return N_COEFFICIENTS if tables is None else tables.n_parameters


def coefficients_at(theta, state: eq.State, tables: MachTables | None = None,
                    const: Constants | None = None) -> eq.Coefficients:
    """Return the coefficients of parameters ``theta`` at ``state``.

    Without ``tables`` ``theta`` holds the coefficients; with them, the constants and
    table points of :meth:`aeroid.model.MachTables.parameter_names`, evaluated at the
    state's Mach number (:meth:`aeroid.model.MachTables.at_state`; ``const``: the
    constants whose air temperature gives it, per sample and RK4 stage, with tables
    that take it).
    """
    if tables is None:
        return _coefficients(theta)
    return tables.at_state([theta[i] for i in range(tables.n_parameters)], state, const)


def rhs(x, delta, theta, const: Constants, tables: MachTables | None = None):
    """Return d(state)/dt (a CasADi vector of 9) and the aerodynamic loads (eqs. 2-10).

    Parameters
    ----------
    x : casadi SX/MX or sequence, length 9
        ``[u, v, w, p, q, r, phi, theta, psi]`` [m/s, rad/s, rad].
    delta : scalar symbol or float
        Fin deflection [rad].
    theta : casadi SX/MX or sequence, length 9
        Coefficients in ``aeroid.NAMES`` order (with ``tables``: their parameters,
        :func:`coefficients_at`).
    const : Constants
    tables : MachTables, optional
    """
    state = _state(x)
    loads = eq.aerodynamic_loads(state, coefficients_at(theta, state, tables, const), delta,
                                 const)
    return ca.vertcat(*eq.derivative(state, loads, const, eq.trig(state))), loads


def measurement(x, delta, theta, positions, const: Constants,
                tables: MachTables | None = None):
    """Return the outputs ``[a1 (3), ..., p, q, r]`` (:func:`aeroid.model.equations.outputs`).

    Parameters
    ----------
    x, delta, theta, const, tables
        As in :func:`rhs`.
    positions : casadi vector of length 3 n_triads, or sequence
        ``[x1, y1, z1, x2, y2, z2, ...]`` triad positions from the c.g. [m].
    """
    state = _state(x)
    loads = eq.aerodynamic_loads(state, coefficients_at(theta, state, tables, const), delta,
                                 const)
    flat = positions if isinstance(positions, ca.SX | ca.MX) else ca.vertcat(*positions)
    n_triads = flat.shape[0] // 3
    symbol = type(x) if isinstance(x, ca.SX | ca.MX) else ca.SX
    out = symbol.zeros(len(eq.output_names(n_triads)))
    return eq.outputs(out, state, loads, const, ca.reshape(flat, 3, n_triads).T)


def interval_step(x, theta, end, start, stop, const_a: Constants, const_b: Constants | None,
                  dt: float, substeps: int, tables: MachTables | None = None):
    """Return the state one sample interval later: the pieces of a schedule, RK4 each.

    The same scheme as the numba kernel (:func:`aeroid.model._compiled.integrate_set`):
    piece ``j`` ends at the fraction ``end[j]`` of the interval, the deflection goes
    linearly from ``start[j]`` to ``stop[j]`` within it, and it gets ``substeps`` RK4
    steps; the constants are interpolated linearly from ``const_a`` (the interval's
    start) to ``const_b`` (its end; None: ``const_a`` throughout). A zero-length piece
    is a step of length zero. Each step is :func:`aeroid.model._integrate.rk4_stages`,
    the RK4 step of the numpy backend.
    """
    f_start = 0.0
    for j in range(len(end) if not hasattr(end, "shape") else end.shape[0]):
        length = end[j] - f_start
        h = length * dt / substeps
        d_span = stop[j] - start[j]
        for sub in range(substeps):
            u = (sub / substeps, (sub + 0.5) / substeps, (sub + 1.0) / substeps)
            deltas = [start[j] + d_span * ui for ui in u]
            consts = [const_a] * 3 if const_b is None else [
                inputs.lerp(const_a, const_b, f_start + length * ui) for ui in u]
            x = rk4_stages(lambda y, d, k: rhs(y, d, theta, k, tables)[0], x, h,
                           *zip(deltas, consts, strict=True))
        f_start = end[j]
    return x


def rk4_step(x, delta, theta, const: Constants, dt: float, substeps: int):
    """Return the state after ``substeps`` RK4 steps of ``dt / substeps`` with ``delta`` held."""
    return interval_step(x, theta, [1.0], [delta], [delta], const, None, dt, substeps)


@functools.lru_cache(maxsize=32)
def step_function(const: Constants, dt: float, substeps: int) -> ca.Function:
    """Return the CasADi Function ``step(x (9), theta (9), delta) -> x_next (9)``."""
    x = ca.SX.sym("x", N_STATE)
    theta = ca.SX.sym("theta", N_COEFFICIENTS)
    delta = ca.SX.sym("delta")
    return ca.Function("step", [x, theta, delta],
                       [rk4_step(x, delta, theta, const, dt, substeps)],
                       ["x", "theta", "delta"], ["x_next"])


@functools.lru_cache(maxsize=32)
def measurement_function(const: Constants) -> ca.Function:
    """Return the CasADi Function ``meas(x (9), theta (9), delta, positions (6)) -> y (9)``."""
    x = ca.SX.sym("x", N_STATE)
    theta = ca.SX.sym("theta", N_COEFFICIENTS)
    delta = ca.SX.sym("delta")
    pos = ca.SX.sym("pos", 6)
    return ca.Function("meas", [x, theta, delta, pos],
                       [measurement(x, delta, theta, pos, const)],
                       ["x", "theta", "delta", "pos"], ["y"])


class IntervalSymbols(NamedTuple):
    """Symbols of one sample interval's inputs (:func:`interval_symbols`)."""

    pieces: ca.SX      # (3 S,): end, start, stop of the S pieces
    exo_a: ca.SX       # (7,) or (0,): exogenous row at the interval's start
    exo_b: ca.SX       # (7,) or (0,): at its end


def interval_symbols(n_pieces: int, varying: bool) -> IntervalSymbols:
    """Return fresh symbols for an interval's pieces and exogenous rows."""
    n_exo = len(inputs.EXOGENOUS) if varying else 0
    return IntervalSymbols(ca.SX.sym("pieces", 3 * n_pieces), ca.SX.sym("exo_a", n_exo),
                        ca.SX.sym("exo_b", n_exo))


def interval_step_symbolic(x, theta, sym: IntervalSymbols, const: Constants, dt: float,
                           substeps: int, tables: MachTables | None = None):
    """:func:`interval_step` on the symbols of :func:`interval_symbols`."""
    n_pieces = sym.pieces.shape[0] // 3
    end, start, stop = (sym.pieces[i * n_pieces:(i + 1) * n_pieces] for i in range(3))
    if sym.exo_a.shape[0]:
        return interval_step(x, theta, end, start, stop, inputs.with_exogenous(const, sym.exo_a),
                             inputs.with_exogenous(const, sym.exo_b), dt, substeps, tables)
    return interval_step(x, theta, end, start, stop, const, None, dt, substeps, tables)


def sample_constants(const: Constants, exo) -> Constants:
    """The constants at a sample: ``const`` with the exogenous row ``exo`` (empty: none)."""
    return inputs.with_exogenous(const, exo) if exo.shape[0] else const


def augmented_functions(const: Constants, dt: float, substeps: int, n_pieces: int = 1,
                        varying: bool = False, position_free: tuple[int, ...] = ()
                        ) -> tuple[ca.Function, ...]:
    """Return the augmented-state (18) model of the Kalman filters with exact Jacobians.

    The augmented state is ``z = [x (9), theta (9), d (m)]`` with constant coefficients
    and, for the ``m`` position components named in ``position_free`` (indices into
    ``[x1, y1, z1, x2, y2, z2]``), constant offsets ``d`` from the given positions.

    Returns
    -------
    f : Function ``(z (18 + m), pieces (3 S), exo_a, exo_b) -> (z_next, F)``
        One sample interval (:func:`interval_step`) and its Jacobian ``d z_next / d z``.
    h : Function ``(z, delta, exo, positions (6)) -> (y (9), H (9, 18 + m))``
        Measurement and its Jacobian.
    """
    return _augmented_functions(inputs.normalised(const, varying), float(dt), int(substeps),
                                int(n_pieces), bool(varying), tuple(position_free))


@functools.lru_cache(maxsize=32)
def _augmented_functions(const: Constants, dt: float, substeps: int, n_pieces: int,
                         varying: bool, position_free: tuple[int, ...]
                         ) -> tuple[ca.Function, ...]:
    n_free = len(position_free)
    z = ca.SX.sym("z", N_STATE + N_COEFFICIENTS + n_free)
    sym = interval_symbols(n_pieces, varying)
    delta = ca.SX.sym("delta")
    exo = ca.SX.sym("exo", sym.exo_a.shape[0])
    pos_given = ca.SX.sym("pos", 6)
    x, theta = z[:N_STATE], z[N_STATE:N_STATE + N_COEFFICIENTS]
    offsets = z[N_STATE + N_COEFFICIENTS:]
    z_next = ca.vertcat(interval_step_symbolic(x, theta, sym, const, dt, substeps),
                        z[N_STATE:])
    # dense outputs: the filters read them through numpy buffers (Buffered)
    f = ca.Function("f_aug", [z, *sym], [z_next, ca.densify(ca.jacobian(z_next, z))])
    pos = ca.vertcat(*[pos_given[c] + offsets[position_free.index(c)]
                       if c in position_free else pos_given[c] for c in range(6)])
    y = measurement(x, delta, theta, pos, sample_constants(const, exo))
    h = ca.Function("h_aug", [z, delta, exo, pos_given], [y, ca.densify(ca.jacobian(y, z))])
    return f, h


#: Compiler flags of :func:`compile_functions` (-O1: a third less compile time than -O2
#: for the same speed within 20 % on the output-error sensitivities, measured).
C_FLAGS: tuple[str, ...] = ("-O1", "-fPIC", "-shared")


def cache_dir() -> Path:
    """Return the on-disk cache of compiled models: ``$AEROID_CASADI_CACHE`` or
    ``~/.cache/aeroid/casadi``."""
    env = os.environ.get("AEROID_CASADI_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "aeroid" / "casadi"


def compile_functions(functions: Sequence[ca.Function], name: str
                      ) -> list[ca.Function] | None:
    """Return compiled copies of ``functions`` (one shared library), or None if impossible.

    The C source from :class:`casadi.CodeGenerator` is hashed (with the compiler and
    flags); the library ``<name>_<hash>.so`` is looked up in :func:`cache_dir` and built
    there with ``$CC`` (else ``cc``/``gcc``) when absent: written to a temporary name and
    renamed, so concurrent processes do not see half-written files. Any failure (no
    compiler, compile error, unwritable cache) returns None and the caller keeps
    CasADi's virtual machine, which gives the same numbers.
    """
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not compiler:
        return None
    try:
        with tempfile.TemporaryDirectory() as tmp:
            gen = ca.CodeGenerator(f"{name}.c")
            for fun in functions:
                gen.add(fun)
            gen.generate(tmp + os.sep)
            source = Path(tmp, f"{name}.c").read_bytes()
        digest = hashlib.sha256(source + compiler.encode() + " ".join(C_FLAGS).encode())
        cache = cache_dir()
        library = cache / f"{name}_{digest.hexdigest()[:20]}.so"
        if not library.exists():
            cache.mkdir(parents=True, exist_ok=True)
            with tempfile.TemporaryDirectory(dir=cache) as tmp:
                src = Path(tmp, f"{name}.c")
                src.write_bytes(source)
                out = Path(tmp, library.name)
                # named and timed by the command line; a study leaves it out of the runtime
                with compiling("the C model"):
                    subprocess.run([compiler, *C_FLAGS, str(src), "-o", str(out)],
                                   check=True, capture_output=True, timeout=300)
                os.replace(out, library)
        return [ca.external(fun.name(), str(library)) for fun in functions]
    except (OSError, subprocess.SubprocessError, RuntimeError):
        return None
