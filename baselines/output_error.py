"""Output-error maximum-likelihood baseline (Klein & Morelli's output-error method, CasADi).

Model: aeroid's output-error forward model (:func:`aeroid.model.symbolic_record`): the
airframe equations integrated with RK4 from the initial state, ``delta`` held over each
sample interval, outputs the six accelerations of eq. 28 at the estimator's sensor
positions and ``p, q, r``, as one CasADi graph with exact forward sensitivities; by
default its per-step functions are compiled to C (see ``compile_model``).

Estimation (Klein & Morelli, ch. 6; :mod:`baselines._gauss_newton`): measurement noise
Gaussian, white, with unknown diagonal covariance ``R``; damped Gauss-Newton on the
weighted least-squares cost with ``R`` re-estimated from the residuals after every
accepted step (the relaxation technique); parameters scaled to order one
(``theta / prior``). The Cramér-Rao covariance is ``(sum_k J_k^T R^-1 J_k)^-1`` (Fisher
information) at the optimum; on a reference flight with the true sensor positions its
standard deviations are within 10 % of the independent prototype's
(reference/README.md), except Cx (0.012 % against 0.02 %), and over 50
Gaussian-noise flights the 95 % intervals covered the truth in 96 % of coefficient-runs
(tests/statistical/test_coverage.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal

import numpy as np

import aeroid
from aeroid.estimation import NOT_AN_OPTION, EstimationResult, Estimator
from aeroid.flights import Flight, imu_error_names
from aeroid.model import OUTPUT_CHANNELS
from baselines import _common, _held, _oe_airdata, _oe_attitude, _oe_wind, _tables_fit, _wind_auto
from baselines._gauss_newton import Fit, Problem, gauss_newton, posterior_information, sandwich
from baselines._oe_aiding import aided_problem, aiding_info, aiding_names, aiding_x0
from baselines._oe_aiding_report import aiding_warnings
from baselines._oe_airdata_fit import airdata_problem, airdata_report
from baselines._oe_constants import (
    MAX_SAMPLES,
    POSITION_NAMES,
    R_FLOOR_REL,
    X0_NAMES,
    X0_RATES,
    X0_VELOCITIES,
)
from baselines._oe_options import check_options
from baselines._oe_record import RecordModel
from baselines._oe_sensors import (
    HELD_VELOCITY_WARNING,
    consider_covariance,
    imu_error_report,
    imu_error_scales,
    position_report,
)
from baselines._oe_skew import skew_report, skew_search
from baselines._oe_starts import best_end, give_up, start_report
from baselines._oe_warm import make_starts, warm_started
from baselines._oe_windows import OutputErrorWindows


@dataclass(frozen=True, kw_only=True)
class OutputErrorEstimator(OutputErrorWindows, _tables_fit.FitsTables, Estimator,
                           _oe_wind.WindOption, _oe_airdata.AirDataOption,
                           _oe_attitude.AttitudeOption):
    """Output-error maximum likelihood (Gauss-Newton, CasADi AD, Cramér-Rao bounds).

    Starts from the airframe's prior coefficients and from equation-error's estimate, the
    state from the first measured sample.

    Attributes
    ----------
    input : {"auto", "hold", "midpoint", "events", "law"}
        How the fin deflection between samples is modelled: ``auto`` (default) is
        ``law`` when the flight's airframe has a ``[fin_law]``, else ``hold``
        (:data:`aeroid.flights.INPUTS`). By name: held until the next sample (a relay latched at
        the log clock, the paper's reference), switched halfway, at the flight's known
        switch instants, or by the airframe's fin law on the measured roll angle (checked
        against the logged deflection first: :func:`aeroid.flights.check_input`; the
        result's ``info['input']`` says which was used). A relay that switches between
        samples and is modelled as held biases Czq and Cmq by up to tens of percent
        (measured on JSBSim flights, tests/crossengine/results.md).
    estimate_delay : bool
        Also estimate an actuator time delay (default False), reported in
        ``info['delay_s']`` with ``info['delay_stderr_s']``.
    delay_s : float
        The delay [s]: its starting value when estimated, else a known delay (default 0).
    noise_model : {"channel", "signal"}
        Measurement-noise variance: per sample ``a_c + b_c yhat^2`` (default; the
        paper's eq. 43 noise is proportional to the signal; :class:`baselines.
        _gauss_newton.Problem`), or one per channel re-estimated from the residuals.
        Default chosen by measurement: paper noise with its 10 % position error (positions
        estimated, 4 flights) mean |error| 0.39 % against 5.3 % per channel; Gaussian IMU
        (10 flights) 0.634 % against 0.650 % (``b_c`` comes out ~0: nothing lost).
    positions : {"estimate", "consider", "known"}
        What to do with accelerometer-position components the airframe calls uncertain
        (``accel1_position_sd_m``, ``accel2_position_sd_m`` > 0): estimate them under that
        Gaussian prior (MAP, default; reported in ``info['accel_positions_m']`` with
        ``info['accel_position_stderr_m']``), keep them at the given values but add their
        effect to the covariance (Schmidt consider analysis), or treat them as known.
    covariance : {"fisher", "sandwich"}
        ``fisher`` (default): the inverse information with the modelled noise;
        ``sandwich``: ``M^-1 B M^-1`` with the scores' outer products, robust to a wrong
        noise model (use it with ``noise_model="channel"``, not with ``signal``).
    estimate_initial_state : bool
        Also estimate the body rates ``p, q, r`` at the first sample (default True: the
        measured rates carry the sensor noise; a wrong initial roll rate puts the whole
        predicted record out of phase).
    estimate_initial_velocity : bool
        Also estimate ``u, v, w`` at the first sample (default False: the flight's
        velocity channels are used as measured, clean in the paper's noise model).
        Decision: off by default because every force and moment scales with ``V^2``, so
        a free initial speed trades against all nine coefficients at once; on the
        reference flight it inflated the Cramér-Rao sd of Cx, Cza, Cma, Cmd from ~0.1 %
        to ~1.6 % (measured). The attitude is taken as measured (see ``attitude_prior``).
    initial_velocity_prior : {"none", "flight"}
        With ``estimate_initial_velocity``: ``"flight"`` puts a Gaussian prior on
        ``u, v, w`` at the first sample, centred on the flight's values with the sd in
        the flight's ``metadata['initial_state_sd']`` (written by :meth:`aeroid.
        reconstruction.Reconstruction.to_flight`: the smoothed sd of the reconstruction);
        default ``"none"`` (no prior). A flight without those sd is refused.
    estimate_rx1, estimate_rx2 : bool
        Also estimate the x position of triad 1 / triad 2 (default False); reported in
        ``info['rx1_m']`` / ``info['rx2_m']``. One position is identifiable when the
        other is right. They cannot undo an error in both positions: at each relay step
        both triads see ``dAz_i = (Czd Q S / m - Cmd Q S D rx_i / Iy) d_delta``, two
        equations for Czd, rx1 and rx2, so Czd stays confounded with the positions.
    substeps : int
        RK4 steps per sample interval (default 2: the outputs then match the 0.25 ms
        truth integration of the reference flight to ~1e-6 relative and a noise-free fit
        recovers the coefficients to ~5e-6; with 1 substep, ~1e-5 and 1.2e-4 (Clp) at
        half the cost per iteration, measured).
    max_iterations : int
        Gauss-Newton iterations per start (default 50).
    tol : float
        Convergence: the largest parameter step, in Cramér-Rao standard deviations of
        the current iterate, is below ``tol`` (default 1e-3) and R has settled.
    equation_error_start : bool
        Also start from equation-error's closed-form estimate of the flight (default
        True; :mod:`baselines._oe_starts`): a start that does not depend on the prior.
    staged_start : bool
        Fit the prior start's ``Cx`` (and its table points) first, everything else held,
        then all from there (default False; :func:`baselines._oe_warm.staged_start`: a
        told mass a few % off, where the prior start fails).
    n_starts : int
        Starts from the prior: the prior itself, then ``n_starts - 1`` draws
        ``prior * (1 + 0.2 N(0, 1))`` from ``rng`` (default 1). The likeliest converged end
        of all starts wins; ``info`` says how many ended elsewhere and how much worse
        (``starts_elsewhere``, ``start_cost_excess``, ``start_distance_sd``), and a
        converged end more than one standard error away is a warning.
    pso_warm_start : bool
        Replace the prior start by the best point of a short run of
        :func:`aeroid.estimation.minimize` on the concentrated likelihood
        ``sum_j log mean_k e_kj^2`` within :func:`aeroid.prior_bounds` (default False).
    pso_particles, pso_iterations : int
        Budget of that warm start (defaults 30 and 40).
    imu_errors : {"none", "bias", "bias+scale"}
        Also estimate the IMU's errors (default ``"none"``: unbiased channels): a bias per
        output channel, with ``"bias+scale"`` also a scale factor, in the sensor law
        ``y_meas = (1 + s) y_model + b`` of :func:`aeroid.flights.simulate_suite`; no prior;
        ``info['imu_errors']`` and ``info['imu_error_stderr']`` (``bax1``, ``sp``, ...).
        For a raw IMU (``Reconstruction.to_flight(imu="raw")``). An axial bias trades
        against Cx; a warning names each pair correlated above 0.98
        (:func:`aeroid.estimation.nuisance_findings`).
    aiding : {"none", "gnss-velocity", "gnss-velocity+ins-attitude", "gnss-position", ...}
        ``"gnss-velocity"``: the flight's GNSS NED velocity samples (``metadata["aiding"]``:
        ``to_flight(aiding=True)``) as outputs at their own samples (on the flight's grid,
        else refused), with the log's stated sd (:mod:`baselines._oe_aiding`); default none.
        ``"gnss-velocity+ins-attitude"``: also the INS's phi theta psi, on the circle.
        ``gnss-position``, ``baro-altitude``: NED position, barometric altitude (_oe_position).
    estimate_skew : {"none", "gnss", "ins", "gnss+ins"}
        Also estimate those aiding sources' skew against the IMU (samples taken at logged
        ``t + skew``; :mod:`baselines._oe_skew`), in ``info['aiding_skew_s']`` with
        ``info['aiding_skew_stderr_s']``; default none. A source must be in ``aiding``.
    compile_model : bool
        Compile the per-step model and sensitivity functions to C with the system
        compiler (default True; CasADi code generation, the library cached on disk in
        ``~/.cache/aeroid/casadi`` or ``$AEROID_CASADI_CACHE``; the first fit of a new
        parameter set compiles for ~3-5 s, then a Jacobian costs ~4x less). Without a
        working compiler it falls back to CasADi's virtual machine (same numbers);
        ``info['compiled']`` says which ran.

    Notes
    -----
    ``cost`` is the negative log-likelihood without constants,
    ``n/2 sum_j log R_jj + 1/2 sum_k e_k^T R^-1 e_k``. ``info`` holds ``R`` (9,),
    ``fisher`` (n_p, n_p), ``parameter_names``, ``parameters`` and ``parameter_stderr``
    (initial-state offsets and rx1 included), ``iterations``. Per-sample channels
    (mass, thrust, inertias, atmosphere) are interpolated in time inside the model.
    """

    name: ClassVar[str] = "output-error"
    uses_state_sd: ClassVar[bool] = True  # initial_velocity_prior, or a warning
    leaves_out_saturated: ClassVar[bool] = True  # RecordModel.mask, Problem.mask
    supports_holds: ClassVar[bool] = True  # holds: baselines._held, the model untouched
    uses_air_data: ClassVar[bool] = True  # option air_data: baselines/_oe_airdata.py
    description: ClassVar[str] = (
        "output-error maximum likelihood: Gauss-Newton with CasADi AD, Cramer-Rao bounds")

    input: Literal["auto", "hold", "midpoint", "events", "law"] = "auto"
    estimate_delay: bool = False
    delay_s: float = 0.0
    noise_model: Literal["channel", "signal"] = "signal"
    positions: Literal["estimate", "consider", "known"] = "estimate"
    covariance: Literal["fisher", "sandwich"] = "fisher"
    estimate_initial_state: bool = True
    estimate_initial_velocity: bool = False
    initial_velocity_prior: Literal["none", "flight"] = "none"
    estimate_rx1: bool = False
    estimate_rx2: bool = False
    substeps: int = 2
    max_iterations: int = 50
    tol: float = 1e-3
    equation_error_start: bool = True
    staged_start: bool = False
    n_starts: int = 1
    pso_warm_start: bool = False
    pso_particles: int = 30
    pso_iterations: int = 40
    imu_errors: Literal["none", "bias", "bias+scale"] = "none"
    aiding: Literal["none", "gnss-velocity", "gnss-velocity+ins-attitude", "gnss-position",
                    "gnss-velocity+gnss-position", "gnss-velocity+gnss-position+ins-attitude",
                    "baro-altitude", "gnss-position+baro-altitude",
                    "gnss-velocity+gnss-position+baro-altitude"] = "none"
    estimate_skew: Literal["none", "gnss", "ins", "gnss+ins"] = "none"
    compile_model: bool = True
    #: Where warm_started's fit starts (a previous fit's parameters), no option: _oe_warm.
    start_parameters: tuple[float, ...] | None = field(default=None, metadata=NOT_AN_OPTION)

    def __post_init__(self) -> None:
        check_options(self)  # one ValueError per bad option: baselines/_oe_options.py
        _oe_airdata.check_air_data_options(self)
        _wind_auto.check_wind_option(self)

    def warm_started(self, result: EstimationResult) -> OutputErrorEstimator | None:
        """This method started from ``result``'s parameters (consider re-fits: _oe_warm)."""
        return warm_started(self, result)

    # ----------------------------------------------------------------------------------
    def parameter_names(self, position_free: tuple[int, ...] = ()) -> tuple[str, ...]:
        """Names of the estimated parameters, in the order of ``info['parameters']``."""
        names = list(aeroid.NAMES) + [X0_NAMES[i] for i in self.x0_free()]
        names += [POSITION_NAMES[c] for c in position_free] + _oe_wind.wind_names(self)
        names += ["delay_s"] if self.estimate_delay else []
        return tuple(names + list(imu_error_names(self.imu_errors))
                     + aiding_names(self.aiding, self.estimate_skew))

    def rx_free(self) -> tuple[int, ...]:
        """Triads (0, 1) whose x position is estimated."""
        return tuple(t for t, on in enumerate((self.estimate_rx1, self.estimate_rx2)) if on)

    def x0_free(self) -> tuple[int, ...]:
        """State indices of the estimated initial-state components."""
        free = (X0_VELOCITIES if self.estimate_initial_velocity else ()) + (
            X0_RATES if self.estimate_initial_state else ()) + aiding_x0(self.aiding)
        return tuple(sorted(set(free + _oe_attitude.attitude_x0(self))))

    def position_free(self, flight: Flight) -> tuple[int, ...]:
        """Estimated position components (indices into ``[x1, y1, z1, x2, y2, z2]``)."""
        free = {3 * t for t in self.rx_free()}
        if self.positions == "estimate":
            free |= set(np.flatnonzero(flight.airframe.accel_position_sd.ravel() > 0).tolist())
        return tuple(sorted(free))

    def problem(self, flight: Flight, position_free: tuple[int, ...] | None = None) -> Problem:
        """Return the fit of ``flight``: measurements, record model, noise model, prior.

        Uncertain position components (``Airframe.accel_position_sd``) estimated under
        ``positions="estimate"`` carry a Gaussian prior centred on the given position.
        """
        position_free = self.position_free(flight) if position_free is None else position_free
        _, prior = _tables_fit.coefficient_layout(flight)  # [tables]: flat at the prior
        pos = flight.airframe.accel_positions.ravel()
        pos_sd = flight.airframe.accel_position_sd.ravel()
        scale = [np.where(prior != 0.0, prior, 1.0)]
        scale.append(np.ones(len(self.x0_free())))
        scale.append([pos_sd[c] if pos_sd[c] > 0 else max(abs(pos[c]), 0.1)
                      for c in position_free] + _oe_wind.wind_scales(self, flight))
        if self.estimate_delay:
            scale.append([flight.dt])
        z = _common.measurements(flight)
        scale += imu_error_scales(z, self.imu_errors)
        scale = np.concatenate(scale)
        weight = _oe_attitude.prior_weights(self, flight, scale, position_free)
        x0 = flight.states()[0]
        x0[_common.RATES] = _common.smoothed_start(z[:, _common.GYROS])
        model = RecordModel(flight, input=self.input, substeps=self.substeps,
                            x0_free=self.x0_free(), position_free=position_free,
                            compiled=self.compile_model, x0=x0, scale=scale,
                            delay_s=self.delay_s, estimate_delay=self.estimate_delay,
                            imu_errors=self.imu_errors, tables=_tables_fit.flight_tables(flight),
                            wind_free=_oe_wind.wind_free(self, flight))
        has_prior = bool(np.any(weight > 0))
        return airdata_problem(self, flight, aided_problem(self.aiding, flight, Problem(
            z=z, model=model, r_floor=R_FLOOR_REL * np.mean(z * z, axis=0) + 1e-300,
            noise_model=self.noise_model, prior_mean=np.zeros(scale.size) if has_prior else None,
            prior_weight=weight if has_prior else None), self.estimate_skew))

    def gauss_newton(self, prob: Problem, p0: np.ndarray, stop: Any = None) -> Fit:
        """Run damped Gauss-Newton with the R relaxation from scaled parameters ``p0``."""
        return gauss_newton(prob, p0, max_iterations=self.max_iterations, tol=self.tol, stop=stop)

    def run(self, flight: Flight, rng: np.random.Generator, holds: Any = None) -> EstimationResult:
        """Fit the flight; random draws only for extra starts and the PSO warm start."""
        if _wind_auto.is_auto(self):  # estimate_wind = auto resolved on the log, said
            return _wind_auto.run_auto(self, flight, _oe_wind.blocked(self, flight),
                                       lambda est: est.run(flight, rng, holds))
        if flight.n_samples > MAX_SAMPLES:
            raise aeroid.EstimatorError(
                f"output-error: {flight.n_samples} samples; it fits at most {MAX_SAMPLES} "
                "at once (its Jacobian grows with the record: ~2.5 kB per "
                "sample); fit windows of the log")
        if self.estimate_wind and _tables_fit.flight_tables(flight) is not None:
            raise aeroid.EstimatorError("output-error: estimate_wind with coefficient tables "
                                        "([tables]) is not built (Mach needs the airspeed)")
        prob = _held.with_priors(self, flight, self.problem(flight), holds)
        model: RecordModel = prob.model  # type: ignore[assignment]
        scale = model.scale
        n_p = scale.size
        names, prior = _tables_fit.coefficient_layout(flight, self.pso_warm_start)
        n_c = len(names)  # the coefficients, or with [tables] their parameters
        first = np.zeros(n_p)
        first[:n_c] = prior / scale[:n_c]
        i_delay = model.n_graph
        if self.estimate_delay:
            first[i_delay] = self.delay_s / scale[i_delay]
        starts, extra_evals = make_starts(self, prob, flight, first, prior, scale, rng, names,
                                          holds)
        fits, labels, failures = [], [], []
        for start in starts:
            try:
                if start.p0 is None:
                    raise FloatingPointError(start.failure)
                fits.append(_held.held_fit(self, prob, start.p0, holds, give_up(fits, self)))
                labels.append(start.label)
            except FloatingPointError as exc:
                failures.append(f"{start.label}: {exc}")
        if not fits:
            return aeroid.failed_result(self.name, failures[0])
        k_best = best_end(fits)  # with estimate_skew, searched along the skews from there
        fits[k_best], search = skew_search(self.estimate_skew, prob, fits[k_best],
                                           lambda p0: _held.held_fit(self, prob, p0, holds))
        best = fits[k_best]
        n_evals = extra_evals + sum(f.n_evaluations for f in fits) + search["n_evaluations"]
        n_iter = sum(f.n_iterations for f in fits)
        M, _ = posterior_information(prob, best.J, best.e, best.r_diag, best.p)
        try:
            cov_p = _held.held_inverse(M, holds)
        except np.linalg.LinAlgError:
            cov_p = np.full_like(M, np.nan)
        if self.covariance == "sandwich":
            cov_p = sandwich(cov_p, best.J, best.e, best.r_diag)
        cov_phys = cov_p * np.outer(scale, scale)
        if self.positions == "consider":
            cov_phys = cov_phys + consider_covariance(self, flight, best, scale)
        phys = best.p * scale + getattr(model, "phys_offset", 0.0)  # aiding's origin
        theta = phys[:n_c]
        cov = cov_phys[:n_c, :n_c]
        hist_p = np.array(best.history_p)
        history = {"axis": "iteration", "step": np.arange(len(hist_p)),
                   "theta": hist_p[:, :n_c] * scale[:n_c],
                   "cost": np.array(best.history_cost)}
        stderr_phys = np.sqrt(np.abs(np.diag(cov_phys)))
        position_free = model.position_free
        info = {"R": best.r_diag, "fisher": M,
                "parameter_names": self.parameter_names(position_free) + getattr(
                    model, "calibration", ()),
                "parameters": phys, "parameter_stderr": stderr_phys,
                "parameter_covariance": cov_phys, "iterations": best.n_iterations,
                "starts": len(starts), "failed_starts": failures, "compiled": model.compiled,
                "start_costs": [f.nll for f in fits], "input": self.input,
                "fit_residuals": {name: best.e[:, j] for j, name in enumerate(OUTPUT_CHANNELS)}}
        start_info, warnings = start_report(labels, fits, k_best, stderr_phys / np.abs(scale),
                                            failures, n_c)
        warnings += _tables_fit.record_tables(info, model, flight, holds)  # names, notes
        info.update(start_info)
        info.update(aiding_info(prob, best.e))
        warnings += aiding_warnings(self.aiding, flight)
        if "initial_state_sd" in flight.metadata and not self.estimate_initial_velocity:
            warnings.append(HELD_VELOCITY_WARNING)
        info.update(position_report(self, model, phys, stderr_phys))
        for t in self.rx_free():
            info[f"rx{t + 1}_m"] = info["accel_positions_m"].ravel()[3 * t]
        if self.estimate_delay:
            info["delay_s"] = float(phys[i_delay])
            info["delay_stderr_s"] = float(stderr_phys[i_delay])
        warnings += _oe_wind.wind_report(self, position_free, phys, stderr_phys, info)
        warnings += _oe_attitude.attitude_report(self, flight, phys, stderr_phys, info)
        warnings += airdata_report(self, flight, prob, best.e, phys, stderr_phys, info)
        warnings += skew_report(self.estimate_skew, info, model, best.p, phys, cov_phys, search)
        if model.n_imu:
            keep = slice(0, n_p - len(aiding_names(self.aiding, self.estimate_skew)))
            imu_info, found = imu_error_report(info["parameter_names"][keep],
                                               imu_error_names(self.imu_errors), phys[keep],
                                               stderr_phys[keep], cov_phys[keep, keep])
            info.update(imu_info)
            warnings += found
        return EstimationResult(
            estimator=self.name, names=names, theta=theta, stderr=np.sqrt(np.abs(np.diag(cov))),
            covariance=cov, cost=best.nll, success=best.converged, message=best.message,
            n_evaluations=n_evals, n_iterations=n_iter, history=history, info=info,
            warnings=tuple(warnings))
