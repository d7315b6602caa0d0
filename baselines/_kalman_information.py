"""The gust filters' standard errors from the innovations' information (issue 26; private).

The augmented EKF/UKF with gust states (:mod:`baselines._kalman_gust`) reported the final
filtered covariance of its coefficient states as their covariance. In Dryden turbulence
that covariance is too small: over 20 flights each in Dryden sd 3 m/s alone and with a
5 m/s steady wind, coverage of the 95 % intervals 0.789 and 0.789, every coefficient
within 3 se on 11/20 and 12/20 flights (``benchmarks/results/gust_stderr_still.md``,
``gust_stderr_steady.md``).

``gust_stderr = innovations``: the covariance is the inverse
of the Fisher information of the innovations of the filter-error method's filter (Maine
& Iliff, NASA RP-1168, ch. 5; Jategaonkar, *Flight Vehicle System Identification*, ch. 5),
evaluated at the filter's estimate and at the intensity that maximises that likelihood
there: the coefficients and the gust intensity are parameters, the gusts are integrated
out by the filter, and

    M_ij = sum_k [dnu_i^T S^-1 dnu_j + 1/2 tr(S^-1 dS_i S^-1 dS_j)]

with ``nu_k`` the innovations, ``S_k`` their covariance and ``dnu``, ``dS`` their
central-difference sensitivities through the whole filter (the gain's dependence on the
parameters included). The code is filter-error's (:mod:`baselines._fem_fit`:
``sensitivities``, ``score_information``, ``nll``; its start from
:mod:`baselines._fem_setup`), so at filter-error's optimum the figures are the ones
filter-error reports. The coefficients' covariance is the coefficient block of ``M^-1``
(the intensity's uncertainty included). Measured on the same flights: coverage 0.872
and 0.850, every coefficient within 3 se on 20/20 and 16/20: better, not calibrated. The
information is the likelihood's curvature at a point that is not the likelihood's
optimum: the filter's estimate scatters more than the Cramér-Rao bound (mean error 15.8
against filter-error's 13.1 %), so the result says so in one line and
``info['intervals']['calibrated']`` is False (as with the filtered covariance in
turbulence).

``gust_stderr = one-step`` (the default, ``auto``, where built): the estimate is moved by
one Fisher-scoring step of that likelihood, ``-M^-1 g`` (Le Cam's one-step estimator:
from a consistent start one Newton or scoring step is asymptotically efficient, with
covariance ``M^-1``). Measured (``benchmarks/results/gust_default_still.md``, Dryden sd
3 m/s, seeds 1-20): coverage 0.956 (``innovations``: 0.872), 20/20 passed and within 3 se,
mean error filter-error's to 0.01 % (13.08 against 13.07 %; ``innovations`` 15.80 %): it
lands where filter-error converges (0.13 se from it on the test's flight); with a 5 m/s
steady wind as well, 1.000 on seeds 1-10. Cost: 0.1 s of CPU more than ``innovations``
per fit (median of seeds 1-8, 2.65 s per fit: ``gust_default_cost.md``): hence the
default. Filter-error alone is cheaper still.
The reported point is the judged one: its covariance is ``M^-1`` there, and the fit check,
the gust and steady-wind verdicts and a settle verdict (the next scoring step) read
filter-error's filter at it (:mod:`baselines._kalman_onestep`). The user's holds and
priors are tested by filter-error's likelihood ratio (:mod:`baselines._kalman_holds`).
The mathematics: :mod:`baselines._kalman_likelihood`.

Not built (one line each, ``gust_stderr = filtered`` with a warning under ``auto``): with
``estimate_wind``, IMU-error, aiding, air-data or sensor-position states, which
filter-error's filter does not have, nor on a flight with saturated samples (the filters
leave them out of their likelihood, filter-error's filter does not). Not tried: the
Dryden transverse components as second-order states (filter-error's first-order gusts
give calibrated intervals at its optimum, so the gusts' order is not what the filtered
covariance lacks).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from aeroid.errors import EstimatorError
from aeroid.estimation import EstimationResult
from aeroid.flights import Flight, used_samples
from aeroid.model import NAMES, OUTPUT_CHANNELS
from baselines import _kalman_air, _kalman_holds, _kalman_onestep, _kalman_verdict
from baselines._kalman_likelihood import (
    InnovationCovariance,
    gust_problem,
    innovation_covariance,
    likelihood_gust_sd,
    noise_at,
    one_step_point,
    point,
    scoring_step,
)

#: The choices of ``gust_stderr`` (:class:`baselines.ekf.ExtendedKalmanEstimator`, ukf).
GUST_STDERR = ("auto", "filtered", "innovations", "one-step")
#: Said when a gust fit keeps the filtered covariance (measured: README, "Gust states
#: against filter-error on the same flights").
FILTERED_WARNING = ("{who}: the standard errors are the final filtered covariance's ({why}); "
                    "with gust states in Dryden turbulence those covered 0.76-0.82 of the 95 % "
                    "intervals (8 flights, sd 3 m/s, alone and with a steady wind): too small")
#: Said with ``gust_stderr = innovations`` in turbulence (the likelihood's intensity above
#: :data:`CALM_GUST_SD_MPS`): measured, ``benchmarks/results/gust_stderr_*.md``.
UNCALIBRATED_WARNING = (
    "{who}: in turbulence these intervals are not calibrated: the information is the "
    "likelihood's, the estimate the filter's, which scatters more (measured in Dryden sd "
    "3 m/s: 95 % intervals covered {coverage}); gust_stderr = one-step (the default) or "
    "method filter-error give calibrated ones (0.96-0.97 on the same flights)")
#: Measured coverage quoted in :data:`UNCALIBRATED_WARNING` (``benchmarks/results/
#: gust_stderr_still.md``, ``gust_stderr_steady.md``).
INNOVATIONS_COVERAGE = ("0.87 and 0.85 on 20 flights each without and with a 5 m/s steady "
                        "wind, the filtered covariance's 0.79")
#: What each choice's intervals covered in Dryden sd 3 m/s (``info['intervals']``;
#: ``benchmarks/results/gust_stderr_*.md``, README "The gust filters' intervals").
MEASURED_COVERAGE = {"one-step": "0.96-0.97", "innovations": "0.85-0.87",
                     "filtered": "0.76-0.82"}
#: Below this likelihood intensity [m/s] the air is taken as calm: the intensity is held
#: (at the search's lower bound, 0.1 m/s, where the still-air flights' estimate is: README)
#: and the warning is not said.
CALM_GUST_SD_MPS = 0.2


def check_gust_stderr(est: Any) -> None:
    """Raise ``ValueError`` for a ``gust_stderr`` not in :data:`GUST_STDERR`."""
    if est.gust_stderr not in GUST_STDERR:
        raise ValueError(f"gust_stderr must be one of {', '.join(GUST_STDERR)}, got "
                         f"{est.gust_stderr!r}")


def _not_built(est: Any, flight: Flight) -> str:
    """What keeps the innovations' information from this fit ('' when nothing)."""
    for on, what in ((est.estimate_wind, "estimate_wind"),
                     (est.imu_errors != "none", f"imu_errors = {est.imu_errors}"),
                     (est.aiding != "none", f"aiding = {est.aiding}"),
                     (_kalman_air.air_plan(est, flight) is not None, "air data as measurements"),
                     (bool(est.position_free(flight)), "estimated sensor positions"),
                     (used_samples(flight.metadata, OUTPUT_CHANNELS, flight.n_samples)
                      is not None, "saturated samples left out")):
        if on:
            return what
    return ""


def refuse(est: Any, flight: Flight) -> None:
    """Raise the one-line error for ``gust_stderr = innovations`` or ``one-step`` where it
    is not built."""
    if est.gust_stderr in ("auto", "filtered"):
        return
    if not est.gusts:
        raise EstimatorError(f"{est.name}: gust_stderr = {est.gust_stderr} needs gust states "
                             "(gust_sd_mps > 0 or estimate_gust_sd = true)")
    blocked = _not_built(est, flight)
    if blocked:
        raise EstimatorError(f"{est.name}: gust_stderr = {est.gust_stderr} with {blocked} is "
                             "not built (filter-error's filter has none of it); set "
                             "gust_stderr = filtered")


def _intervals(result: EstimationResult, source: str, calibrated: bool) -> dict:
    """``info['intervals']``: where the se came from and whether they are calibrated (False:
    known to undercover in turbulence, measured)."""
    return {**result.info, "intervals": {"source": source, "calibrated": calibrated,
                                         "measured_coverage_turbulence": MEASURED_COVERAGE[
                                             source]}}


def _kept_filtered(est: Any, result: EstimationResult, why: str, calm: bool
                   ) -> EstimationResult:
    """The filtered covariance kept: not calibrated unless the air is calm, said."""
    said = () if calm else (FILTERED_WARNING.format(who=est.name, why=why),)
    return dataclasses.replace(result, info=_intervals(result, "filtered", calm),
                               warnings=(*result.warnings, *said))


def with_gust_stderr(est: Any, flight: Flight, result: EstimationResult, holds: Any = None
                     ) -> EstimationResult:
    """``result`` (a gust fit of ``est``, EKF or UKF) with ``gust_stderr`` applied and the
    user's holds and priors tested (:mod:`baselines._kalman_holds`).

    ``one-step`` (and ``auto`` where built): the estimate moved by one Fisher-scoring step
    (:func:`baselines._kalman_likelihood.one_step_point`), its covariance the inverse of
    the information there, its fit check and verdicts at that point
    (:mod:`baselines._kalman_onestep`); ``innovations``: the filter's estimate with the
    information's covariance at it and the intensity that maximises the likelihood there
    (:func:`baselines._kalman_likelihood.likelihood_gust_sd`), said not calibrated in
    turbulence. The filter's own estimate and covariance are kept in
    ``info['theta_filtered']``, ``info['stderr_filtered']``,
    ``info['covariance_filtered']``; ``info['intervals']`` says where the se came from and
    whether they are calibrated. ``auto`` where not built, or ``filtered``: the filtered
    ones, said not calibrated in turbulence.
    """
    if not est.gusts:
        return result
    calm_filter = float(result.info.get("gust_sd_mps", 0.0)) < CALM_GUST_SD_MPS
    blocked = _not_built(est, flight)
    if blocked:
        why = ("gust_stderr = filtered" if est.gust_stderr == "filtered" else
               f"with {blocked} the innovations' information is not built")
        out = _kept_filtered(est, result, why, calm_filter)
        return dataclasses.replace(out, warnings=(*out.warnings, *_kalman_holds.untested_warning(
            est.name, holds, f"with {blocked} filter-error's filter is not built")))
    if not np.all(np.isfinite(result.theta)):  # a refused fit's se are reported too
        return result
    if est.gust_stderr == "filtered":
        result = _kept_filtered(est, result, "gust_stderr = filtered", calm_filter)
        if not _kalman_holds.tested(holds):
            return result
    problem, noise = gust_problem(flight, result.theta, scale_length_m=est.gust_scale_length_m,
                                  substeps=est.substeps, input_mode=est.input,
                                  delay_s=est.delay_s, holds=holds)
    R = noise_at(problem, noise, float(result.info["gust_sd_mps"]))
    if est.gust_stderr == "filtered":  # the holds tested from the filter's estimate
        out, start = result, point(problem, likelihood_gust_sd(problem, R))
        return _kalman_holds.with_hold_test(est.name, out, problem, start, noise, R, holds,
                                            flight)
    sd = likelihood_gust_sd(problem, R)
    calm = sd < CALM_GUST_SD_MPS  # at the search's lower bound: held there
    found = innovation_covariance(problem, noise, sd, R=R, sigma_free=not calm)
    if not found.ok:
        out = _kept_filtered(est, result, "the innovations' information was not invertible "
                             "at the estimate", calm)
        return _kalman_holds.with_hold_test(est.name, out, problem, point(problem, sd), noise,
                                            R, holds, flight)
    info = {**result.info, "theta_filtered": result.theta, "stderr_filtered": result.stderr,
            "covariance_filtered": result.covariance}
    if est.gust_stderr == "innovations":
        said = () if calm else (UNCALIBRATED_WARNING.format(
            who=est.name, coverage=INNOVATIONS_COVERAGE),)
        out = _reported(est, dataclasses.replace(result, info=info), found, said,
                        "innovations", calm)
        return _kalman_holds.with_hold_test(est.name, out, problem, point(problem, sd), noise,
                                            R, holds, flight)
    p, length = one_step_point(problem, found)
    theta, _, sigma = problem.unpack(p[None])
    at = innovation_covariance(dataclasses.replace(problem, theta_base=theta[0]), noise,
                               float(sigma[0]), R=R, sigma_free=not calm)
    if not at.ok:
        failed = dataclasses.replace(result, theta=theta[0], success=False, info=info,
                                     message=f"{est.name}: the innovations' information at "
                                     "the one-step estimate is not invertible: no se")
        return _reported(est, failed, found, (), "one-step", False)
    names = (*(NAMES[i] for i in problem.free), "gust_sd_mps")
    judged = _kalman_onestep.judge(at.runs, scoring_step(at)[1], names, float(sigma[0]),
                                   -flight.dt / math.log(problem.decay), flight.dt, est.name)
    moved = np.max(np.abs(theta[0] - result.theta)[problem.free] / at.stderr[problem.free])
    said = [f"{est.name}: gust_stderr = one-step: the estimate is the filter's moved by one "
            f"Fisher-scoring step of the innovations' likelihood (Le Cam's one-step "
            f"estimator; step length {length:g}, at most {moved:.2f} se), judged there (its "
            "innovations, gust path and next step)"]
    filter_refused = _kalman_verdict.refused_by_verdict(result)
    if filter_refused:
        said.append(f"{est.name}: the filter's own estimate was refused ({result.message}); "
                    "the one-step estimate reported is judged on its own")
    success, message = result.success, result.message
    if result.success or filter_refused:
        success, message = judged.ok, judged.message
    info = {**info, **judged.info, "gust_verdict_filtered": result.info.get("gust_verdict"),
            "one_step": {**judged.info["one_step"], "step_length": length,
                         "filter_success": result.success, "filter_message": result.message}}
    out = _reported(est, dataclasses.replace(result, theta=theta[0], success=success,
                                             message=message, info=info), at, tuple(said),
                    "one-step", True)
    return _kalman_holds.with_hold_test(est.name, out, problem, p, noise, R, holds, flight)


def _reported(est: Any, result: EstimationResult, found: InnovationCovariance,
              said: tuple[str, ...], source: str, calibrated: bool) -> EstimationResult:
    """``result`` with ``found``'s covariance and ``info['gust_information']``, said."""
    free = found.stderr > 0
    filtered = result.info["stderr_filtered"]
    ratio = found.stderr[free] / filtered[free]
    info = {**_intervals(result, source, calibrated),
            "gust_information": {"information": found.information,
                                 "gust_sd_mps": found.gust_sd_mps,
                                 "gust_sd_stderr_mps": found.gust_sd_stderr_mps,
                                 "noise": found.noise_source,
                                 "measurement_noise_var": found.R}}
    notice = (f"{est.name}: standard errors from the innovations' information at the estimate "
              f"(filter-error's likelihood, the gusts integrated out, its intensity there "
              f"{found.gust_sd_mps:.3g} m/s, {found.noise_source} noise), not the final "
              f"filtered covariance: {np.min(ratio):.2f}-{np.max(ratio):.2f} x its sd")
    return dataclasses.replace(result, stderr=found.stderr, covariance=found.covariance,
                               info=info, warnings=(*result.warnings, notice, *said))
