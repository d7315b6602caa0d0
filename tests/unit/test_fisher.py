"""The Cramér-Rao floor: sensitivities against closed forms and a second computation."""

from __future__ import annotations

import numpy as np
import pytest

from aeroid.errors import EstimatorError
from aeroid.estimation._floor import (
    PROTOTYPE_FLOOR,
    OutputErrorInputs,
    coefficient_information,
    cramer_rao_sd,
    information_from_sensitivities,
    inputs_from_flight,
    model_noise_sd,
    model_outputs,
    output_error_information,
    output_sensitivities,
)
from aeroid.flights._noise import GaussianNoise, NoNoise, PaperNoise
from aeroid.model._coefficients import NAMES, nominal
from aeroid.model._dynamics import OUTPUT_CHANNELS, accelerometers, constants, regressors
from aeroid.model._integrate import propagate

#: Central differences (relative step 1e-5) of outputs that are linear in theta at k = 0:
#: rounding only, ~eps |y| / step relative to each column's scale; measured below 1e-9.
CLOSED_FORM_RTOL = 1e-7
#: Versus a 4-point stencil with step 1e-4 on the numpy backend: the module's central
#: difference is good to 4e-7 of each column's scale (Czq; module docstring).
SECOND_STENCIL_RTOL = 2e-6
#: Reference README, Cramér-Rao sd in % of nominal, and the decimals it is given to.
README_PERCENT = np.array([0.02, 0.11, 0.34, 6.0, 11.5, 14.4, 0.07, 0.13, 0.86])
README_DECIMALS = [2, 2, 2, 1, 1, 1, 2, 2, 2]
N_SHORT = 101  # samples of the short window used where a second computation is costly


@pytest.fixture(scope="module")
def short_inputs(clean_flight):
    """The first 0.2 s of the clean flight as output-error inputs."""
    full = inputs_from_flight(clean_flight)
    return OutputErrorInputs(full.state0, full.delta[:N_SHORT], full.dt)


def _column_error(a: np.ndarray, b: np.ndarray) -> float:
    """Max |a - b| relative to each parameter column's max |b| (last axis)."""
    scale = np.max(np.abs(b).reshape(-1, b.shape[-1]), axis=0)
    return float(np.max(np.abs(a - b).reshape(-1, b.shape[-1]) / scale))


def _skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def test_sensitivities_at_the_first_sample_equal_the_closed_form(reference_scenario,
                                                                  short_inputs):
    # at k = 0 the state is given: d a / d theta = [I/m, -[R]x I^-1] X(x0, delta0) (eq. 28)
    airframe = reference_scenario.airframe
    const = constants(airframe)
    jac = output_sensitivities(airframe, nominal(), short_inputs)
    assert jac.shape == (N_SHORT, len(OUTPUT_CHANNELS), len(NAMES))
    x = regressors(short_inputs.state0, short_inputs.delta[0], const)
    inv_inertia = np.diag([1 / const.ix, 1 / const.iy, 1 / const.iz])
    expected = np.vstack([np.hstack([np.eye(3) / const.mass, -_skew(r) @ inv_inertia]) @ x
                          for r in airframe.accel_positions])
    assert _column_error(jac[0, :6], expected) < CLOSED_FORM_RTOL
    np.testing.assert_array_equal(jac[0, 6:], 0.0)  # the initial rates are given


def _numpy_outputs(airframe, thetas, inputs):
    """Model outputs on the numpy backend, computed here (not by aeroid.estimation)."""
    const = constants(airframe)
    states = propagate(inputs.state0, thetas, inputs.delta[:-1], inputs.dt, const, substeps=8,
                       backend="numpy")
    acc = accelerometers(states, inputs.delta[None, :], thetas[:, None, :], const,
                         airframe.accel_positions)
    return np.concatenate([acc.reshape(len(thetas), -1, 6), states[..., 3:6]], axis=-1)


@pytest.fixture(scope="module")
def second_jacobian(reference_scenario, short_inputs):
    """d y / d theta by the 4-point stencil, step 1e-4 relative, numpy backend."""
    theta = nominal()
    step = 1e-4 * np.abs(theta)
    sets = np.concatenate([theta + m * np.diag(step) for m in (-2, -1, 1, 2)])
    y = _numpy_outputs(reference_scenario.airframe, sets, short_inputs).reshape(
        4, len(NAMES), N_SHORT, len(OUTPUT_CHANNELS))
    jac = (y[0] - 8 * y[1] + 8 * y[2] - y[3]) / (12 * step[:, None, None])
    return np.moveaxis(jac, 0, -1)


def test_sensitivities_equal_a_second_stencil_and_backend(reference_scenario, short_inputs,
                                                          second_jacobian):
    jac = output_sensitivities(reference_scenario.airframe, nominal(), short_inputs)
    assert _column_error(jac, second_jacobian) < SECOND_STENCIL_RTOL


def test_model_outputs_reproduce_the_clean_flight(reference_scenario, clean_flight):
    out = model_outputs(reference_scenario.airframe, nominal(), clean_flight)
    assert out.shape == (clean_flight.n_samples, len(OUTPUT_CHANNELS))
    measured = np.column_stack([clean_flight.accelerations().reshape(-1, 6),
                                clean_flight.states()[:, 3:6]])
    scale = np.max(np.abs(measured), axis=0)
    assert np.max(np.abs(out - measured) / scale) < 1e-12


def test_gaussian_floor_equals_sigma2_inverse_jtj(reference_scenario, short_inputs,
                                                  second_jacobian):
    # linear-Gaussian: equal sd on every channel -> covariance sigma^2 (J^T J)^-1
    sigma = 0.03
    direct = sigma**2 * np.linalg.inv(np.einsum("kci,kcj->ij", second_jacobian,
                                                second_jacobian))
    info = output_error_information(reference_scenario.airframe, nominal(), short_inputs, sigma)
    cov = np.linalg.inv(info)
    scale = np.sqrt(np.outer(np.diag(direct), np.diag(direct)))
    # over this 0.2 s window Cl0 and Clp are correlated at -0.999999: the inverse
    # amplifies the ~1e-8 differences of the two J's; measured 9e-7, bound 1e-5
    np.testing.assert_allclose(np.diag(cov), np.diag(direct), rtol=1e-5)
    np.testing.assert_allclose(cov / scale, direct / scale, rtol=0, atol=1e-5)
    # and through the noise model (one sd for accelerations and rates)
    noise = GaussianNoise(accel_sd_mps2=sigma, rate_sd_radps=sigma)
    sd = model_noise_sd(noise, model_outputs(reference_scenario.airframe, nominal(), short_inputs))
    np.testing.assert_array_equal(sd, sigma)


def test_scaling_with_the_noise_level_is_exact(reference_scenario):
    base = cramer_rao_sd(reference_scenario, PaperNoise())
    double = cramer_rao_sd(reference_scenario, PaperNoise(accelerations_xi=0.1, rates_xi=0.1))
    np.testing.assert_allclose(double, 2 * base, rtol=1e-12)
    g1 = cramer_rao_sd(reference_scenario, GaussianNoise())
    g2 = cramer_rao_sd(reference_scenario, GaussianNoise(accel_sd_mps2=0.1, rate_sd_radps=0.01))
    np.testing.assert_allclose(g2, 2 * g1, rtol=1e-12)
    assert base.shape == (len(NAMES),) and np.all(base > 0)


def test_heteroscedastic_sd_follows_eq43(reference_scenario, short_inputs):
    outputs = model_outputs(reference_scenario.airframe, nominal(), short_inputs)
    sd = model_noise_sd(PaperNoise(), outputs)
    # U[-xi, xi] has standard deviation xi / sqrt(3)
    np.testing.assert_allclose(sd, np.abs(outputs) * 0.05 / np.sqrt(3), rtol=1e-15)
    homo = model_noise_sd(PaperNoise(), outputs, noise_form="homoscedastic")
    np.testing.assert_allclose(homo[0] ** 2 * 3 / 0.05**2, np.mean(outputs**2, axis=0),
                               rtol=1e-13)


def test_nuisance_initial_state_is_the_schur_complement(reference_scenario, short_inputs):
    airframe = reference_scenario.airframe
    jac = output_sensitivities(airframe, nominal(), short_inputs, estimate_initial=("p", "q"))
    n_c = len(NAMES)
    assert jac.shape == (N_SHORT, len(OUTPUT_CHANNELS), n_c + 2)
    # d y / d p0 on the p channel is 1 at k = 0 and close to 1 just after
    assert jac[0, OUTPUT_CHANNELS.index("p"), n_c] == pytest.approx(1.0, rel=1e-8)
    full = information_from_sensitivities(jac, 0.05)
    reduced = coefficient_information(full)
    np.testing.assert_allclose(np.linalg.inv(reduced), np.linalg.inv(full)[:n_c, :n_c], rtol=1e-6)
    known = information_from_sensitivities(jac[..., :n_c], 0.05)
    assert np.all(np.diag(np.linalg.inv(reduced)) >= np.diag(np.linalg.inv(known)))


def test_prototype_options_reproduce_the_reference_readme(reference_scenario):
    sd = cramer_rao_sd(reference_scenario, PaperNoise(), **PROTOTYPE_FLOOR)
    percent = 100 * sd / np.abs(nominal())
    rounded = [round(float(v), d) for v, d in zip(percent, README_DECIMALS, strict=True)]
    np.testing.assert_allclose(rounded, README_PERCENT, rtol=1e-12)


def test_default_floor_is_below_the_homoscedastic_one(reference_scenario, clean_flight):
    default = cramer_rao_sd(reference_scenario, PaperNoise())
    homo = cramer_rao_sd(reference_scenario, PaperNoise(), noise_form="homoscedastic")
    assert np.all(default < homo)
    # a flight gives the scenario's result (same noise-free simulation)
    np.testing.assert_array_equal(cramer_rao_sd(clean_flight, PaperNoise()), default)


def test_estimator_positions_option(paper_flight, reference_scenario):
    """positions='estimator' is the floor of the model with the flight's (wrong) copy of
    the positions: the information built here from those positions, not the true ones."""
    true = cramer_rao_sd(paper_flight, GaussianNoise())
    seen = cramer_rao_sd(paper_flight, GaussianNoise(), positions="estimator")
    inputs = inputs_from_flight(paper_flight)
    theta = paper_flight.true_coefficients
    for positions, floor in ((paper_flight.airframe.accel_positions, seen),
                             (np.asarray(paper_flight.metadata["true_accel_positions_m"]),
                              true)):
        noise = model_noise_sd(GaussianNoise(), model_outputs(paper_flight.airframe, theta,
                                                              inputs, positions=positions))
        info = output_error_information(paper_flight.airframe, theta, inputs, noise,
                                        positions=positions)
        np.testing.assert_allclose(floor.to_numpy(), np.sqrt(np.diag(np.linalg.inv(info))),
                                   rtol=1e-9)
    assert not np.allclose(true, seen, rtol=1e-6)  # the two position sets are different


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda sc, fl: cramer_rao_sd(sc, NoNoise()), "no Cramér-Rao floor"),
        (lambda sc, fl: cramer_rao_sd(sc, PaperNoise(), positions="cad"), "positions must be"),
        (lambda sc, fl: cramer_rao_sd(sc, PaperNoise(), noise_form="x"), "unknown noise_form"),
        (lambda sc, fl: cramer_rao_sd(sc, PaperNoise(), channels="x"), "unknown channels"),
        (lambda sc, fl: cramer_rao_sd(sc, PaperNoise(), estimate_initial=("mach",)),
         "unknown state name"),
        (lambda sc, fl: cramer_rao_sd(type(fl)(fl.data, fl.airframe, {}), PaperNoise()),
         "no metadata"),
        (lambda sc, fl: output_sensitivities(sc.airframe, np.zeros(8), fl), "shape"),
        (lambda sc, fl: model_outputs(sc.airframe, nominal(), fl, positions=np.zeros(3)),
         "positions must be 2 x 3"),
    ],
)
def test_bad_input_raises_one_line(reference_scenario, clean_flight, call, message):
    with pytest.raises(ValueError, match=message) as info:
        call(reference_scenario, clean_flight)
    assert "\n" not in str(info.value)


def test_floor_is_named_and_equals_the_inverse_information(reference_scenario, clean_flight):
    """The public floor carries the coefficient names; its values are sqrt(diag(F^-1)) of
    the information matrix computed here from its parts; bad options are EstimatorError."""
    sd = cramer_rao_sd(reference_scenario, GaussianNoise())
    assert list(sd.index) == list(NAMES)
    inputs = inputs_from_flight(clean_flight)
    truth = clean_flight.true_coefficients
    positions = np.asarray(clean_flight.metadata["true_accel_positions_m"])
    noise = model_noise_sd(GaussianNoise(), model_outputs(clean_flight.airframe, truth, inputs,
                                                          positions=positions))
    info = output_error_information(clean_flight.airframe, truth, inputs, noise,
                                    positions=positions)
    np.testing.assert_allclose(sd.to_numpy(), np.sqrt(np.diag(np.linalg.inv(info))),
                               rtol=1e-9)
    with pytest.raises(EstimatorError, match="cramer_rao_sd"):
        cramer_rao_sd(reference_scenario, GaussianNoise(), channels="x")


def _gauss_newton(airframe, inputs, measured, sd, theta0, iterations=4):
    """Weighted least-squares output-error fit (weights 1 / sd^2) by Gauss-Newton."""
    theta = theta0.copy()
    weight = 1.0 / sd**2
    for _ in range(iterations):
        residual = measured - model_outputs(airframe, theta, inputs)
        jac = output_sensitivities(airframe, theta, inputs)
        lhs = np.einsum("kci,kc,kcj->ij", jac, weight, jac)
        rhs = np.einsum("kci,kc,kc->i", jac, weight, residual)
        theta = theta + np.linalg.solve(lhs, rhs)
    return theta


@pytest.mark.slow
@pytest.mark.parametrize("noise", [GaussianNoise(), PaperNoise()], ids=["gaussian", "paper"])
def test_weighted_least_squares_attains_the_floor(reference_scenario, clean_flight, noise):
    # Monte Carlo: 150 flights' worth of noise on the model outputs (the initial state and
    # delta known), fitted by weighted least squares; the spread of the estimates must
    # match cramer_rao_sd (the sd of a sample sd from 150 draws is ~6 %: allow 25 %)
    rng = np.random.default_rng(2024)
    airframe, theta = reference_scenario.airframe, nominal()
    inputs = inputs_from_flight(clean_flight)
    clean = model_outputs(airframe, theta, inputs)
    sd = model_noise_sd(noise, clean)
    floor = cramer_rao_sd(clean_flight, noise)
    estimates = []
    for _ in range(150):
        if isinstance(noise, PaperNoise):  # eq. 43
            measured = clean * (1 + 0.05 * (2 * rng.random(clean.shape) - 1))
        else:
            measured = clean + sd * rng.standard_normal(clean.shape)
        estimates.append(_gauss_newton(airframe, inputs, measured, sd, theta))
    spread = np.std(estimates, axis=0, ddof=1)
    np.testing.assert_allclose(spread / floor, 1.0, atol=0.25)
    bias = np.abs(np.mean(estimates, axis=0) - theta)
    assert np.all(bias < 4 * floor / np.sqrt(150))
