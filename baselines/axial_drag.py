"""Axial drag from an axial accelerometer and a GNSS track: the range-test reduction.

A cheap flight computer logs one accelerometer axis along the rocket (no lateral axes, no
gyros), GNSS positions and a barometer. Range tables are reduced from such data by fitting
a point mass whose only aerodynamic force is the drag along the airspeed to the tracked
trajectory (trajectory matching). This method does that by maximum likelihood
(output-error; :mod:`baselines._axial_model`): the outputs are the axial accelerometer
``(1 + scale) f_x + bias``, the GNSS positions (and velocities when logged) and the
barometer's pressure altitude ``h0 - pd``; the parameters are the Cx table in Mach (the
airframe's ``[tables] Cx`` knots, the option ``cx_knots``, or a constant Cx), the
accelerometer's bias and scale factor (Gaussian priors), the initial position and
velocity and the barometer's origin altitude ``h0``. Gauss-Newton
(:func:`scipy.optimize.least_squares`) on the residuals weighted by the log's noise sd,
with the exact sensitivities; the covariance is the inverse information at the optimum.

Such a log determines Cx / m (the accelerometer and the track both see the specific
force): a mass given with an sd enters Cx's standard errors through the consider path
(:func:`aeroid.estimation.add_consider`), a wrong mass goes into Cx in proportion and no
fit check can see it. Every other coefficient is not determined by such a log and is
named so (``info["not_determined"]``, a warning).

A log reaching into the burn is fitted with the airframe's ``[thrust_curve]``: its thrust
inside the burn window and the mass along it enter the axial force at the time grid's
nodes, linear between them (:mod:`baselines._axial_motor`).

Input: a :class:`aeroid.flights.SuiteLog` (``read_suite_log``) or an
:class:`baselines._axial_log.AxialLog`. A :class:`aeroid.flights.Flight` holds no track:
the result is ``success=False`` saying so.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import scipy.optimize

from aeroid.errors import AeroidError, EstimatorError
from aeroid.estimation import (
    CoefficientSpec,
    EstimationResult,
    Estimator,
    add_consider,
    airframe_holds,
    exact_mass_note,
    failed_result,
)
from aeroid.flights import Flight, SuiteLog
from aeroid.model import NAMES, constants, tables
from baselines._axial_check import fit_check
from baselines._axial_log import AxialLog, axial_log
from baselines._axial_model import N_TRACK, PD, PN, VD, VN, propagate
from baselines._axial_motor import motor_on_grid

__all__ = ["AxialDragEstimator", "NOT_DETERMINED"]

#: Why every coefficient but Cx is not determined by an axial-only log.
NOT_DETERMINED = ("an axial accelerometer and a track see the axial force only: no "
                  "lateral force, moment or rate is measured")
#: Time grid merge tolerance [s]: sample times of two groups closer than this are one node.
TIME_TOLERANCE_S = 1e-6
#: Name of the trim factor (``info["nuisance"]``).
TRIM = "trim_factor"
#: Names of the initial state, the first nuisance parameters (``info["nuisance"]``).
TRACK_START = ("pn0", "pe0", "pd0", "vn0", "ve0", "vd0")
#: The axial accelerometer's bias [m/s^2] and scale factor, named like output-error's
#: IMU errors (``reading = (1 + s) f_x + b``).
IMU_ERRORS = ("bax1", "sax1")
#: Window [s] of the quadratic fit of the first GNSS positions that starts the velocity.
START_WINDOW_S = 1.0


def _grid(record: AxialLog) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    times = [record.t, record.gnss_t] + ([] if record.baro_t is None else [record.baro_t])
    merged = np.unique(np.concatenate(times))
    keep = np.concatenate([[True], np.diff(merged) > TIME_TOLERANCE_S])
    grid = merged[keep]

    def index(t: np.ndarray) -> np.ndarray:
        i = np.clip(np.searchsorted(grid, t - TIME_TOLERANCE_S), 0, grid.size - 1)
        return i

    found = {"accel": index(record.t), "gnss": index(record.gnss_t)}
    if record.baro_t is not None:
        found["baro"] = index(record.baro_t)
    return grid, found


def _start(record: AxialLog, cx0: float, k: int, bias0: float, scale0: float
           ) -> np.ndarray:
    t0 = record.t[0]
    near = record.gnss_t <= t0 + START_WINDOW_S
    if near.sum() < 3:
        near = np.arange(record.gnss_t.size) < 3
    dt = record.gnss_t[near] - t0
    fit = np.polynomial.polynomial.polyfit(dt, record.gnss[near, :3], min(2, near.sum() - 1))
    x0 = np.concatenate([fit[0], fit[1]])
    if record.has_velocity:
        x0[VN:] = record.gnss[0, 3:]
    h0 = []
    if record.baro_t is not None:
        assert record.baro_altitude is not None
        h0 = [float(record.baro_altitude[0] + x0[PD])]
    return np.concatenate([np.full(k, cx0), x0, [bias0, scale0], h0])


class _Hush(logging.Filter):
    """Drops this method's own INFO notes (said by the consider path's re-fits)."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not (record.levelno == logging.INFO
                    and record.getMessage().startswith("axial-drag: "))


@dataclass(frozen=True, kw_only=True)
class AxialDragEstimator(Estimator):
    """The Cx table from an axial accelerometer and a GNSS track (module docstring).

    Options
    -------
    cx_knots : tuple of float
        Knots [Mach] of the Cx table; empty: the airframe's ``[tables] Cx``, else a constant
        Cx.
    accel_bias_mps2 : float
        Prior mean of the axial accelerometer's bias [m/s^2] (a calibration; 0: none).
    accel_bias_sd_mps2 : float
        Prior sd of that bias [m/s^2].
    accel_scale : float
        Prior mean of its scale factor (a calibration; 0: none).
    scale_sd : float
        Prior sd of that scale factor.
    trim : bool
        Whether the trim's normal force in the gravity turn is in the model (its factor a
        free parameter, ``info["nuisance"]["trim_factor"]``; :mod:`baselines._axial_model`).
    max_iterations : int
        Most Gauss-Newton evaluations.
    """

    name: ClassVar[str] = "axial-drag"
    description: ClassVar[str] = ("Cx table from an axial accelerometer and a GNSS track "
                                  "(point-mass output-error)")
    fits_tables: ClassVar[bool] = True
    #: ``aeroid estimate LOG.toml`` fits a suite log with this method (aeroid/cli/_axial.py).
    reads_suite_log: ClassVar[bool] = True

    cx_knots: tuple[float, ...] = ()
    accel_bias_mps2: float = 0.0
    accel_bias_sd_mps2: float = 0.5
    accel_scale: float = 0.0
    scale_sd: float = 0.02
    trim: bool = True
    max_iterations: int = 100

    def __post_init__(self) -> None:
        for key in ("accel_bias_sd_mps2", "scale_sd"):
            value = getattr(self, key)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"option {key} must be a positive number, got {value!r}")
        if self.max_iterations < 1:
            raise ValueError(f"option max_iterations must be >= 1, got {self.max_iterations}")
        if self.cx_knots:
            tables.check_knots(self.cx_knots, "axial-drag: option cx_knots")

    def run(self, flight: Flight, rng: np.random.Generator) -> EstimationResult:
        """A :class:`Flight` has no GNSS track: a failed result saying what to give."""
        return failed_result(self.name, "axial-drag fits a suite log (aeroid.flights."
                             "read_suite_log) with an axial accelerometer and a GNSS track; "
                             "a Flight holds no track")

    def fit(self, flight: Any, *, rng: Any = None, progress: Any = None,
            holds: Any = None) -> EstimationResult:
        """Fit a suite log or an :class:`AxialLog`; a Flight goes the base class's way.

        Raises
        ------
        EstimatorError
            One line: what the log holds that the method cannot use or lacks
            (:func:`baselines._axial_log.axial_log`), a hold or prior, tables of other
            coefficients, a per-sample atmosphere, a bad seed.
        """
        if not isinstance(flight, SuiteLog | AxialLog):
            return super().fit(flight, rng=rng, progress=progress, holds=holds)
        record = flight if isinstance(flight, AxialLog) else axial_log(flight)
        spec = airframe_holds(record.airframe).merged(CoefficientSpec.coerce(holds))
        on_cx = sorted(n for n in (*spec.held, *spec.priors) if n.split("@")[0] == "Cx")
        if on_cx:
            raise EstimatorError(f"axial-drag: {', '.join(on_cx)} held or given a prior: "
                                 "this method fits Cx free (it is all it estimates)")
        if holds is not None and not CoefficientSpec.coerce(holds).empty:
            raise EstimatorError("axial-drag: holds and priors are not taken by this method "
                                 "(it estimates Cx alone; the others are not determined)")
        if not spec.empty:  # the airframe's own (a passive fin's): nothing to do with Cx
            record = dataclasses.replace(record, notes=(
                *record.notes, f"the airframe's {spec.describe()}: not used (those "
                "coefficients are not in a point-mass model)"))
        try:
            generator = np.random.default_rng(rng)
        except (TypeError, ValueError) as exc:
            raise EstimatorError(f"axial-drag: bad seed {rng!r}: {exc}") from None
        start = time.perf_counter()
        try:
            result = self._fit(record)
        except AeroidError:
            raise  # bad input found on the way: a user error, one line
        except Exception as exc:  # failure is data (aeroid.estimation.Estimator.fit)
            text = " ".join(str(exc).split())
            result = failed_result(self.name, f"{type(exc).__name__}: {text}".rstrip(": "))
        result = dataclasses.replace(result, wall_time_s=time.perf_counter() - start)
        # the consider path's re-fits (the mass moved by +-1 sd, taken as exact) would say
        # their notes again, "mass taken as exact: 10.3 kg" among them: not this fit's
        logger, hush = logging.getLogger("aeroid"), _Hush()
        logger.addFilter(hush)
        try:
            return add_consider(self, record, result, rng=generator)
        finally:
            logger.removeFilter(hush)

    def _knots(self, record: AxialLog) -> tuple[tuple[float, ...], float, str]:
        airframe = record.airframe
        spec = airframe.tables
        if spec is not None:
            other = [name for name, _ in spec.knots if name != "Cx"]
            if other:
                raise EstimatorError(f"axial-drag: [tables] {', '.join(other)}: not "
                                     f"determined by an axial-only log; table Cx only")
        sound = (spec.speed_of_sound(airframe.altitude_m) if spec is not None else
                 tables.TableSpec((("Cx", 1),)).speed_of_sound(airframe.altitude_m))
        if self.cx_knots:
            return tuple(self.cx_knots), sound, "option cx_knots"
        if spec is not None and "Cx" in dict(spec.knots):
            given = dict(spec.knots)["Cx"]
            if isinstance(given, int):  # a count: over the Mach range of a constant-Cx fit
                first = dataclasses.replace(self, cx_knots=(1.0,))._fit(record)
                start = [first.info["nuisance"][n][0] for n in TRACK_START]
                extra = [first.info["nuisance"][TRIM][0]] if self.trim else []
                grid, _ = _grid(record)
                track = propagate(np.array(start), np.concatenate([first.theta, extra]), grid,
                                  constants(airframe), (1.0,), sound, self.trim,
                                  motor_on_grid(airframe, grid)[0])
                speed = np.linalg.norm(track.states[:, VN:], axis=1)
                return (tables.choose_knots(speed / sound, given), sound,
                        f"[tables] Cx = {given} knots over the Mach range of a constant-Cx fit")
            return tuple(given), sound, "[tables] Cx"
        return (1.0,), sound, "constant"

    def _fit(self, record: AxialLog) -> EstimationResult:
        airframe = record.airframe
        const = constants(airframe)
        if not np.isfinite(const.rho):
            raise EstimatorError("axial-drag: the airframe's atmosphere is per sample; this "
                                 "method takes a constant density (altitude_m or density_kgm3)")
        knots, sound, origin = self._knots(record)
        k = len(knots)
        names = (("Cx",) if origin == "constant"
                 else tuple(tables.point_name("Cx", knot) for knot in knots))
        grid, index = _grid(record)
        motor, motor_note = motor_on_grid(airframe, grid)  # a thrust curve's, or None
        baro = record.baro_t is not None
        n_c = k + int(self.trim)  # the table points, then the trim factor
        nuisance = (*((TRIM,) if self.trim else ()), *TRACK_START, *IMU_ERRORS,
                    *(("h0",) if baro else ()))
        n_dyn = n_c + N_TRACK
        bias_j, scale_j = n_dyn, n_dyn + 1
        gnss_cols = record.gnss.shape[1]
        prior_mean = np.array([self.accel_bias_mps2, self.accel_scale])
        prior_sd = np.array([self.accel_bias_sd_mps2, self.scale_sd])

        def model(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            track = propagate(theta[n_c:n_dyn], theta[:n_c], grid, const, knots, sound,
                              self.trim, motor)
            parts, jac = [], []
            i = index["accel"]
            gain = 1.0 + theta[scale_j]
            pred = gain * track.force[i] + theta[bias_j]
            d = np.zeros((i.size, theta.size))
            d[:, :n_dyn] = gain * track.force_sensitivity[i]
            d[:, bias_j] = 1.0
            d[:, scale_j] = track.force[i]
            parts.append((record.accel - pred) / record.accel_sd)
            jac.append(-d / record.accel_sd)
            i = index["gnss"]
            cols = [PN, PN + 1, PD] + ([VN, VN + 1, VD] if gnss_cols > 3 else [])
            for j, col in enumerate(cols):
                d = np.zeros((i.size, theta.size))
                d[:, :n_dyn] = track.sensitivity[i, col]
                parts.append((record.gnss[:, j] - track.states[i, col]) / record.gnss_sd[j])
                jac.append(-d / record.gnss_sd[j])
            if baro:
                assert record.baro_altitude is not None and record.baro_sd is not None
                i = index["baro"]
                d = np.zeros((i.size, theta.size))
                d[:, :n_dyn] = -track.sensitivity[i, PD]
                d[:, -1] = 1.0
                pred = theta[-1] - track.states[i, PD]
                parts.append((record.baro_altitude - pred) / record.baro_sd)
                jac.append(-d / record.baro_sd[:, None])
            d = np.zeros((2, theta.size))
            d[[0, 1], [bias_j, scale_j]] = 1.0 / prior_sd
            parts.append((theta[[bias_j, scale_j]] - prior_mean) / prior_sd)
            jac.append(d)
            return np.concatenate(parts), np.vstack(jac)

        cx0 = float(airframe.prior_vector()[NAMES.index("Cx")])
        theta0 = _start(record, cx0, k, self.accel_bias_mps2, self.accel_scale)
        if self.trim:  # the trim factor starts at 0
            theta0 = np.insert(theta0, k, 0.0)
        cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

        def cached(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            key = theta.tobytes()
            if key not in cache:
                cache.clear()
                cache[key] = model(theta)
            return cache[key]

        solution = scipy.optimize.least_squares(
            lambda th: cached(th)[0], theta0, jac=lambda th: cached(th)[1], method="trf",
            x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-10, max_nfev=self.max_iterations)
        theta = solution.x
        residuals, jacobian = model(theta)
        try:
            covariance = np.linalg.inv(jacobian.T @ jacobian)
        except np.linalg.LinAlgError:
            covariance = np.full((theta.size, theta.size), np.nan)
        se = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
        channels = ["accel", *(["pn", "pe", "pd", "vn", "ve", "vd"][:gnss_cols]),
                    *(["baro"] if baro else [])]
        sizes = [record.t.size, *([record.gnss_t.size] * gnss_cols),
                 *([record.baro_t.size] if record.baro_t is not None else [])]
        verdict = fit_check(residuals, channels, sizes, IMU_ERRORS, 1.0 + theta[scale_j])
        converged = solution.status > 0
        success = converged and verdict.passed
        message = ("" if success else verdict.message if converged else
                   f"not converged after {solution.nfev} evaluations: {solution.message}")
        speed = np.linalg.norm(propagate(theta[n_c:n_dyn], theta[:n_c], grid, const, knots,
                                         sound, self.trim, motor).states[:, VN:], axis=1)
        others = tuple(n for n in NAMES if n != "Cx")
        notes = [*record.notes,
                 (f"Cx: constant over the fitted track's Mach {speed.min() / sound:.3g}.."
                  f"{speed.max() / sound:.3g}" if origin == "constant" else
                  f"Cx: {origin} at Mach {', '.join(f'{kn:g}' for kn in knots)}") + ", speed of "
                 f"sound {sound:.5g} m/s, density {const.rho:.5g} kg/m^3 (the airframe's, "
                 "along the whole track)",
                 "point mass: drag along the airspeed, no lever arm, " + (
                     "the trim's normal force a free share of gravity's normal component"
                     if self.trim else "no lateral force (trim = false)"),
                 *([motor_note] if motor_note else [])]
        mass_note = exact_mass_note(airframe)
        if mass_note and "mass_kg" not in airframe.mass_sd:
            notes.append(mass_note.split(";")[0])
        warnings = (f"axial-drag: {', '.join(others)} not determined ({NOT_DETERMINED}); not "
                    "estimated",)
        for line in (*notes, warnings[0]):  # what was read, assumed and left out, said
            logging.getLogger("aeroid").info(line if line.startswith("axial-drag")
                                             else f"axial-drag: {line}")
        return EstimationResult(
            estimator=self.name, names=names, theta=theta[:k], stderr=se[:k],
            covariance=covariance[:k, :k], cost=float(0.5 * residuals @ residuals),
            success=bool(success), message=message, warnings=warnings,
            n_evaluations=int(solution.nfev), n_iterations=int(solution.njev or 0),
            info={"nuisance": {n: (float(v), float(s)) for n, v, s in
                               zip(nuisance, theta[k:], se[k:], strict=True)},
                  "not_determined": dict.fromkeys(others, NOT_DETERMINED),
                  "fit_check": verdict.info,
                  "imu_errors": {n: float(v) for n, v in zip(
                      IMU_ERRORS, theta[[bias_j, scale_j]], strict=True)},
                  "imu_error_stderr": {n: float(v) for n, v in zip(
                      IMU_ERRORS, se[[bias_j, scale_j]], strict=True)},
                  "knots": list(knots),
                  "speed_of_sound_mps": sound, "notes": notes,
                  "mach_range": [float(speed.min() / sound), float(speed.max() / sound)],
                  "span_s": [float(grid[0]), float(grid[-1])],
                  "options": self.options()})
