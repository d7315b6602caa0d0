"""The filter-error method: maximum likelihood with an extended Kalman filter in the loop.

For a flight in turbulence (issue 26; Maine & Iliff, NASA RP-1168, ch. 5; Jategaonkar,
*Flight Vehicle System Identification*, ch. 5, FVSysID's ``ml_fem``). Output-error
integrates the model open loop and so needs still air (or a steady wind): gusts move the
measured loads away from any deterministic prediction and the fit check refuses it. Here
a Kalman filter follows the gusts and the likelihood is that of its innovations.

- **Model**: the model's state plus the wind the loads see, three NED components: a
  mean of zero (still air) and a gust per component, a
  first-order Gauss-Markov process (Dryden's first-order approximation, time constant
  ``L / V``, intensity ``sigma``; :mod:`baselines._fem_filter`). The gusts are in NED,
  not body axes: the airframe rolls at ~51 rad/s and a gust fixed in the air turns in body
  axes at that rate, so the filter's gain is time-varying (an EKF, exact CasADi
  Jacobians; :mod:`baselines._fem_model`). ``gust_model = "dryden"``: the simulator's
  Dryden shaping filters (transverse second order) as the gust states instead
  (:mod:`baselines._fem_dryden`).
- **Parameters**: the free coefficients (held ones and priors through
  :class:`aeroid.estimation.CoefficientSpec`) and ``log sigma``. Measurement noise:
  :mod:`baselines._fem_setup`. A steady wind is a parameter only with ``estimate_wind``
  (:mod:`baselines._fem_wind`); by default the gusts are zero-mean and, in turbulence,
  carry a steady wind a few sd of theirs (reference flight, 5 m/s steady plus Dryden sd
  3 m/s, seeds 1-2: every coefficient within 1.9 se, the fit check passed;
  ``benchmarks/bench_filter_error.py --checks``). Without turbulence they cannot: the
  along-path part is pulled to zero and the coefficients take it up; a steady part of the
  filtered wind beyond what the fitted intensity allows refuses the fit
  (:func:`baselines._fem_wind.steady_verdict`).
- **Criterion and optimizer**: the innovations' negative log-likelihood, Fisher scoring
  with central-difference sensitivities of the whole filter; standard errors (the
  Cramér-Rao bound) from the innovations' Fisher information (:mod:`baselines._fem_fit`).
- **Verdict**: the fit check reads the innovations (``info['fit_residuals']``) with the
  filter's own innovation variances as its noise model (``info['R']``): a right model
  leaves white innovations of that size. In turbulence the gust states take up a model
  error and the innovations stay white, so the filtered gust path is judged too
  (:mod:`baselines._gust_verdict`): a steady along-body-x part larger than Dryden's
  intensity allows refuses the fit (measured: Cx or Clp held 10 % off refused 6/6 in
  Dryden sd 3 m/s, where the fit check passed them; pitch and normal-force errors, Cma
  held 30 % off, still pass: a passed fit with gusts says so in one line). What the user
  asserts, held coefficients and priors, is tested by a likelihood ratio against a fit
  with them free (:mod:`baselines._fem_holds`): a pitch-plane coefficient held wrong is
  refused there.
- **Air data** (``air_data``, default ``inertial``): a probe's alpha, beta and airspeed as
  measured outputs of the filter, their calibration as parameters
  (:mod:`baselines._fem_air`).
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass
from typing import Any, ClassVar, Literal, NamedTuple

import numpy as np

from aeroid.errors import EstimatorError
from aeroid.estimation import EstimationResult, Estimator, failed_result
from aeroid.flights import INPUTS, MIL_SCALE_LENGTH_M, Flight
from aeroid.model import N_STATE, NAMES, OUTPUT_CHANNELS, PHI, PSI, THETA, P
from baselines import (
    _common,
    _fem_air,
    _fem_dryden,
    _fem_fit,
    _fem_holds,
    _fem_setup,
    _fem_wind,
)
from baselines._fem_filter import gust_model
from baselines._fem_model import N_WIND
from baselines._gust_verdict import AXIAL_LIMIT, gust_verdict


class Start(NamedTuple):
    """The likelihood's problem, the scaled start ``p0``, the measurement noise, the air
    data used (or None), the gusts' time constant [s], the record's speed [m/s] and the
    airframe's prior coefficients (:meth:`FilterErrorEstimator.start`)."""

    problem: _fem_fit.Problem
    p0: np.ndarray
    noise: _fem_setup.Noise
    air: _fem_air.FemAirPlan | None
    tau: float
    speed: float
    prior: np.ndarray


#: Samples at most: the filter keeps every perturbed run's innovation covariances
#: (2 n_p + 1 runs x n x m x m doubles: 15 kB per sample with 10 parameters and the IMU's
#: 9 outputs; 33 kB with the air data's 3 outputs and 4 calibration parameters).
MAX_SAMPLES = 5000


@dataclass(frozen=True, kw_only=True)
class FilterErrorEstimator(_fem_wind.FemWindOption, _fem_air.FemAirOption, Estimator):
    """Filter-error maximum likelihood: an EKF with NED gust states inside the likelihood.

    Starts from the airframe's prior coefficients and ``gust_sd_start_mps``; the module
    docstring says what is estimated and how.

    Attributes
    ----------
    input : {"auto", "hold", "midpoint", "events", "law"}
        How the fin deflection between samples is modelled: ``auto`` (default) is
        ``law`` when the flight's airframe has a ``[fin_law]``, else ``hold``
        (:data:`aeroid.flights.INPUTS`).
    delay_s : float
        A known actuator delay [s] (default 0).
    substeps : int
        RK4 steps per sample interval (default 1: against 2, the coefficients moved by
        0.023 of their standard errors in still air and 2e-4 in Dryden sd 3 m/s; the
        reference flight, Gaussian IMU, seed 1; ``benchmarks/bench_filter_error.py
        --checks``).
    scale_length_m : float
        The gusts' scale length L [m] (default MIL-F-8785C's 533.4 m, the simulator's);
        the time constant is ``L / V`` with ``V`` the mean speed of the record.
    gust_sd_start_mps : float
        The gust intensity the fit starts from [m/s] (default 1.0).
    measurement_noise : {"auto", "metadata", "innovations"}
        The measurement-noise variances: from the flight's noise metadata, or estimated
        from the innovations after every iteration (FVSysID's relaxation); ``auto``
        (default): metadata when the flight has a noise model with noise, else
        innovations; said in one line (:mod:`baselines._fem_setup`).
    max_iterations : int
        Fisher-scoring iterations at most (default 30).
    tol : float
        Convergence: every parameter's step below ``tol`` of its Cramér-Rao sd (default
        0.01).
    compile_model : bool
        Compile the model's CasADi functions to C (default True; falls back to CasADi's
        virtual machine, the same numbers; ``info['compiled']`` says which ran).
    gust_model : {"first-order", "dryden"}
        The gusts' model: ``first-order`` (default) three NED first-order Gauss-Markov
        gusts; ``dryden`` the simulator's Dryden shaping filters (transverse second
        order) in the path axes of the record's mean velocity, scale length
        ``scale_length_m`` (:mod:`baselines._fem_dryden`), said in one line.
    estimate_wind : bool
        Also estimate a steady wind (north, east, down [m/s]; default False: the gusts
        are zero-mean), the gusts decaying towards it; reported in
        ``info['wind_ned_mps']`` and ``info['wind_stderr_mps']`` with a one-line notice:
        for a steady wind without turbulence, or in turbulence with an airspeed channel
        (``air_data = measured``; from an IMU alone the along-path part is not
        identified there; :mod:`baselines._fem_wind`).
    air_data : {"inertial", "auto", "measured"}
        The flight's air data (alpha, beta that differ from the inertial ones, airspeed)
        as measured outputs: ``measured`` or ``auto`` (when the flight has them);
        ``inertial`` (default) leaves them out, said in one line
        (:class:`baselines._fem_air.FemAirOption`, also ``air_data_calibration`` and
        ``air_data_noise``).

    Notes
    -----
    ``cost`` is the innovations' negative log-likelihood without constants, plus the
    priors'. ``info``: ``gust_sd_mps`` and ``gust_sd_stderr_mps`` (NaN when at its lower
    bound, :data:`baselines._fem_fit.LOG_SIGMA_MIN`: still air), ``gust_time_constant_s``,
    ``scale_length_m``, ``gust_model``, ``measurement_noise`` (which source) and
    ``measurement_noise_var`` (m,), ``measurement_noise_fractions`` (per iteration with the
    noise estimated from the innovations: how far towards the relaxed variances it went, 1
    in full, 0 refused because it raised the cost; :func:`baselines._fem_fit.noise_step`),
    ``R`` (n, m): the innovations' variances (the fit check's noise model),
    ``fisher`` (the scaled parameters' information), ``parameter_names``, ``parameters``,
    ``parameter_stderr``, and
    ``wind_filtered_ned_mps`` (n, N_WIND): the filtered wind (steady and gusts) at each
    sample, ``state_filtered`` (n, N_STATE): the filtered state, ``gust_verdict``: the gust
    verdict's figures (:class:`baselines._gust_verdict.GustVerdict`) and the steady-wind
    verdict's (:class:`baselines._fem_wind.SteadyVerdict`). With air data ``air_data``
    (:func:`baselines._fem_air.air_report`), the probe's channels in ``fit_residuals``
    and ``R`` after the IMU's, the calibration last in ``parameters``.
    """

    name: ClassVar[str] = "filter-error"
    description: ClassVar[str] = (
        "filter-error maximum likelihood: an EKF with NED gust states in the loop (turbulence)")
    supports_holds: ClassVar[bool] = True
    uses_state_sd: ClassVar[bool] = True  # the initial covariance: _fem_setup.initial_state

    input: Literal["auto", "hold", "midpoint", "events", "law"] = "auto"
    delay_s: float = 0.0
    substeps: int = 1
    scale_length_m: float = MIL_SCALE_LENGTH_M
    gust_sd_start_mps: float = 1.0
    measurement_noise: Literal["auto", "metadata", "innovations"] = "auto"
    max_iterations: int = 30
    tol: float = 0.01
    compile_model: bool = True
    gust_model: Literal["first-order", "dryden"] = "first-order"

    def __post_init__(self) -> None:
        if self.input not in INPUTS:
            raise ValueError(f"input must be one of {', '.join(INPUTS)}, got {self.input!r}")
        if self.measurement_noise not in ("auto", "metadata", "innovations"):
            raise ValueError("measurement_noise must be auto, metadata or innovations, got "
                             f"{self.measurement_noise!r}")
        if not (math.isfinite(self.delay_s) and abs(self.delay_s) < 0.1):
            raise ValueError(f"delay_s must be seconds below 0.1 in magnitude, got {self.delay_s}")
        for key in ("substeps", "max_iterations"):
            if not (isinstance(getattr(self, key), int) and getattr(self, key) >= 1):
                raise ValueError(f"{key} must be an integer >= 1, got {getattr(self, key)!r}")
        for key in ("scale_length_m", "gust_sd_start_mps", "tol"):
            if not (math.isfinite(getattr(self, key)) and getattr(self, key) > 0):
                raise ValueError(f"{key} must be a positive number, got {getattr(self, key)}")
        if self.gust_model not in ("first-order", "dryden"):
            raise ValueError("gust_model must be first-order or dryden, got "
                             f"{self.gust_model!r}")
        self.check_air_options()

    def parameter_names(self, free_names: tuple[str, ...], calibration: tuple[str, ...] = ()
                        ) -> tuple[str, ...]:
        """Names of the estimated parameters, in the order of ``info['parameters']``
        (``calibration``: the air data's, last)."""
        return (*free_names, "gust_sd_mps", *_fem_wind.wind_names(self), *calibration)

    def start(self, flight: Flight, holds: Any = None) -> Start:
        """The likelihood's problem on a validated ``flight`` and where the fit starts."""
        if flight.n_samples > MAX_SAMPLES:
            raise EstimatorError(f"{self.name}: {flight.n_samples} samples; it fits at most "
                                 f"{MAX_SAMPLES} at once (the perturbed filters' innovation "
                                 "covariances: ~15 kB per sample); fit a shorter window")
        zs = _common.measurements(flight)
        noise = _fem_setup.measurement_noise(flight, zs, self.measurement_noise, self.name)
        _fem_setup.say(noise.note)
        x0, P0x = _fem_setup.initial_state(flight, zs, noise.R)
        air = _fem_air.air_plan(self, flight)  # the probe's channels after the IMU's
        if air is not None:
            noise = noise._replace(
                R=np.concatenate([noise.R, air.var]),
                floor=np.concatenate([noise.floor, air.floor]),
                update=np.concatenate([np.full(zs.shape[1], noise.update),
                                       np.full(len(air.channels), not air.held)]))
            zs = np.hstack([zs, air.z])
        decay, tau, speed = _fem_setup.gust_decay(flight, self.scale_length_m)
        prior = flight.airframe.prior_vector()
        theta_base = prior.copy() if holds is None else holds.with_held(prior)
        free, scale, mean, info_prior = _fem_setup.free_parameters(prior, holds)
        probe = () if air is None else (air.channels, air.calibration, air.probe)
        gust = None
        if self.gust_model == "dryden":
            model = _fem_dryden.dryden_gust_model(flight, self.substeps, self.input,
                                                  self.delay_s, self.compile_model, *probe)
            gust = _fem_dryden.dryden_gust(flight.dt, self.scale_length_m, speed,
                                           _fem_dryden.mean_velocity_ned(flight))
            _fem_setup.say(f"{self.name}: Dryden gusts (longitudinal first order, transverse "
                           f"second order) in the path axes of the record's mean velocity, "
                           f"L {self.scale_length_m:g} m, tau {tau:.3g} s")
        else:
            model = gust_model(flight, self.substeps, self.input, self.delay_s,
                               self.compile_model, *probe)
        problem = _fem_fit.Problem(model, zs, x0, P0x, decay, theta_base, free, scale,
                                   self.estimate_wind, mean, info_prior, gust)
        p0 = np.concatenate([theta_base[free] / scale, [math.log(self.gust_sd_start_mps)],
                             np.zeros(len(_fem_wind.wind_names(self))),
                             _fem_air.calibration_start(air)])
        return Start(problem, p0, noise, air, tau, speed, prior)

    def run(self, flight: Flight, rng: np.random.Generator, holds: Any = None
            ) -> EstimationResult:
        """Fit the flight (no random draws: ``rng`` is unused)."""
        problem, p0, noise, air, tau, speed, prior = self.start(flight, holds)
        try:
            fit = _fem_fit.fisher_scoring(problem, p0, noise.R, update_noise=noise.update,
                                          r_floor=noise.floor,
                                          max_iterations=self.max_iterations, tol=self.tol)
        except FloatingPointError as exc:
            return failed_result(self.name, str(exc))
        test = _fem_holds.hold_test(problem, fit, holds, prior, update_noise=noise.update,
                                    r_floor=noise.floor, max_iterations=self.max_iterations,
                                    tol=self.tol, who=self.name)
        return self._result(flight, problem, fit, noise, tau, speed, test, air)

    def _result(self, flight: Flight, problem: _fem_fit.Problem, fit: _fem_fit.Fit,
                noise: _fem_setup.Noise, tau: float, speed: float,
                test: _fem_holds.HoldTest | None = None,
                air: _fem_air.FemAirPlan | None = None) -> EstimationResult:
        """Turn the fit into an :class:`EstimationResult` (class docstring, Notes)."""
        n_p, nf, i_s = fit.p.size, problem.free.size, problem.i_sigma
        n_cal = problem.n_calibration
        active = np.array([i != i_s or not fit.at_bound for i in range(n_p)])
        cov_p = np.full((n_p, n_p), np.nan)
        with contextlib.suppress(np.linalg.LinAlgError):  # then NaN: no standard errors
            cov_p[np.ix_(active, active)] = np.linalg.inv(
                fit.information[np.ix_(active, active)])
        # physical units: coefficients x scale; sigma = exp(p) (delta method)
        jac = np.ones(n_p)
        jac[:nf] = problem.scale
        jac[i_s] = math.exp(fit.p[i_s])
        phys = fit.p.copy()
        phys[:nf] *= problem.scale
        phys[i_s] = math.exp(fit.p[i_s])
        if n_cal:  # the calibration: scaled as output-error's
            phys[n_p - n_cal:] = problem.calibration(fit.p[None])[0]
            jac[n_p - n_cal:] = _fem_air.calibration_scales(list(problem.model.calibration))
        cov_phys = cov_p * np.outer(jac, jac)
        stderr_phys = np.sqrt(np.abs(np.diag(cov_phys)))
        theta, steady, _ = problem.unpack(fit.p[None])
        cov = np.zeros((len(NAMES), len(NAMES)))
        cov[np.ix_(problem.free, problem.free)] = cov_phys[:nf, :nf]
        stderr = np.full(len(NAMES), np.nan)
        stderr[problem.free] = stderr_phys[:nf]
        runs = fit.runs
        S_diag = np.diagonal(runs.S[0], axis1=-2, axis2=-1)
        free_names = tuple(NAMES[i] for i in problem.free)
        channels = (*OUTPUT_CHANNELS, *problem.model.air_channels)
        info: dict[str, Any] = {
            "parameter_names": self.parameter_names(free_names, problem.model.calibration),
            "parameters": phys,
            "parameter_stderr": stderr_phys, "parameter_covariance": cov_phys,
            "fisher": fit.information, "gust_sd_mps": float(phys[i_s]),
            "gust_sd_stderr_mps": float(stderr_phys[i_s]), "gust_sd_at_bound": fit.at_bound,
            "gust_time_constant_s": tau, "scale_length_m": self.scale_length_m,
            "gust_model": self.gust_model,
            "speed_mps": speed, "measurement_noise": noise.source,
            "measurement_noise_var": fit.R, "R": S_diag, "compiled": problem.model.compiled,
            "measurement_noise_fractions": np.array(fit.noise_fractions),
            "iterations": fit.n_iterations,
            "wind_filtered_ned_mps": runs.x[0][:, -N_WIND:],
            "state_filtered": runs.x[0][:, :N_STATE],
            "fit_residuals": {c: runs.innovation[0][:, j] for j, c in enumerate(channels)},
        }
        x = runs.x[0]
        gust = x[:, -N_WIND:] - steady[0]  # the gusts alone (steady: 0 unless estimated)
        verdict = gust_verdict(gust, x[:, [PHI, THETA, PSI]], x[:, P],
                               float(phys[i_s]), tau, flight.dt, who=self.name,
                               velocity=x[:, :3])
        steady_check = _fem_wind.steady_verdict(
            gust, verdict.figures["axial_mean_sd_mps"], float(phys[i_s]), flight.dt,
            who=self.name, estimated=self.estimate_wind)
        info["gust_verdict"] = verdict.figures | steady_check.figures
        success, message = fit.converged, fit.message
        if success and not verdict.ok:
            success, message = False, verdict.message
        if success and not steady_check.ok:
            success, message = False, steady_check.message
        warnings: list[str] = _fem_wind.wind_report(
            self.name, steady[0] if self.estimate_wind else None,
            stderr_phys[i_s + 1:n_p - n_cal], info)
        if air is not None:
            m = len(OUTPUT_CHANNELS)
            info["air_data"], said = _fem_air.air_report(
                air, phys[n_p - n_cal:], stderr_phys[n_p - n_cal:], fit.R[m:], self.name,
                flight)
            warnings += said
        if test is not None:  # the user's holds and priors against the data
            info["hold_test"] = test.figures
            if success and not test.ok:
                success, message = False, test.message
            elif test.message:
                warnings.append(test.message)
        if success and not fit.at_bound:
            warnings.append(
                f"{self.name}: in turbulence a passed fit is weak evidence of a right model: "
                "the gust states take up model errors; the gust verdict sees those taken up "
                "as a steady along-body wind (axial force, roll damping) but not pitch or "
                f"normal-force ones (measured: Cma held 30 % off passes it; here axial z "
                f"{verdict.figures['axial_z']:.1f}, limit {AXIAL_LIMIT:g}); holds and priors "
                "are tested by a likelihood ratio, free coefficients are not")
        if np.any(flight.airframe.accel_position_sd > 0):
            warnings.append(f"{self.name}: the airframe's uncertain accelerometer positions "
                            "(accel*_position_sd_m) are taken as given: not estimated, and "
                            "their uncertainty is not in the standard errors")
        hist_p = np.array(fit.history_p)
        history = {"axis": "iteration", "step": np.arange(len(hist_p)),
                   "theta": problem.unpack(hist_p)[0],
                   "cost": np.array(fit.history_cost[:len(hist_p)])}
        return EstimationResult(
            estimator=self.name, theta=theta[0], stderr=stderr, covariance=cov,
            cost=fit.cost, success=success, message=message,
            n_evaluations=fit.n_evaluations, n_iterations=fit.n_iterations, history=history,
            info=info, warnings=tuple(warnings))
