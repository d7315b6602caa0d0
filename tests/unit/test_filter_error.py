"""The filter-error method (issue 26): its model, filter, score and verdicts.

References: the EKF's steady-wind CasADi functions (:mod:`baselines._kalman_wind`) for
the model variant; filterpy's EKF (:func:`baselines._kalman.run_ekf`) on those functions
for the batched filter; central differences of the likelihood for its score; output-error
in still air; the simulator's truth in Dryden turbulence, where output-error is refused.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from closeness import assert_close_in_norm

import aeroid
from aeroid.flights import Wind, make_noise, simulate
from aeroid.model import N_COEFFICIENTS, N_STATE, constants
from baselines import _common, _fem_fit, _fem_setup, _kalman, _kalman_wind
from baselines._fem_filter import gust_model, run_filters
from baselines._fem_model import N_WIND, gust_functions
from baselines.filter_error import FilterErrorEstimator

#: Two CasADi graphs of the same equations (the variant drops the coefficients' states):
#: rounding only.
SAME_RTOL = 1e-12
#: filterpy's EKF and the batched one differ in the order of the covariance algebra and
#: in filterpy's rounding clip of P (baselines._kalman.ROUNDING_RTOL): measured 6e-12 of
#: each channel's innovation range (7e-13 on S, 1e-13 on the wind).
FILTER_RTOL = 1e-9
#: The score from the innovations' central-difference sensitivities (step 1e-4) against
#: a central difference of the cost itself (step COST_STEP): the cost is strongly curved
#: in Cl0 and Clp, its difference's truncation is 3e-2 of the largest component at step
#: 1e-3, 3e-4 at 1e-4, 2.5e-6 at 1e-5 (measured; the score itself agrees to 1e-9 between
#: sensitivity steps 1e-4 and 1e-6).
SCORE_RTOL = 2e-5
COST_STEP = 1e-5
#: Forward against central sensitivities (the iterations' against the end's): O(step),
#: measured 7e-5 on the innovations and 1.0e-4 on S (S is linear in sigma^2 = exp(2 u):
#: the forward difference in u = log sigma is off by exactly the step, 1e-4).
FORWARD_RTOL = 1e-3
#: The verdict's margin: a coefficient further than this many of its own standard errors
#: from the truth is a wrong estimate (the issue's criterion).
WITHIN_SE = 3.0
#: Filter-error and output-error in still air: the same likelihood up to the gusts' floor
#: (1 mm/s) and the integration (1 against 2 RK4 substeps): measured 0.05 se apart.
AGREE_SE = 0.3
TURBULENCE_SD = 3.0
#: A noise-free flight is recovered up to one RK4 step per sample against the 0.25 ms
#: truth integration: output-error measured 1.2e-4 (Clp) with 1 substep; here 1.2e-4.
NOISE_FREE_RTOL = 2e-4


@pytest.fixture(scope="module")
def turbulent_flight(reference_scenario):
    s = reference_scenario
    man = dataclasses.replace(s.manoeuvre, wind=Wind(turbulence_sd_mps=TURBULENCE_SD))
    return simulate(s.airframe, s.coefficient_vector, man, make_noise("gaussian"), rng=1)


@pytest.fixture(scope="module")
def still_flight(reference_scenario):
    s = reference_scenario
    return simulate(s.airframe, s.coefficient_vector, s.manoeuvre, make_noise("gaussian"),
                    rng=1)


def _start(flight):
    zs = _common.measurements(flight)
    noise = _fem_setup.measurement_noise(flight, zs, "metadata", "test")
    x0, P0x = _fem_setup.initial_state(flight, zs, noise.R)
    return zs, noise, x0, P0x


def test_the_variant_is_the_ekfs_steady_wind_model(turbulent_flight, reference_scenario) -> None:
    const = constants(turbulent_flight.airframe)
    dt = turbulent_flight.dt
    f, h = gust_functions(const, dt, 1, 1, False)
    f_ekf, h_ekf, _, _ = _kalman_wind._wind_functions(const, dt, 1, 1, False, ())
    theta = reference_scenario.coefficient_vector
    x = turbulent_flight.states()[100]
    w = np.array([1.5, -2.0, 0.7])
    z = np.concatenate([x, theta, w])
    xw = np.concatenate([x, w])
    _, pieces, _ = aeroid.flights.flight_record(turbulent_flight, "hold").symbolic_inputs()
    pieces = pieces[:, 100]
    delta = turbulent_flight["delta"][100]
    pos = turbulent_flight.airframe.accel_positions.ravel()
    x_next, F = (np.asarray(v) for v in f(xw, theta, pieces, [], []))
    z_next, F_ekf = (np.asarray(v) for v in f_ekf(z, pieces, [], []))
    keep = np.r_[0:N_STATE, N_STATE + N_COEFFICIENTS:N_STATE + N_COEFFICIENTS + N_WIND]
    assert_close_in_norm(x_next.ravel(), z_next.ravel()[:N_STATE], SAME_RTOL)
    assert_close_in_norm(F, F_ekf[:N_STATE][:, keep], SAME_RTOL)
    assert np.max(np.abs(F[:, N_STATE:])) > 1e-4  # the wind moves the state in 2 ms
    y, H = (np.asarray(v) for v in h(xw, theta, delta, [], pos))
    y_ekf, H_ekf = (np.asarray(v) for v in h_ekf(z, delta, [], pos))
    assert_close_in_norm(y, y_ekf, SAME_RTOL)
    assert_close_in_norm(H, H_ekf[:, keep], SAME_RTOL)
    assert np.max(np.abs(H[:, N_STATE:])) > 0.1  # m/s^2 per m/s: the loads see the wind


def test_the_batched_filter_is_filterpys_ekf(turbulent_flight, reference_scenario) -> None:
    """The gust filter against filterpy's EKF on the EKF's wind model, with the gusts'
    decay and process noise put into that model's wind states."""
    flight = turbulent_flight
    zs, noise, x0, P0x = _start(flight)
    theta = reference_scenario.coefficient_vector
    sigma, decay = 2.0, 0.99
    model = _kalman_wind.wind_model(flight, 1, aeroid.flights.flight_record(flight, "auto"), ())
    wind = slice(N_STATE + N_COEFFICIENTS, N_STATE + N_COEFFICIENTS + N_WIND)

    def transition(z, k):
        z_next, F = model.transition(z, k)
        z_next, F = z_next.copy(), F.copy()
        z_next[wind] = decay * z[wind]
        F[wind, wind] = decay * np.eye(N_WIND)
        return z_next, F

    n_aug = model.dim_x
    P0 = np.zeros((n_aug, n_aug))
    P0[:N_STATE, :N_STATE] = P0x
    P0[wind, wind] = sigma**2 * np.eye(N_WIND)
    # the coefficients are known: a variance far below anything the data could move
    P0[N_STATE:wind.start, N_STATE:wind.start] = 1e-20 * np.eye(N_COEFFICIENTS)
    Q = np.zeros((n_aug, n_aug))
    Q[wind, wind] = sigma**2 * (1 - decay**2) * np.eye(N_WIND)
    x0_aug = np.concatenate([x0, theta, np.zeros(N_WIND)])
    reference = _kalman.run_ekf(dataclasses.replace(model, transition=transition), x0_aug, P0,
                                Q, np.diag(noise.R), zs)
    assert reference.failed_at is None
    runs = run_filters(gust_model(flight, 1, "auto", 0.0), theta[None], np.zeros((1, N_WIND)),
                       np.array([sigma]), decay, x0, P0x, noise.R, zs)
    assert runs.ok[0]
    assert_close_in_norm(runs.innovation[0], reference.innovation, FILTER_RTOL, axis=0)
    assert_close_in_norm(np.diagonal(runs.S[0], axis1=1, axis2=2), reference.innovation_var,
                         FILTER_RTOL, axis=0)
    assert_close_in_norm(runs.x[0][:, N_STATE:], reference.x[:, wind], FILTER_RTOL)


def _problem(flight, estimate_wind=False):
    zs, noise, x0, P0x = _start(flight)
    prior = flight.airframe.prior_vector()
    free = np.arange(N_COEFFICIENTS)
    decay, _, _ = _fem_setup.gust_decay(flight, aeroid.flights.MIL_SCALE_LENGTH_M)
    problem = _fem_fit.Problem(gust_model(flight, 1, "auto", 0.0), zs, x0, P0x, decay,
                               prior.copy(), free, prior, estimate_wind,
                               np.zeros(free.size), np.zeros(free.size))
    return problem, noise


def test_the_score_is_the_central_difference_of_the_likelihood(turbulent_flight) -> None:
    """At the prior (off the optimum: a large score), with the steady wind free too."""
    problem, noise = _problem(turbulent_flight, estimate_wind=True)
    p = np.concatenate([np.ones(N_COEFFICIENTS), [np.log(2.0)], [0.5, -0.3, 0.2]])
    center, dnu, dS, ok = _fem_fit.sensitivities(problem, p, noise.R)
    assert ok
    g, M = _fem_fit.score_information(center.innovation[0], center.S[0], dnu, dS)
    step = COST_STEP
    rows = np.concatenate([p + step * np.eye(p.size), p - step * np.eye(p.size)])
    cost = _fem_fit.nll(problem.run(rows, noise.R))
    fd = (cost[:p.size] - cost[p.size:]) / (2 * step)
    assert_close_in_norm(g, fd, SCORE_RTOL)
    assert np.all(np.linalg.eigvalsh(M) > 0)  # information: positive definite
    # the iterations' forward differences
    _, dnu_f, dS_f, _ = _fem_fit.sensitivities(problem, p, noise.R, central=False)
    assert_close_in_norm(dnu_f, dnu, FORWARD_RTOL)
    assert_close_in_norm(dS_f, dS, FORWARD_RTOL)


def test_still_air_agrees_with_output_error(still_flight, reference_scenario) -> None:
    fe = FilterErrorEstimator().fit(still_flight, rng=0)
    oe = aeroid.make_estimator("output-error").fit(still_flight, rng=0)
    assert fe.success and oe.success, (fe.message, oe.message)
    assert fe.info["gust_sd_at_bound"]  # still air: the gusts at their floor
    assert fe.info["gust_sd_mps"] <= 1e-3 + 1e-12
    assert np.all(np.abs(fe.theta - oe.theta) < AGREE_SE * oe.stderr)
    np.testing.assert_allclose(fe.stderr, oe.stderr, rtol=0.1)  # the same information
    truth = reference_scenario.coefficient_vector
    assert np.all(np.abs(fe.theta - truth) < WITHIN_SE * fe.stderr)


def test_in_turbulence_the_truth_is_within_3_se_where_output_error_is_refused(
        turbulent_flight, reference_scenario) -> None:
    truth = reference_scenario.coefficient_vector
    # output-error's still-air model (said: its default, auto, would estimate a steady
    # wind on this flight, which declares its turbulence; that does not converge here)
    oe = aeroid.make_estimator("output-error", {"estimate_wind": False}).fit(
        turbulent_flight, rng=0)
    assert not oe.success and "does not fit" in oe.message  # the known-wrong model
    assert np.max(np.abs(oe.theta - truth) / oe.stderr) > 10
    fe = FilterErrorEstimator().fit(turbulent_flight, rng=0)
    assert fe.success, fe.message  # a correct fit accepted: the fit check on the innovations
    assert fe.info["fit_check"]["not_white"] == []
    assert np.all(np.abs(fe.theta - truth) < WITHIN_SE * fe.stderr), (fe.theta - truth) / fe.stderr
    sd, sd_se = fe.info["gust_sd_mps"], fe.info["gust_sd_stderr_mps"]
    # Dryden's transverse spectrum is not first order: the intensity comes out 3.75 m/s
    # (+- 0.27) on this flight; a bracket, not a 3-se claim
    assert 0.5 * TURBULENCE_SD < sd < 2 * TURBULENCE_SD and sd_se > 0
    assert fe.history["axis"] == "iteration" and fe.history["theta"].shape[1] == N_COEFFICIENTS


def test_a_noise_free_flight_is_recovered(clean_flight, reference_scenario) -> None:
    """No noise metadata to use (model "none"): the noise from the innovations, said."""
    fe = FilterErrorEstimator().fit(clean_flight, rng=0)
    assert fe.success, fe.message
    assert fe.info["measurement_noise"] == "innovations"
    np.testing.assert_allclose(fe.theta, reference_scenario.coefficient_vector,
                               rtol=NOISE_FREE_RTOL)
    assert fe.info["gust_sd_at_bound"]


def test_the_verdict_on_a_known_wrong_model_in_still_air(still_flight, reference_scenario) -> None:
    """Cmq held at twice its value in still air: the gusts cannot take up the error and the
    innovations are autocorrelated (measured: refused on seeds 1-3). In turbulence the
    same wrong model passes (0/3 refused, benchmarks/results/filter_error_wrong.md): the
    gust states absorb it; not asserted here, said in the README. The hold is also tested
    inside the fit (a likelihood ratio, baselines/_fem_holds.py), which refuses it first:
    its message is the result's, the fit check's finding stays in ``info``."""
    truth = reference_scenario.coefficient_vector
    wrong = FilterErrorEstimator().fit(still_flight, rng=0,
                                       holds={"hold": {"Cmq": 2.0 * float(truth[8])}})
    assert not wrong.success and "the data refuse the user's Cmq (hold)" in wrong.message
    assert wrong.info["fit_check"]["not_white"], wrong.info["fit_check"]


def test_a_held_coefficient_stays_and_a_prior_pulls(turbulent_flight, reference_scenario) -> None:
    truth = reference_scenario.coefficient_vector
    held = FilterErrorEstimator(max_iterations=8).fit(
        turbulent_flight, rng=0, holds={"hold": {"Czq": float(truth[3])}})
    assert held.theta[3] == truth[3] and np.isnan(held.stderr[3])
    assert "Czq" not in held.info["parameter_names"]
    # a prior 50 % off with an sd of 0.1 % of it outweighs the data (se ~90 %): the
    # estimate stays at the prior's mean, its se at most the prior's sd
    mean, sd = 1.5 * float(truth[3]), 1e-3 * abs(1.5 * float(truth[3]))
    pulled = FilterErrorEstimator(max_iterations=8).fit(
        turbulent_flight, rng=0, holds={"prior": {"Czq": [mean, sd]}})
    assert abs(pulled.theta[3] - mean) < sd and pulled.stderr[3] <= sd
    assert pulled.priors == {"Czq": (mean, sd)}


def test_refusals_are_one_line(still_flight, clean_flight) -> None:
    est = FilterErrorEstimator(measurement_noise="metadata")
    bare = aeroid.flights.Flight(still_flight.data, still_flight.airframe,
                                 {k: v for k, v in still_flight.metadata.items() if k != "noise"})
    for flight, match in ((bare, "has no noise metadata"), (clean_flight, "has no noise")):
        with pytest.raises(aeroid.EstimatorError, match=match) as info:
            est.fit(flight, rng=0)
        assert "\n" not in str(info.value)
    with pytest.raises(aeroid.EstimatorError, match="cannot fit several windows"):
        FilterErrorEstimator().fit(aeroid.flights.Windows((still_flight, still_flight),
                                                          ("a", "b")), rng=0)
    for bad in ({"scale_length_m": -1.0}, {"measurement_noise": "vane"},
                {"substeps": 0}, {"gust_sd_start_mps": 0.0}):
        with pytest.raises(aeroid.EstimatorError, match="filter-error") as info:
            FilterErrorEstimator.from_options(bad)
        assert "\n" not in str(info.value)


def test_noise_from_the_innovations_on_a_log_without_metadata(still_flight) -> None:
    bare = aeroid.flights.Flight(still_flight.data, still_flight.airframe,
                                 {k: v for k, v in still_flight.metadata.items() if k != "noise"})
    fe = FilterErrorEstimator().fit(bare, rng=0)  # auto: innovations, said in info
    assert fe.info["measurement_noise"] == "innovations"
    sd = np.sqrt(fe.info["measurement_noise_var"])
    noise = still_flight.metadata["noise"]
    want = np.array([noise["accel_sd_mps2"] if c in aeroid.model.ACCEL_CHANNELS
                     else noise["rate_sd_radps"] for c in aeroid.model.OUTPUT_CHANNELS])
    np.testing.assert_allclose(sd, want, rtol=0.15)  # 501 samples: sd of an sd ~3 %
    assert fe.success, fe.message
