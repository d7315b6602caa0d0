"""Air that moves, for the simulator: a steady wind and Dryden turbulence (issue 26).

The wind is the air's velocity over the ground in north-east-down axes [m/s]; the model
takes it as the constants ``wind_n, wind_e, wind_d`` (steady) or as exogenous columns of
the same names (per sample, interpolated linearly within each sample interval:
:data:`aeroid.model.EXOGENOUS`), and its loads see the air-relative velocity.

Turbulence is the Dryden form of MIL-F-8785C, section 3.7.2.3 (also MIL-HDBK-1797,
appendix A, "Dryden form"): a frozen random field crossed at the airspeed ``V``
(Taylor's hypothesis), with the spatial spectra

    Phi_u(W) = sd^2 (2 L / pi) / (1 + (L W)^2),
    Phi_v(W) = Phi_w(W) = sd^2 (L / pi) (1 + 3 (L W)^2) / (1 + (L W)^2)^2,

equal intensities ``sd`` and scale lengths ``L`` in the three components (MIL-F-8785C
above 2000 ft: L = 1750 ft = 533.4 m). In time (``tau = L / V``) they are the outputs of
the shaping filters ``1 / (1 + tau s)`` (longitudinal) and ``(1 + sqrt(3) tau s) /
(1 + tau s)^2`` (transverse) driven by white noise, and their autocorrelations are

    R_u(t) = sd^2 exp(-V t / L),    R_v(t) = R_w(t) = sd^2 (1 - V t / (2 L)) exp(-V t / L).

The generator samples the filters exactly at the sample interval (no discretisation
error): the state-space form of each filter (:func:`scipy.signal.tf2ss`) is scaled to
the variance ``sd^2`` (:func:`scipy.linalg.solve_continuous_lyapunov`), started in its
stationary distribution and stepped with ``Phi = expm(A dt)`` and the exact discrete
process noise ``P - Phi P Phi^T`` (:func:`scipy.signal.dlsim`), so the samples have the
autocovariances above at every lag.

Axes: ``u_g`` along the initial flight path (the initial velocity in NED), ``w_g``
perpendicular to it in the vertical plane (down positive), ``v_g`` completing the
right-handed triad (horizontal); the field is crossed along that path at the constant
initial speed (the window is ~1 s: the speed changes by < 1 %).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from scipy import linalg, signal

from aeroid.errors import AirframeError
from aeroid.model import EXOGENOUS, Constants, exogenous_table, fileform

#: MIL-F-8785C's scale length above 2000 ft [m] (1750 ft).
MIL_SCALE_LENGTH_M = 533.4
#: Keys of the scenario's ``[wind]`` table.
WIND_KEYS = ("north_mps", "east_mps", "down_mps", "turbulence_sd_mps", "scale_length_m")
#: The model's wind columns, north, east, down.
WIND_COLUMNS = ("wind_n", "wind_e", "wind_d")


class Shaping(NamedTuple):
    """One Dryden component sampled at ``dt``: ``x_{k+1} = phi x_k + noise_sqrt w_k``,
    ``gust_k = c x_k``, ``x_0 ~ N(0, stationary)``, ``w_k ~ N(0, I)``."""

    phi: np.ndarray
    noise_sqrt: np.ndarray
    c: np.ndarray
    stationary: np.ndarray


def dryden_autocorrelation(lag_s: Any, *, sd: float, scale_length_m: float,
                           airspeed_mps: float) -> tuple[np.ndarray, np.ndarray]:
    """Return the longitudinal and transverse autocorrelations [m^2/s^2] at ``lag_s`` [s]."""
    xi = np.abs(np.asarray(lag_s, dtype=float)) * airspeed_mps / scale_length_m
    decay = sd * sd * np.exp(-xi)
    return decay, decay * (1.0 - 0.5 * xi)


def shaping_filters(dt: float, *, sd: float, scale_length_m: float,
                    airspeed_mps: float) -> tuple[Shaping, Shaping, Shaping]:
    """Return the exact discrete Dryden filters of ``u_g, v_g, w_g`` (module docstring)."""
    tau = scale_length_m / airspeed_mps
    longitudinal = signal.tf2ss([1.0], [tau, 1.0])
    transverse = signal.tf2ss([math.sqrt(3.0) * tau, 1.0], [tau * tau, 2.0 * tau, 1.0])
    out = []
    for a, b, c, _ in (longitudinal, transverse, transverse):
        p = linalg.solve_continuous_lyapunov(a, -b @ b.T)  # unit white-noise intensity
        c = c * (sd / math.sqrt(float((c @ p @ c.T)[0, 0])))
        phi = linalg.expm(a * dt)
        q = p - phi @ p @ phi.T  # the stationary process's exact one-step noise
        q = 0.5 * (q + q.T)
        values, vectors = np.linalg.eigh(q)
        out.append(Shaping(phi, vectors * np.sqrt(np.clip(values, 0.0, None)), c, p))
    return out[0], out[1], out[2]


def path_axes(velocity_ned: np.ndarray) -> np.ndarray:
    """Return the unit vectors of ``u_g, v_g, w_g`` in NED as rows (module docstring)."""
    e_u = np.asarray(velocity_ned, dtype=float) / np.linalg.norm(velocity_ned)
    e_v = np.cross([0.0, 0.0, 1.0], e_u)  # horizontal, to the right of the path
    if np.linalg.norm(e_v) < 1e-9:  # a vertical path: "to the right" of flying north
        e_v = np.array([0.0, 1.0, 0.0])
    e_v /= np.linalg.norm(e_v)
    return np.array([e_u, e_v, np.cross(e_u, e_v)])


@dataclass(frozen=True, kw_only=True)
class Wind:
    """The air the simulated flight crosses.

    Attributes
    ----------
    steady_ned_mps : tuple of 3 float
        The steady wind (north, east, down) [m/s]: the air's velocity over the ground.
    turbulence_sd_mps : float
        Dryden intensity ``sd`` of each component [m/s]; 0: no turbulence.
    scale_length_m : float
        Dryden scale length ``L`` [m] (default MIL-F-8785C's 533.4 m).
    """

    steady_ned_mps: tuple[float, float, float] = (0.0, 0.0, 0.0)
    turbulence_sd_mps: float = 0.0
    scale_length_m: float = MIL_SCALE_LENGTH_M

    def __post_init__(self) -> None:
        steady = fileform.numbers(self.steady_ned_mps, 3, "wind: steady_ned_mps")
        object.__setattr__(self, "steady_ned_mps", tuple(steady))
        sd = fileform.number(self.turbulence_sd_mps, "wind: turbulence_sd_mps")
        length = fileform.number(self.scale_length_m, "wind: scale_length_m")
        if not (math.isfinite(sd) and sd >= 0):
            raise AirframeError(f"wind: turbulence_sd_mps must be >= 0, got {sd:g}")
        if not (math.isfinite(length) and length > 0):
            raise AirframeError(f"wind: scale_length_m must be positive, got {length:g}")
        object.__setattr__(self, "turbulence_sd_mps", sd)
        object.__setattr__(self, "scale_length_m", length)

    @property
    def turbulent(self) -> bool:
        """Whether the wind has turbulence (then it varies per sample)."""
        return self.turbulence_sd_mps > 0

    def constants(self, const: Constants) -> Constants:
        """Return ``const`` with the steady wind."""
        return const._replace(**dict(zip(WIND_COLUMNS, self.steady_ned_mps, strict=True)))

    def gusts(self, n: int, dt: float, velocity_ned: np.ndarray,
              rng: np.random.Generator) -> np.ndarray:
        """Return Dryden gusts at ``n`` samples ``dt`` apart, NED, shape (n, 3) [m/s].

        ``velocity_ned``: the initial velocity over the ground [m/s] (the airspeed is its
        norm less the steady wind; the path axes are its direction). Each component in
        turn draws its stationary start, then its ``n`` driving-noise vectors, from ``rng``.
        """
        air = np.asarray(velocity_ned, dtype=float) - np.array(self.steady_ned_mps)
        filters = shaping_filters(dt, sd=self.turbulence_sd_mps,
                                  scale_length_m=self.scale_length_m,
                                  airspeed_mps=float(np.linalg.norm(air)))
        path = np.empty((n, 3))
        for j, f in enumerate(filters):
            x0 = np.linalg.cholesky(f.stationary) @ rng.standard_normal(f.phi.shape[0])
            w = rng.standard_normal((n, f.phi.shape[0]))
            _, y, _ = signal.dlsim((f.phi, f.noise_sqrt, f.c, np.zeros((1, f.phi.shape[0])),
                                    dt), w, x0=x0)
            path[:, j] = np.ravel(y)
        return path @ path_axes(air)

    def exogenous(self, const: Constants, gusts_ned: np.ndarray) -> np.ndarray:
        """Return the model's exogenous table with the wind steady + ``gusts_ned`` (n, 3)."""
        n = gusts_ned.shape[0]
        table = exogenous_table(self.constants(const), n)
        for j, name in enumerate(WIND_COLUMNS):
            table[:, EXOGENOUS.index(name)] += gusts_ned[:, j]
        return table

    def describe(self) -> dict[str, Any]:
        """The scenario's ``[wind]`` table of this wind."""
        return {"north_mps": self.steady_ned_mps[0], "east_mps": self.steady_ned_mps[1],
                "down_mps": self.steady_ned_mps[2],
                "turbulence_sd_mps": self.turbulence_sd_mps,
                "scale_length_m": self.scale_length_m}


def wind_from_table(table: Any, where: str) -> Wind:
    """Return the :class:`Wind` of a scenario's ``[wind]`` table (keys :data:`WIND_KEYS`)."""
    table = fileform.check_table(table, where)
    fileform.check_keys(table, WIND_KEYS, where)
    values = {k: fileform.number(table[k], f"{where} {k}") for k in table}
    try:
        north, east, down = (values.get(k, 0.0) for k in WIND_KEYS[:3])
        return Wind(steady_ned_mps=(north, east, down),
                    turbulence_sd_mps=values.get("turbulence_sd_mps", 0.0),
                    scale_length_m=values.get("scale_length_m", MIL_SCALE_LENGTH_M))
    except AirframeError as exc:
        raise AirframeError(f"{where}: {str(exc).removeprefix('wind: ')}") from None
