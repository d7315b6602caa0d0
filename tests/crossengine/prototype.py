"""Research prototype: aeroid's equations with the model inputs issue 10 asks for.

Not part of aeroid: a numpy model that measures what each input would change before the
lead builds it. It integrates aeroid's own equations (:func:`aeroid.model.state_derivative`,
:func:`aeroid.model.accelerometers`) with fixed-step RK4, batched over coefficient sets,
and takes:

* the fin deflection as a function of time (:class:`Inputs.delta_mode`):
  ``"events"`` (piecewise constant with given switch instants; every RK4 step that
  contains a switch is split at it, so the switch is not approximated), which also
  expresses ``"hold"`` (switch at the logged sample where the deflection changed, what
  aeroid does today) and ``"midpoint"`` (halfway between the two samples); or ``"law"``
  (the fin law evaluated on the model's own roll angle, each switch located inside the
  RK4 step by a cubic Hermite interpolation of phi and bisection, the step then split);
* an input time delay (``delay_s``): added to every switch instant (events), or the
  time from a zero of the switching function to the switch (law; the switches of the
  first ``delay_s`` of the window, which the law cannot know, come from the events
  given);
* per-sample density and gravity, linearly interpolated to the RK4 stage times, or
  constants.

:func:`fit_output_error` is an output-error fit in the manner of aeroid's (maximum
likelihood with the relaxation of R, Gauss-Newton with Levenberg damping, Cramér-Rao
standard errors, the initial p, q, r estimated) whose Jacobian is a central finite
difference of the batched simulation. :func:`equation_error_per_sample_density` is
aeroid's equation-error with the regressors evaluated at each sample's density.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from aeroid.flights import Flight
from aeroid.model import FinLaw, accelerometers, constants, regressors
from baselines import _common

from . import _kernel

#: Relative finite-difference step of the coefficients (central differences).
FD_REL_STEP = 1e-6
#: Finite-difference step of the initial rates [rad/s] and of the delay [s].
FD_RATE_STEP = 1e-6
FD_DELAY_STEP = 1e-7


@dataclass(frozen=True, kw_only=True)
class Inputs:
    """What the model is given besides the coefficients and the initial state.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Sample times [s] (uniform).
    delta_mode : {"events", "law"}
    switch_times, switch_values : ndarray, shape (m,)
        Switch instants [s] and the deflection after each [rad]: all of them (events), or
        at least those of the first ``delay_s`` of the window (law).
    initial_delta : float
        The deflection before the first switch [rad] (events; law with a delay).
    relay : FinLaw or None
        Law: the fin law.
    delay_s : float
        Input delay [s]: added to every switch instant (events), or from a zero of the
        switching function to the switch (law).
    rho : float or ndarray, shape (n,)
        Density [kg/m^3]: a constant or per sample.
    gravity : float or ndarray, shape (n,)
        Gravity [m/s^2]: a constant or per sample.
    substeps : int
        RK4 steps per sample interval (before splitting at switches).
    """

    t: np.ndarray
    delta_mode: Literal["events", "law"] = "events"
    switch_times: np.ndarray = field(default_factory=lambda: np.empty(0))
    switch_values: np.ndarray = field(default_factory=lambda: np.empty(0))
    initial_delta: float = 0.0
    relay: FinLaw | None = None
    delay_s: float = 0.0
    rho: float | np.ndarray = 1.0
    gravity: float | np.ndarray = 9.80665
    substeps: int = 2

    def replace(self, **changes) -> Inputs:
        """Return a copy with fields replaced."""
        return dataclasses.replace(self, **changes)

    def at(self, name: str, time: float | np.ndarray) -> float | np.ndarray:
        """Return ``rho`` or ``gravity`` at ``time`` (linear interpolation of samples)."""
        value = getattr(self, name)
        if np.ndim(value) == 0:
            return float(value)
        return np.interp(time, self.t, value)


def logged_events(flight: Flight, where: Literal["hold", "midpoint"]) -> dict:
    """Return event fields from the logged ``delta``: switch at the sample or halfway."""
    t, delta = flight.t, flight["delta"]
    k = np.flatnonzero(np.diff(delta) != 0.0) + 1
    times = t[k] if where == "hold" else 0.5 * (t[k - 1] + t[k])
    return {"switch_times": times, "switch_values": delta[k], "initial_delta": float(delta[0])}


def _kernel_constants(flight: Flight) -> np.ndarray:
    af = flight.airframe
    return np.array([af.area_m2, af.diameter_m, af.mass_kg, af.ix_kgm2, af.iy_kgm2,
                     af.iz_kgm2, af.thrust_n])


def _samples(inputs: Inputs, name: str) -> np.ndarray:
    value = getattr(inputs, name)
    return np.broadcast_to(np.asarray(value, dtype=float), inputs.t.shape).copy()


def simulate(flight: Flight, inputs: Inputs, theta: np.ndarray, x0: np.ndarray,
             output_delta: np.ndarray | None = None, return_delta: bool = False):
    """Integrate aeroid's model over the flight's samples (compiled, :mod:`._kernel`).

    Parameters
    ----------
    flight : Flight
        Supplies the airframe (constants, sensor positions).
    inputs : Inputs
    theta : ndarray, shape (B, 9)
    x0 : ndarray, shape (B, 9)
        State at ``inputs.t[0]``.
    output_delta : ndarray, shape (n,), optional
        Deflection for the output equation at the samples (default: the model's own).
        The delay's finite difference uses the unshifted one: the model's deflection at a
        sample jumps when a shifted switch crosses the sample.

    return_delta : bool
        Return only the first trajectory's deflection at the samples, shape (n,).

    Returns
    -------
    states : ndarray, shape (B, n, 9)
    outputs : ndarray, shape (B, n, 9)
        ``[ax1, ay1, az1, ax2, ay2, az2, p, q, r]`` at each sample (eq. 28 with the
        deflection and density at the sample).
    """
    t = inputs.t
    n = t.size
    dt = float((t[-1] - t[0]) / (n - 1))
    theta = np.ascontiguousarray(theta, dtype=float)
    x0 = np.ascontiguousarray(x0, dtype=float)
    order = np.argsort(inputs.switch_times, kind="stable")
    ev_t = np.asarray(inputs.switch_times, dtype=float)[order]
    ev_v = np.asarray(inputs.switch_values, dtype=float)[order]
    if inputs.delta_mode == "law":
        relay = inputs.relay
        law = np.array([relay.command_amplitude, np.radians(relay.command_phase_deg),
                        relay.delta_max_rad, inputs.delay_s])
        early = ev_t < t[0] + inputs.delay_s  # switches the delayed law cannot know
        mode, ev_t, ev_v = 1, ev_t[early], ev_v[early]
    else:
        mode, ev_t, law = 0, ev_t + inputs.delay_s, np.zeros(4)
    states, deltas = _kernel.integrate(
        x0, theta, _kernel_constants(flight), float(t[0]), dt, n, int(inputs.substeps),
        _samples(inputs, "rho"), _samples(inputs, "gravity"), mode, ev_t, ev_v,
        float(inputs.initial_delta), law)
    if return_delta:
        return deltas[0].copy()
    if output_delta is not None:
        deltas = np.broadcast_to(output_delta, deltas.shape)
    const = constants(flight.airframe)._replace(rho=_samples(inputs, "rho")[None, :])
    acc = accelerometers(states, deltas, theta[:, None, :], const,
                         flight.airframe.accel_positions).reshape(len(theta), n, 6)
    return states, np.concatenate([acc, states[:, :, 3:6]], axis=2)


@dataclass(frozen=True)
class FitResult:
    """An output-error prototype fit: estimates, Cramér-Rao sd, and the fit's quality."""

    theta: np.ndarray
    stderr: np.ndarray
    delay_s: float
    delay_sd: float
    x0_rates: np.ndarray
    iterations: int
    residual_rms: np.ndarray
    converged: bool


def law_delay_guess(flight: Flight, relay: FinLaw) -> float:
    """Return a starting delay [s] for the law input: logged switches minus the law's.

    The law's zeros come from the measured roll angle (linear interpolation of the
    switching function between samples, accurate to ~1e-5 s at 500 Hz); each logged
    switch (a change of ``delta`` between two samples, taken at their midpoint, +-1 ms) is
    paired with the last zero of the same direction before the later of the two samples.
    The mean difference is unbiased; its error is about 0.6 ms / sqrt(number of
    switches). Never negative.
    """
    t, delta = flight.t, flight["delta"]
    s = relay.switching_function(flight["phi"])
    k = np.flatnonzero((s[1:] >= 0.0) != (s[:-1] >= 0.0))
    zeros = t[k] + (t[k + 1] - t[k]) * s[k] / (s[k] - s[k + 1])
    rising = s[k + 1] >= 0.0
    j = np.flatnonzero(np.diff(delta) != 0.0)
    logged = 0.5 * (t[j] + t[j + 1])
    up = delta[j + 1] > delta[j]
    gaps = []
    for when, later, direction in zip(logged, t[j + 1], up, strict=True):
        before = zeros[(zeros <= later) & (rising == direction)]
        if before.size:
            gaps.append(when - before[-1])
    return max(float(np.mean(gaps)), 0.0) if gaps else 0.0


def fit_output_error(flight: Flight, inputs: Inputs, *, theta0: np.ndarray | None = None,
                     estimate_delay: bool = False, max_iterations: int = 30,
                     tol: float = 1e-10) -> FitResult:
    """Fit the nine coefficients (plus p0, q0, r0 and optionally a delay) by output error.

    Starts from the airframe prior (or ``theta0``), the first measured state and the
    input's delay (with ``estimate_delay`` and the law input: :func:`law_delay_guess`;
    the law's delay stays >= 0). Stops when the largest relative parameter change is
    below ``tol`` or no step lowers the cost.
    """
    z = _common.measurements(flight)
    x0_meas = flight.states()[0]
    theta = np.array(flight.airframe.prior_vector() if theta0 is None else theta0, float)
    law = inputs.delta_mode == "law"
    delay0 = law_delay_guess(flight, inputs.relay) if law and estimate_delay else inputs.delay_s
    params = np.concatenate([theta, x0_meas[3:6], [delay0]])
    free = list(range(12)) + ([12] if estimate_delay else [])
    floor = 1e-24 * np.mean(z * z, axis=0) + 1e-300

    def steps(p):
        s = np.empty(13)
        s[:9] = FD_REL_STEP * np.maximum(np.abs(p[:9]), 1e-3)
        s[9:12] = FD_RATE_STEP
        s[12] = FD_DELAY_STEP
        return s

    def run(p_batch):
        x0 = np.repeat(x0_meas[None], len(p_batch), axis=0)
        x0[:, 3:6] = p_batch[:, 9:12]
        out = []
        nominal = None
        for delay in np.unique(p_batch[:, 12]):  # one input per delay value
            sel = p_batch[:, 12] == delay
            shifted = delay != p_batch[0, 12]
            if shifted and nominal is None:
                nominal = simulate(flight, inputs.replace(delay_s=float(p_batch[0, 12])),
                                   p_batch[:1, :9], x0[:1], return_delta=True)
            _, y = simulate(flight, inputs.replace(delay_s=float(delay)), p_batch[sel, :9],
                            x0[sel], output_delta=nominal if shifted else None)
            out.append((sel, y))
        y_all = np.empty((len(p_batch), *z.shape))
        for sel, y in out:
            y_all[sel] = y
        return y_all

    def residuals_jacobian(p):
        s = steps(p)
        batch, widths = [p], []
        for j in free:
            plus, minus = p.copy(), p.copy()
            plus[j] += s[j]
            if not (law and j == 12 and p[j] < s[j]):  # the law's delay stays >= 0
                minus[j] -= s[j]
            batch += [plus, minus]
            widths.append(plus[j] - minus[j])
        y = run(np.array(batch))
        e = z - y[0]
        J = np.stack([(y[1 + 2 * i] - y[2 + 2 * i]) / widths[i] for i in range(len(free))],
                     axis=-1)
        return e, J

    e, J = residuals_jacobian(params)
    r_diag = np.maximum(np.mean(e * e, axis=0), floor)
    damping, converged, iterations = 1e-6, False, 0
    for iteration in range(1, max_iterations + 1):
        iterations = iteration
        w = 1.0 / np.sqrt(r_diag)
        Jw = (J * w[None, :, None]).reshape(-1, len(free))
        ew = (e * w[None, :]).reshape(-1)
        M, g = Jw.T @ Jw, Jw.T @ ew
        cost = 0.5 * float(ew @ ew)
        diag = np.diag(M).copy()
        while True:
            step = np.linalg.solve(M + damping * np.diag(diag), g)
            trial = params.copy()
            trial[free] += step
            if law:
                trial[12] = max(trial[12], 0.0)
            e_new = z - run(trial[None])[0]
            if 0.5 * float(np.sum(e_new**2 / r_diag)) <= cost * (1 + 1e-12):
                break
            damping *= 10.0
            if damping > 1e8:
                break
        if damping > 1e8:
            converged = True  # numerical minimum
            break
        damping = max(damping / 10.0, 1e-12)
        rel = np.abs(step) / np.maximum(np.abs(params[free]), 1e-3)
        params = trial
        e, J = residuals_jacobian(params)
        r_diag = np.maximum(np.mean(e * e, axis=0), floor)
        if float(np.max(rel)) < tol:
            converged = True
            break
    w = 1.0 / np.sqrt(r_diag)
    Jw = (J * w[None, :, None]).reshape(-1, len(free))
    cov = np.linalg.pinv(Jw.T @ Jw)
    sd = np.sqrt(np.abs(np.diag(cov)))
    return FitResult(theta=params[:9], stderr=sd[:9], delay_s=float(params[12]),
                     delay_sd=float(sd[12]) if estimate_delay else 0.0,
                     x0_rates=params[9:12], iterations=iterations,
                     residual_rms=np.sqrt(np.mean(e * e, axis=0)), converged=converged)


def equation_error_per_sample_density(flight: Flight, rho: np.ndarray | None = None
                                      ) -> np.ndarray:
    """aeroid's two-step equation-error with the regressors at each sample's density.

    ``rho`` (n,) [kg/m^3]; None gives aeroid's constant airframe density (today's fit).
    """
    from aeroid import estimation as rc
    from baselines.equation_error import solve_subproblems

    rec = rc.reconstruct(flight)
    const = constants(flight.airframe)
    if rho is not None:
        const = const._replace(rho=np.asarray(rho, dtype=float))
    X = rc.smooth(regressors(flight.states(), flight["delta"], const), axis=0)
    theta, *_ = solve_subproblems(X, rec.fm_smooth, rc.estimate_noise_sd(rec.fm))
    return theta
