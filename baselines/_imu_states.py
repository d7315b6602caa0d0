"""The IMU's errors as states of the augmented-state filters (EKF, UKF; private).

:class:`ImuFilterOptions` adds to :class:`baselines._common.AugmentedFilterOptions` the
option ``imu_errors``: a bias per output channel and, with ``"bias+scale"``, a scale
factor, constant states in the sensor law ``y_meas = (1 + s) y_model + b`` of
:func:`aeroid.flights.simulate_suite` (as output-error's ``imu_errors``), the model
wrapped by :func:`baselines._kalman.with_sensor_errors`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar, Literal

import numpy as np

from aeroid.estimation import EstimationResult, nuisance_findings
from aeroid.flights import (
    IMU_ERROR_KINDS,
    MIL_SCALE_LENGTH_M,
    Flight,
    flight_record,
    imu_error_names,
    used_samples,
)
from aeroid.model import ACCEL_CHANNELS, OUTPUT_CHANNELS, U, V, W
from baselines import (
    _common,
    _kalman,
    _kalman_aiding,
    _kalman_air,
    _kalman_gust,
    _kalman_verdict,
    _kalman_wind,
)
from baselines._oe_aiding import (
    AIDING,
    RESIDUAL_NAMES,
    AidingSamples,
    aiding_samples,
    aiding_sources,
    aiding_warnings,
)

PassRunner = Callable[[_kalman.DiscreteModel, _common.FilterSetup], _kalman.FilterOutput]


@dataclass(frozen=True, kw_only=True)
class ImuFilterOptions(_kalman_air.AirFilterOptions, _common.AugmentedFilterOptions):
    """The augmented filters' options with the IMU's errors as states (not registered).

    Attributes
    ----------
    imu_errors : {"none", "bias", "bias+scale"}
        Also carry the IMU's errors as constant states (default ``"none"``): a bias per
        output channel and, with ``"bias+scale"``, a scale factor, in the sensor law
        ``y_meas = (1 + s) y_model + b`` (as output-error's ``imu_errors``), started at 0
        with the sd below, each pass afresh (started where the last pass ended, with
        ``PASS_INFLATION`` times its sd as the coefficients are, the EKF's passes did not
        settle: measured on one suite seed); reported in ``info['imu_errors']`` with
        ``info['imu_error_stderr']`` (the final filtered sd).
    imu_accel_bias_sd_mps2, imu_gyro_bias_sd_radps, imu_scale_sd : float
        Initial sd of those states [m/s^2, rad/s, -] (defaults 0.2, 0.005, 0.005: the
        reconstruction's priors, :func:`aeroid.reconstruction.reconstruct`). The initial
        rates' variance grows by what those errors do to the first gyro reading.
    aiding : {"none", "gnss-velocity", "gnss-velocity+ins-attitude"}
        ``"gnss-velocity"``: the flight's GNSS NED velocity samples (``metadata["aiding"]``,
        as output-error's ``aiding``) as three more measurements at their own samples, with
        the log's stated sd (:mod:`baselines._kalman_aiding`); default ``"none"``.
        ``"gnss-velocity+ins-attitude"``: also the INS's phi theta psi, on the circle.
    estimate_wind : bool or "auto"
        Also carry a steady wind (north, east, down [m/s]) as three constant states,
        started at 0 with ``wind_sd_mps`` as sd (later passes where the last ended, with
        the coefficients); default auto: unless the log says still air, said in one line
        (:mod:`baselines._wind_auto`; still air assumed where the filters cannot carry it:
        :func:`baselines._kalman_wind.blocked`). On noisy flights the carried passes walk
        along the along-path component and are refused (the default smoothed passes do
        not, nor with an airspeed: ``benchmarks/results/kalman_air.md``); reported in
        ``info['wind_ned_mps']`` and ``info['wind_stderr_mps']`` (the final filtered sd)
        with a one-line notice (:mod:`baselines._kalman_wind`).
    wind_sd_mps : float
        Initial sd of each wind component [m/s] (default 10).
    gust_sd_mps : float
        Intensity (sd) of three Gauss-Markov gust states [m/s] (north, east, down; the
        loads see the steady wind plus the gust, :mod:`baselines._kalman_gust`); default
        0: no gust states.
    estimate_gust_sd : bool
        Gust states with the intensity that maximises the first pass's innovation
        likelihood (default False); not with ``gust_sd_mps``.
    gust_scale_length_m : float
        The gusts' scale length ``L`` [m]: time constant ``L / V``, ``V`` the record's
        mean measured speed (default MIL-F-8785C's 533.4 m, the simulator's).

    Every fit with more than one pass is judged on its last pass
    (:mod:`baselines._kalman_verdict`): a coefficient or steady-wind state that it moved
    by more than ``SETTLE_LIMIT_SE`` of its standard error makes ``success=False``.
    The air-data options (``air_data``, ...): :class:`baselines._kalman_air.AirFilterOptions`.
    """

    leaves_out_saturated: ClassVar[bool] = True  # FilterSetup.mask

    imu_errors: Literal["none", "bias", "bias+scale"] = "none"
    imu_accel_bias_sd_mps2: float = 0.2
    imu_gyro_bias_sd_radps: float = 0.005
    imu_scale_sd: float = 0.005
    aiding: Literal["none", "gnss-velocity", "gnss-velocity+ins-attitude"] = "none"
    estimate_wind: bool | Literal["auto"] = "auto"
    wind_sd_mps: float = _kalman_wind.WIND_SD_MPS
    gust_sd_mps: float = 0.0
    estimate_gust_sd: bool = False
    gust_scale_length_m: float = MIL_SCALE_LENGTH_M

    def __post_init__(self) -> None:
        super().__post_init__()
        self.check_air_options()
        if self.imu_errors not in IMU_ERROR_KINDS:
            raise ValueError(f"imu_errors must be one of {', '.join(IMU_ERROR_KINDS)}, got "
                             f"{self.imu_errors!r}")
        if self.aiding not in AIDING:
            raise ValueError(f"aiding must be one of {', '.join(AIDING)}, got {self.aiding!r}")
        _kalman_wind.check_wind_option(self)  # true, false or auto (baselines._wind_auto)
        if not isinstance(self.estimate_gust_sd, bool):
            raise ValueError(f"estimate_gust_sd must be true or false, got "
                             f"{self.estimate_gust_sd!r}")
        if not self.gust_sd_mps >= 0:
            raise ValueError(f"gust_sd_mps must be >= 0, got {self.gust_sd_mps}")
        if self.estimate_gust_sd and self.gust_sd_mps > 0:
            raise ValueError("give gust_sd_mps or estimate_gust_sd = true, not both")
        for name in ("imu_accel_bias_sd_mps2", "imu_gyro_bias_sd_radps", "imu_scale_sd",
                     "wind_sd_mps", "gust_scale_length_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")

    @property
    def gusts(self) -> bool:
        """Whether the filter carries gust states."""
        return self.gust_sd_mps > 0 or self.estimate_gust_sd

    def imu_error_names(self) -> tuple[str, ...]:
        """Names of the IMU-error states: ``b`` + channel, then ``s`` + channel."""
        return imu_error_names(self.imu_errors)

    def setup(self, flight: Flight) -> _common.FilterSetup:
        """The shared start, with the wind states (``estimate_wind``) and the IMU-error
        states (``imu_errors``) appended."""
        setup = super().setup(flight)
        if _kalman_wind.carries_wind(self, flight):  # auto: resolved as the fit does
            setup = _kalman_wind.wind_setup(setup, self.wind_sd_mps)
        if self.gusts:  # the given intensity, or the search's start (replaced per trial)
            setup = _kalman_gust.gust_setup(setup, self.gust_sd_mps or 1.0,
                                            self.gust_phi(flight))
        names = self.imu_error_names()
        if not names:
            return setup
        n_accel = len(ACCEL_CHANNELS)
        sd = np.array([self.imu_scale_sd if n[0] == "s" else self.imu_accel_bias_sd_mps2
                       if OUTPUT_CHANNELS.index(n[1:]) < n_accel else self.imu_gyro_bias_sd_radps
                       for n in names])
        n, k = setup.x0.size, len(names)
        P0, Q = np.zeros((n + k, n + k)), np.zeros((n + k, n + k))
        P0[:n, :n], P0[n:, n:], Q[:n, :n] = setup.P0, np.diag(sd ** 2), setup.Q
        # the initial rates are the first gyro readings: as uncertain as their errors
        rates = np.arange(_common.RATES.start, _common.RATES.stop)
        spread = self.imu_gyro_bias_sd_radps ** 2 + (
            (self.imu_scale_sd * setup.x0[rates]) ** 2 if "s" in IMU_ERROR_KINDS[self.imu_errors]
            else 0.0)
        P0[rates, rates] += spread
        return setup._replace(x0=np.concatenate([setup.x0, np.zeros(k)]), P0=P0, Q=Q)

    def given_gust(self, sd_mps: float) -> ImuFilterOptions:
        """These options with the gust intensity ``sd_mps`` given."""
        return dataclasses.replace(self, gust_sd_mps=sd_mps, estimate_gust_sd=False)

    def gust_phi(self, flight: Flight) -> float:
        """The gusts' Gauss-Markov transition over one interval at the mean speed."""
        return _kalman_gust.gust_phi(flight.dt, self.mean_speed(flight), self.gust_scale_length_m)

    @staticmethod
    def mean_speed(flight: Flight) -> float:
        """The record's mean measured speed ``|u, v, w|`` [m/s]."""
        return float(np.mean(np.linalg.norm(flight.states()[:, [U, V, W]], axis=1)))

    def innovation_noise_law(self, out: _kalman.FilterOutput, setup: _common.FilterSetup
                             ) -> tuple[np.ndarray, np.ndarray]:
        """The shared refit, each channel on its innovations in the likelihood (the
        others, saturated samples, are NaN: :func:`with_mask`); the GNSS channels' law
        (``aiding``) stays the stated sd's."""
        out = _kalman_aiding.first_channels(out, setup.zs.shape[1])
        if np.all(np.isfinite(out.innovation)):
            return super().innovation_noise_law(out, setup)
        laws = []
        for c in range(setup.zs.shape[1]):
            rows = np.isfinite(out.innovation[:, c])
            one = _kalman.FilterOutput(out.x[rows], out.sd[rows], out.P, None, "",
                                       out.innovation[rows, c:c + 1],
                                       None if out.innovation_var is None
                                       else out.innovation_var[rows, c:c + 1],
                                       None if out.noise_var is None
                                       else out.noise_var[rows, c:c + 1])
            alone = setup._replace(zs=setup.zs[rows, c:c + 1], r_floor=setup.r_floor[c:c + 1])
            laws.append(super().innovation_noise_law(one, alone))
        return (np.array([float(a[0]) for a, _ in laws]),
                np.array([float(b[0]) for _, b in laws]))

    def run_imu_passes(self, flight: Flight, run_filter: PassRunner,
                       evaluations_per_pass: Callable[[_kalman.DiscreteModel], int]
                       ) -> EstimationResult:
        """:meth:`run_passes` on the model with the IMU-error states, and their report."""
        names = self.imu_error_names()
        passes: list[_kalman.FilterOutput] = []
        mask = used_samples(flight.metadata, OUTPUT_CHANNELS, flight.n_samples)
        samples = tuple(aiding_samples(flight, s) for s in aiding_sources(self.aiding)) or None
        if samples is not None:
            _kalman_wind.refuse_with(self, "aiding = gnss-velocity")
            _kalman_gust.refuse_with(self, "aiding = gnss-velocity")
        wind: list[_kalman.DiscreteModel] = []  # the model with the wind states, built once
        wind_first = _common.COEFFICIENTS.stop + len(self.position_free(flight))
        gust_first = wind_first + (len(_kalman_wind.WIND_NAMES) if self.estimate_wind else 0)
        if samples is not None:
            mask = _kalman_aiding.aided_mask(mask, flight.n_samples, len(OUTPUT_CHANNELS),
                                             samples)
        air = _kalman_air.air_plan(self, flight)  # air data as measurements (or None)
        air_var, air_models = [None if air is None else air.var], {}
        if air is not None and mask is not None:
            mask = np.hstack([mask, np.ones((flight.n_samples, len(air.channels)), bool)])
        wind_columns = (() if not self.estimate_wind else (wind_first,)) + (
            (gust_first,) if self.gusts else ())

        def one_pass(model: _kalman.DiscreteModel, setup: _common.FilterSetup,
                     trial: bool = False) -> _kalman.FilterOutput:
            if self.estimate_wind or self.gusts:  # in place of the still-air model
                if not wind:
                    wind.append(_kalman_wind.wind_model(
                        flight, self.substeps, flight_record(flight, self.input, self.delay_s),
                        setup.position_free))
                    if self.gusts:  # the loads see the steady wind plus the gust
                        wind[0] = _kalman_gust.with_gusts(wind[0], self.gust_phi(flight),
                                                          steady=self.estimate_wind)
                model = wind[0]
                if self.estimate_wind and passes and passes[-1].failed_at is None:
                    setup = _kalman_wind.carried(setup, passes[-1], wind_first)  # as theta
            if air is not None:  # the calibration states after the wind's and the gusts'
                if id(model) not in air_models:
                    air_models[id(model)] = (model, _kalman_air.air_model(
                        model, flight, air, self.input, self.delay_s, wind_columns))
                model = air_models[id(model)][1]
                setup = _kalman_air.air_setup(setup, air, air_var[0], passes[-1] if (
                    passes and passes[-1].failed_at is None) else None)
            if names:
                model = _kalman.with_sensor_errors(model, len(names))
            if samples is not None:
                model = _kalman_aiding.with_aiding(model, samples)
                setup = _kalman_aiding.aided_setup(setup, samples)
            if mask is None:
                out = run_filter(model, setup)
            else:  # saturated samples leave the likelihood
                out = masked_output(run_filter(with_mask(model, setup.zs, mask), setup), mask)
            if not trial:
                passes.append(out)
                if air is not None and out.failed_at is None and len(passes) <= _common.LAW_REFITS:
                    air_var[0] = _kalman_air.refit_variances(out, air)  # as the IMU's law
            return out

        search, runner = None, self
        if self.estimate_gust_sd:  # trial first passes over the intensity, then the passes
            search = _kalman_gust.search_gust_sd(lambda sd: one_pass(
                None, self.given_gust(sd).setup(flight), trial=True).neg_log_likelihood)
            runner = self.given_gust(search.sd_mps)
        result = runner.run_passes(flight, one_pass, evaluations_per_pass)
        judged = np.r_[_common.COEFFICIENTS.start:_common.COEFFICIENTS.stop, wind_first:gust_first]
        result = _kalman_verdict.settle_verdict(
            result, passes, judged,
            (*result.names, *(_kalman_wind.WIND_NAMES if self.estimate_wind else ())))
        if "fit_residuals" in result.info and flight.metadata.get("saturated"):
            # the fit check reads the innovations in the likelihood (saturated left out)
            kept = {c: e[np.isfinite(e)] for c, e in result.info["fit_residuals"].items()}
            result = dataclasses.replace(result, info={**result.info, "fit_residuals": kept})
        if warned := aiding_warnings(self.aiding, flight, self.name):
            result = dataclasses.replace(result, warnings=(*result.warnings, *warned))
        good = [out for out in passes if out.failed_at is None]
        if samples is not None and good and "fit_residuals" in result.info:
            result = dataclasses.replace(result, info={**result.info, **aiding_innovations(
                good[-1], samples, flight.n_samples, result.info["fit_residuals"])})
        if not good or not np.all(np.isfinite(result.theta)):
            return result
        last = good[-1]  # the pass the result is (run_passes keeps the last good one)
        if air is not None:
            steady = wind_first if self.estimate_wind and not self.gusts else None
            found, said = _kalman_air.air_report(last, air, air_var[0], self.name, flight, steady)
            result = dataclasses.replace(result, info={**result.info, "air_data": found[
                "air_data"], "fit_residuals": {**result.info.get("fit_residuals", {}),
                                               **found["air_innovations"]}},
                                         warnings=(*result.warnings, *said))
        if self.estimate_wind:
            found, notice = _kalman_wind.wind_report(last, wind_first)
            result = dataclasses.replace(result, info={**result.info, **found},
                                         warnings=(*result.warnings, notice))
        if self.gusts:
            found, notice = _kalman_gust.gust_report(
                last, gust_first, runner.gust_sd_mps, self.gust_scale_length_m,
                self.mean_speed(flight), "given" if search is None else search.describe(),
                flight.dt, self.name)
            if search is not None:
                found["gust_sd_trials"] = search.trials
            both = (_kalman_gust.BOTH_WARNING,) if self.estimate_wind and (
                air is None or "airspeed" not in air.channels) else ()  # it pins the walk
            result = dataclasses.replace(result, info={**result.info, **found},
                                         warnings=(*result.warnings, notice, *both))
            if result.success and found["gust_verdict_refusal"]:
                result = dataclasses.replace(result, success=False,
                                             message=found["gust_verdict_refusal"])
        if not names:
            return result
        k = len(names)
        x, P = last.x[-1], last.P
        info = dict(result.info)
        info["imu_errors"] = dict(zip(names, x[-k:].tolist(), strict=True))
        info["imu_error_stderr"] = dict(zip(names, np.sqrt(np.diag(P)[-k:]).tolist(),
                                            strict=True))
        keep = list(range(_common.COEFFICIENTS.start, _common.COEFFICIENTS.stop)) + list(
            range(x.size - k, x.size))
        warnings = nuisance_findings((*result.names, *names), x[keep], P[np.ix_(keep, keep)],
                                     names)
        return dataclasses.replace(result, info=info,
                                   warnings=(*result.warnings, *warnings))


def with_mask(model: _kalman.DiscreteModel, zs: np.ndarray, mask: np.ndarray
              ) -> _kalman.DiscreteModel:
    """Return ``model`` whose masked measurements (``mask`` False) carry no information.

    At a masked entry the predicted measurement is the measurement itself and its row of
    ``H`` is zero (for the UKF: the same value at every sigma point), so its innovation is
    zero, its innovation covariance is its noise variance alone and uncorrelated with the
    others, and its column of the gain is zero: the update equals the update on the
    other measurements alone, exactly (the Kalman filter without those measurements;
    ``tests/unit/test_kalman_mask.py``). :func:`masked_output` then marks them NaN.

    Parameters
    ----------
    model : DiscreteModel
    zs : ndarray, shape (n, dim_z)
        The measurements.
    mask : ndarray of bool, shape (n, dim_z)
        True for the measurements in the likelihood.
    """
    observe, observe_batch = model.observe, model.observe_batch

    def masked_observe(x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        z, H = observe(x, k)
        if mask[k].all():
            return z, H
        out = ~mask[k]
        z, H = np.array(z, dtype=float), np.array(H, dtype=float)
        z[out], H[out] = zs[k, out], 0.0
        return z, H

    def masked_batch(X: np.ndarray, k: int) -> np.ndarray:
        assert observe_batch is not None
        rows = observe_batch(X, k)
        if mask[k].all():
            return rows
        rows = np.array(rows, dtype=float)
        rows[:, ~mask[k]] = zs[k, ~mask[k]]
        return rows

    return dataclasses.replace(model, observe=masked_observe,
                               observe_batch=None if observe_batch is None else masked_batch)


def masked_output(out: _kalman.FilterOutput, mask: np.ndarray) -> _kalman.FilterOutput:
    """The pass with the masked entries' innovation and its variances NaN (not measured)."""
    def nan(a: np.ndarray | None) -> np.ndarray | None:
        return None if a is None else np.where(mask, a, np.nan)

    return dataclasses.replace(out, innovation=nan(out.innovation),
                               innovation_var=nan(out.innovation_var),
                               noise_var=nan(out.noise_var))


def aiding_innovations(out: _kalman.FilterOutput, samples: tuple[AidingSamples, ...], n: int,
                       residuals: dict) -> dict:
    """The aiding innovations of the second half (as the IMU's) for the fit check, against
    the stated sd, and ``info["aiding"]``."""
    m = len(OUTPUT_CHANNELS)
    residuals, signals, noise_sd, counts = dict(residuals), {}, {}, {}
    for i, s in enumerate(samples):
        k = s.index[s.index >= n // 2]
        names = RESIDUAL_NAMES[s.source]
        residuals.update({c: out.innovation[k, m + 3 * i + j] for j, c in enumerate(names)})
        noise_sd.update(dict(zip(names, s.sd.tolist(), strict=True)))
        signals.update({c: s.z[:, j] - np.mean(s.z[:, j]) for j, c in enumerate(names)})
        counts[s.source] = int(s.index.size)
    return {"fit_residuals": residuals, "fit_noise_sd": noise_sd, "fit_signals": signals,
            "aiding": {"channels": tuple(noise_sd), "n_samples": sum(counts.values()),
                       "n_samples_per_source": counts,
                       "noise": "the log's stated sd (not estimated)"}}
