"""Air data as measured outputs of output-error: a probe's alpha, beta, airspeed (issue 26).

``air_data = "measured"`` (or ``"auto"`` on a flight that has air data) appends the log's
air-data channels to the record model's outputs, at every sample:

- **Prediction**: the model's own air-data definition. The states (and their exact
  sensitivities) are propagated through the model's RK4 interval step
  (:func:`aeroid.model.symbolic.interval_step_symbolic`) with the steady wind of
  ``estimate_wind`` added by :func:`aeroid.model.with_wind_symbols`; at each sample the
  air-relative velocity is :func:`aeroid.model.equations.air_velocity` plus the
  rotation-induced flow at the probe, ``omega x r_probe``, and ``V, alpha, beta`` are
  :func:`aeroid.model.equations.air_data` of it (eqs. 14-16): nothing written twice.
- **Calibration** (option ``air_data_calibration``): the logged flow angles are
  ``(1 + k) alpha + b`` and ``(1 + k) beta + b`` with a factor ``k`` (upwash, a vane's
  gain) and an offset ``b`` [rad] per angle, estimated with the coefficients (no prior,
  start 0; exact sensitivities). The airspeed is taken as calibrated: a factor on it
  trades with the wind along the path, which it is there to fix.
- **Probe position**: ``metadata["air_data_probe"]["position_m"]`` (body axes from the
  c.g. [m], the sidecar's metadata); without it, the c.g., said in the result's notice.
- **Noise**: one variance per air-data channel, re-estimated from the residuals with the
  IMU's (the relaxation), reported as the probe's noise sd with its standard error
  ``sd / sqrt(2 n)`` (:mod:`baselines._oe_airdata_report`).

A channel given is used or refused: the flight's logged angles are outputs when they
differ from the inertial ones (:func:`aeroid.estimation.has_air_angles`), its
``airspeed`` when logged; ``"inertial"`` (the default: the option adds outputs and
parameters) leaves them out and the result says it ignores them.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Any, Literal

import casadi as ca
import numpy as np

import aeroid
from aeroid.estimation import AIR_DATA_CHOICES, has_air_angles, has_airspeed
from aeroid.flights import Flight
from aeroid.model import (
    EXOGENOUS,
    N_STATE,
    OUTPUT_CHANNELS,
    equations,
    symbolic,
    with_wind_symbols,
)

#: The option ``air_data_calibration``: which flow-angle calibration parameters are
#: estimated (a factor and an offset per angle, or either, or none).
CALIBRATIONS: tuple[str, ...] = ("none", "offset", "factor", "factor+offset")
#: Output-error's ``air_data`` values (not equation-error's ``reconstruction``).
OE_CHOICES: tuple[str, ...] = ("inertial", "auto", "measured")
#: Scales of the calibration parameters: a factor of order 1e-2, an offset of order
#: 1e-3 rad (0.06 deg).
FACTOR_SCALE = 0.01
OFFSET_SCALE_RAD = 1e-3
#: The metadata key of the probe and its position.
PROBE_KEY = aeroid.flights.AIR_DATA_PROBE_KEY


@dataclass(frozen=True, kw_only=True)
class AirDataOption:
    """Output-error's air-data options (a base of :class:`baselines.output_error.
    OutputErrorEstimator`).

    Attributes
    ----------
    air_data : {"inertial", "auto", "measured"}
        ``"measured"``: the flight's air data (logged ``alpha``, ``beta`` that differ from
        the inertial ones; a logged ``airspeed``) as measured outputs at every sample, or
        a one-line refusal of a flight without them; ``"auto"``: those outputs when the
        flight has air data; ``"inertial"`` (default): left out, and said ignored
        (:mod:`baselines._oe_airdata`).
    air_data_calibration : {"none", "offset", "factor", "factor+offset"}
        Flow-angle calibration estimated with the coefficients (default
        ``"factor+offset"``): ``logged = (1 + k) angle + b`` per angle.
    """

    air_data: Literal["inertial", "auto", "measured"] = "inertial"
    air_data_calibration: Literal["none", "offset", "factor", "factor+offset"] = \
        "factor+offset"


def check_air_data_options(est: Any) -> None:
    """Raise ValueError (one line) for an air-data option out of its range."""
    if est.air_data not in OE_CHOICES:
        raise ValueError(f"air_data must be one of {', '.join(OE_CHOICES)}, "
                         f"got {est.air_data!r}" + (" (output-error estimates the wind "
                                                    "itself: estimate_wind)" if
                                                    est.air_data in AIR_DATA_CHOICES else ""))
    if est.air_data_calibration not in CALIBRATIONS:
        raise ValueError(f"air_data_calibration must be one of {', '.join(CALIBRATIONS)}, "
                         f"got {est.air_data_calibration!r}")


def air_channels(flight: Flight) -> tuple[str, ...]:
    """The flight's air-data channels usable as outputs: ``alpha, beta`` (when they differ
    from the inertial ones) and ``airspeed`` (when logged)."""
    return (("alpha", "beta") if has_air_angles(flight) else ()) + (
        ("airspeed",) if has_airspeed(flight) else ())


def used_channels(est: Any, flight: Flight) -> tuple[str, ...]:
    """The air-data outputs of a fit of ``flight`` by ``est`` (empty: none).

    Raises
    ------
    FlightError
        ``air_data = "measured"`` on a flight without air data.
    """
    if est.air_data == "inertial":
        return ()
    channels = air_channels(flight)
    if est.air_data == "measured" and not channels:
        where = flight.metadata.get("source", "flight")
        raise aeroid.FlightError(f"output-error: air_data = 'measured' but {where} has no "
                                 "airspeed channel and no logged alpha and beta apart from "
                                 "the inertial atan(w/u), asin(v/V)")
    return channels


def calibration_names(est: Any, channels: tuple[str, ...]) -> list[str]:
    """Names of the calibration parameters (factors, then offsets, of the angles used)."""
    angles = [c for c in ("alpha", "beta") if c in channels]
    kind = est.air_data_calibration
    names = [f"{a}_factor" for a in angles] if "factor" in kind else []
    return names + ([f"{a}_offset_rad" for a in angles] if "offset" in kind else [])


def calibration_scales(names: list[str]) -> np.ndarray:
    """The scales of the calibration parameters ``names``."""
    return np.array([FACTOR_SCALE if n.endswith("_factor") else OFFSET_SCALE_RAD
                     for n in names])


def probe_position(flight: Flight) -> tuple[np.ndarray, str]:
    """The probe's position [m] and how it was found
    (:func:`aeroid.flights.air_data_probe_position`, written once for every method)."""
    return aeroid.flights.air_data_probe_position(flight)


def _probe_outputs(x: Any, const: Any, r: Any, cal: Any, channels: tuple[str, ...],
                   calibration: tuple[str, ...]) -> Any:
    """The air-data outputs of state ``x`` (CasADi) with constants ``const`` (the wind in
    them), probe at ``r``, calibration parameters ``cal`` named ``calibration``."""
    state = equations.State(*(x[i] for i in range(N_STATE)))
    ua, va, wa = equations.air_velocity(state, const)
    p, q, rr = state.p, state.q, state.r
    speed, alpha, beta = equations.air_data(ua + q * r[2] - rr * r[1],  # + omega x r
                                            va + rr * r[0] - p * r[2],
                                            wa + p * r[1] - q * r[0])
    raw = {"alpha": alpha, "beta": beta, "airspeed": speed}
    out = dict(raw)
    for j, name in enumerate(calibration):  # logged = (1 + k) angle + b
        angle = name.split("_")[0]
        out[angle] = out[angle] + cal[j] * (raw[angle] if name.endswith("_factor") else 1.0)
    return ca.vertcat(*[out[c] for c in channels])


class AirDataModel:
    """The record model with the air-data outputs appended, shape (n, m + len(channels)).

    Parameters ``p``: the record model's (``base.scale``), then the calibration
    parameters. Everything else (layout, the delay's smooth region) is the record
    model's.
    """

    def __init__(self, base: Any, channels: tuple[str, ...], calibration: list[str],
                 probe: np.ndarray) -> None:
        self.base, self.channels, self.calibration = base, channels, tuple(calibration)
        self.probe = np.asarray(probe, dtype=float)
        self.n_base = base.scale.size
        self.scale = np.concatenate([base.scale, calibration_scales(list(calibration))])
        n = base.t.size
        mask = np.ones((n, len(OUTPUT_CHANNELS)), bool) if base.mask is None else base.mask
        self.mask = np.hstack([mask, np.ones((n, len(channels)), bool)])
        self.n_theta, self.n_x0 = base.n_theta, len(base.x0_free)
        self.i_wind = base.n_graph - 3 if base.wind_free else None  # first wind parameter
        self.n_s = self.n_theta + self.n_x0 + 3  # what moves the states: theta, x0, wind
        self.varying = base.exogenous is not None
        const = base.const
        if self.varying:  # as the record: per-sample values replace these
            const = const._replace(**dict.fromkeys(EXOGENOUS, 0.0))
        self.const = const
        self._graphs: dict[int, tuple[ca.Function, ca.Function, ca.Function]] = {}

    def __getattr__(self, name: str) -> Any:
        return getattr(self.base, name)

    def _graph(self, n_pieces: int) -> tuple[ca.Function, ca.Function, ca.Function]:
        """The states with sensitivities over the record, the states alone, and the
        air-data outputs with their Jacobians in the state, wind and calibration."""
        if n_pieces in self._graphs:
            return self._graphs[n_pieces]
        x = ca.SX.sym("x", N_STATE)
        sens = ca.SX.sym("S", N_STATE, self.n_s)
        theta = ca.SX.sym("theta", self.n_theta)
        wind = ca.SX.sym("wind", 3)
        sym = symbolic.interval_symbols(n_pieces, self.varying)
        dt = float(self.base.t[1] - self.base.t[0])
        const_w, sym_w, row = with_wind_symbols(self.const, sym, wind)
        x_next = symbolic.interval_step_symbolic(x, theta, sym_w, const_w, dt,
                                                 self.base.substeps)
        seeds = ca.vertcat(sens, ca.horzcat(ca.SX.eye(self.n_theta),
                                            ca.SX.zeros(self.n_theta, self.n_s - self.n_theta)),
                           ca.horzcat(ca.SX.zeros(3, self.n_s - 3), ca.SX.eye(3)))
        s_next = ca.jtimes(x_next, ca.vertcat(x, theta, wind), seeds)
        exo = ca.SX.sym("exo", sym.exo_a.shape[0])
        cal = ca.SX.sym("cal", len(self.calibration))
        r = ca.SX.sym("r", 3)
        y = _probe_outputs(x, symbolic.sample_constants(const_w, exo + row), r, cal,
                           self.channels, self.calibration)
        tag = hashlib.sha256(repr((tuple(self.const), dt, self.base.substeps, self.n_s,
                                   n_pieces, self.varying, self.channels,
                                   self.calibration)).encode()).hexdigest()[:12]
        funcs = [ca.Function(f"air_step_{tag}", [x, sens, theta, wind, *sym], [x_next, s_next]),
                 ca.Function(f"air_plain_{tag}", [x, theta, wind, *sym], [x_next]),
                 ca.Function(f"air_out_{tag}", [x, wind, exo, r, cal],
                             [y] + [ca.densify(ca.jacobian(y, v)) for v in (x, wind, cal)])]
        if self.base.compiled_requested:
            funcs = symbolic.compile_functions(funcs, f"aeroid_airdata_{tag}") or funcs
        m = self.base.t.size - 1
        self._graphs[n_pieces] = (funcs[0].mapaccum("air_record", m, 2),
                                  funcs[1].mapaccum("air_states", m),
                                  funcs[2].map(self.base.t.size))
        return self._graphs[n_pieces]

    def _physical(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Coefficients, initial state, wind [m/s] and calibration at scaled ``p``."""
        base, scale = self.base, self.scale
        theta = p[:self.n_theta] * scale[:self.n_theta]
        x0 = base.x0.copy()
        free = slice(self.n_theta, self.n_theta + self.n_x0)
        x0[list(base.x0_free)] += p[free] * scale[free]
        wind = (np.zeros(3) if self.i_wind is None
                else p[self.i_wind:self.i_wind + 3] * scale[self.i_wind:self.i_wind + 3])
        cal = p[self.n_base:] * scale[self.n_base:]
        return theta, x0, wind, cal

    def _air(self, p: np.ndarray, jacobian: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """The air-data outputs (n, k) and, with ``jacobian``, ``dy/dp`` (k, n, n_p)."""
        base, n = self.base, self.base.t.size
        theta, x0, wind, cal = self._physical(p)
        record = base.record(base.tau(p))
        _, pieces, exo = record.symbolic_inputs()
        step, plain, out = self._graph(record.n_pieces)
        m = n - 1
        rep = [np.tile(v[:, None], (1, m)) for v in (theta, wind)]
        if not jacobian:
            xs = np.hstack([x0[:, None], np.asarray(plain(x0, *rep, pieces, exo[:, :m],
                                                          exo[:, 1:]))])
        else:
            s0 = np.zeros((N_STATE, self.n_s))
            s0[list(base.x0_free), range(self.n_theta, self.n_theta + self.n_x0)] = 1.0
            xk, sk = step(x0, s0, *rep, pieces, exo[:, :m], exo[:, 1:])
            xs = np.hstack([x0[:, None], np.asarray(xk)])
            ss = np.concatenate([s0[:, None, :], np.asarray(sk).reshape(N_STATE, m, self.n_s)],
                                axis=1)  # (9, n, n_s)
        k = len(self.channels)
        y, dx, dw, dc = out(xs, np.tile(wind[:, None], (1, n)), exo,
                            np.tile(self.probe[:, None], (1, n)),
                            np.tile(cal[:, None], (1, n)))
        y = np.asarray(y).T.copy()  # (n, k)
        if not jacobian:
            return y, None
        dx = np.asarray(dx).reshape(k, n, N_STATE)  # block j: dy_j / dx
        J = np.zeros((k, n, p.size))
        dstate = np.einsum("knx,xns->kns", dx, ss)  # (k, n, n_s) physical
        scale = self.scale
        J[:, :, :self.n_theta] = dstate[:, :, :self.n_theta] * scale[:self.n_theta]
        free = slice(self.n_theta, self.n_theta + self.n_x0)
        J[:, :, free] = dstate[:, :, free] * scale[free]
        if self.i_wind is not None:
            dwind = dstate[:, :, -3:] + np.asarray(dw).reshape(k, n, 3)
            J[:, :, self.i_wind:self.i_wind + 3] = dwind * scale[self.i_wind:self.i_wind + 3]
        if self.calibration:
            J[:, :, self.n_base:] = (np.asarray(dc).reshape(k, n, len(self.calibration))
                                     * scale[self.n_base:])
        return y, J

    # OutputModel -------------------------------------------------------------------
    def outputs(self, p: np.ndarray) -> np.ndarray:
        """Return ``y(p)``, shape (n, m + k): the IMU's outputs, then the air data."""
        return np.hstack([self.base.outputs(p[:self.n_base]), self._air(p, False)[0]])

    def outputs_jacobian(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return ``y(p)`` (n, m + k) and ``dy/dp`` (m + k, n, n_p)."""
        y, J = self.base.outputs_jacobian(p[:self.n_base])
        J = np.concatenate([J, np.zeros(J.shape[:2] + (p.size - self.n_base,))], axis=2)
        ya, Ja = self._air(p, True)
        return np.hstack([y, ya]), np.concatenate([J, Ja], axis=0)
