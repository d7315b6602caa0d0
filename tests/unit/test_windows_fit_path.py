"""Several windows take the single flight's path through Estimator.fit.

What the one path brings to windows, against closed forms and the single flight's own
results: the mass uncertainty's consider share (F = m a: d theta / d m = theta / m for
the force coefficients, exactly, on a coast), the identifiability findings (a
coefficient is named only when no window determines it), and the one-line refusals.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aeroid.errors import EstimatorError
from aeroid.estimation import make_estimator, record_findings
from aeroid.estimation._windows import common_findings
from aeroid.flights import NoNoise, PaperNoise, cut_windows, load_scenario, simulate_scenario
from aeroid.model import NAMES

#: The force coefficients (their S is theta / m on a coast) and the moments (S = 0).
FORCES = [j for j, n in enumerate(NAMES) if n.startswith(("Cx", "Cz"))]
MOMENTS = [j for j, n in enumerate(NAMES) if j not in FORCES]
#: Equation-error's S is exact to rounding (tests/unit/test_consider.py EE_RTOL).
EE_RTOL = 1e-8
#: Output-error's re-fits stop at the Gauss-Newton tolerance (test_consider.py OE_RTOL).
OE_RTOL = 1e-5


def _coast(noise, rng):
    """The reference scenario with no thrust, recorded over 5.0-6.6 s."""
    scenario = load_scenario(None)
    scenario = dataclasses.replace(
        scenario, airframe=scenario.airframe.replace(thrust_n=0.0),
        manoeuvre=dataclasses.replace(scenario.manoeuvre, window_s=(5.0, 6.6)))
    return simulate_scenario(scenario, noise, rng=rng)


def _with(flight, **changes):
    return dataclasses.replace(flight, airframe=flight.airframe.replace(**changes))


@pytest.fixture(scope="module")
def clean_windows():
    return cut_windows(_with(_coast(NoNoise(), 0), mass_sd_kg=1.4), "5-5.7,5.9-6.6")


@pytest.fixture(scope="module")
def noisy_windows():
    return cut_windows(_coast(PaperNoise(), 4), "5-5.7,5.9-6.6")


def test_windows_consider_share_is_theta_over_m(clean_windows):
    """The re-fits move each window's mass; the force coefficients scale with it."""
    result = make_estimator("output-error", {}).fit(clean_windows, rng=0)
    assert result.success, result.message
    assert result.consider is not None and result.consider.names == ("mass_kg",)
    by_mass = result.consider.sensitivity[:, 0]
    np.testing.assert_allclose(by_mass[FORCES], result.theta[FORCES] / 70.0, rtol=OE_RTOL)
    assert np.all(np.abs(by_mass[MOMENTS]) <= OE_RTOL * np.abs(result.theta[MOMENTS]) / 70.0)


def test_windows_total_se_is_plain_plus_closed_form_share(noisy_windows):
    """Equation-error over two noisy windows: se_total^2 = se^2 + (theta sd / m)^2."""
    sd = 2.1
    plain = make_estimator("equation-error", {}).fit(noisy_windows, rng=0)
    wide = make_estimator("equation-error", {}).fit(
        type(noisy_windows)(tuple(_with(f, mass_sd_kg=sd) for f in noisy_windows),
                            noisy_windows.names), rng=0)
    assert plain.consider is None and wide.consider is not None
    np.testing.assert_array_equal(wide.theta, plain.theta)
    expected = np.sqrt(plain.stderr**2 + (plain.theta * sd / 70.0) ** 2)
    np.testing.assert_allclose(wide.stderr[FORCES], expected[FORCES], rtol=EE_RTOL)
    np.testing.assert_allclose(wide.stderr[MOMENTS], plain.stderr[MOMENTS], rtol=EE_RTOL)
    assert wide.info["windows"] == list(noisy_windows.names)


def test_windows_with_different_mass_uncertainties_are_refused(noisy_windows):
    first, second = noisy_windows.flights
    mixed = type(noisy_windows)((_with(first, mass_sd_kg=2.1), second), noisy_windows.names)
    said = (r"window '5.9-6.6' states another mass uncertainty \(none\) than '5-5.7' "
            r"\(mass_kg sd 2.1\)")
    with pytest.raises(EstimatorError, match=said):
        make_estimator("equation-error", {}).fit(mixed, rng=0)


def test_a_coefficient_is_not_identifiable_only_when_no_window_determines_it(noisy_windows):
    first, second = noisy_windows.flights
    still = first.data.copy()
    still["delta"] = 0.0  # no fin motion in this window
    frozen = dataclasses.replace(first, data=still)
    moving, held = record_findings(second), record_findings(frozen)
    assert [f.names for f in held] == [("Czd", "Cmd")] and moving == ()
    assert common_findings([held, moving]) == ()
    assert common_findings([held, held]) == held
    assert common_findings([held]) == held


# held coefficients and priors over several windows --------------------------------------
#: One window fitted as Windows is the single flight's fit: the same problem, the same
#: arithmetic (measured: equal to rounding, <= 1e-12 relative).
SAME_RTOL = 1e-9
#: Noise-free recovery over two windows (tests/unit/test_windows.py RECOVERY_RTOL).
RECOVERY_RTOL = 1e-4


def _holds(flight):
    truth = flight.true_coefficients
    cmd, cmq = NAMES.index("Cmd"), NAMES.index("Cmq")
    return {"hold": {"Czd": float(truth[NAMES.index("Czd")])},
            "prior": {"Cmd": (float(truth[cmd]) * 1.02, 0.05 * abs(float(truth[cmd]))),
                      "Cmq": (float(truth[cmq]), 0.1 * abs(float(truth[cmq])))}}


@pytest.mark.parametrize("method", ["output-error", "equation-error", "ekf"])
def test_one_window_with_holds_is_the_single_flight_fit(noisy_windows, method):
    flight = noisy_windows.flights[0]
    holds = _holds(flight)
    est = make_estimator(method, {})
    one = est.fit(flight, rng=0, holds=holds)
    win = est.fit(type(noisy_windows)((flight,), ("only",)), rng=0, holds=holds)
    assert one.held == win.held == {"Czd": holds["hold"]["Czd"]}
    assert set(win.priors) == {"Cmd", "Cmq"}
    np.testing.assert_allclose(win.theta, one.theta, rtol=SAME_RTOL)
    np.testing.assert_allclose(win.stderr, one.stderr, rtol=SAME_RTOL)


def test_output_error_holds_over_two_noise_free_windows(clean_windows):
    truth = clean_windows.true_coefficients
    j = NAMES.index("Cmd")
    free = [k for k in range(len(NAMES)) if k != j]
    windows = type(clean_windows)(tuple(_with(f, mass_sd_kg=0.0) for f in clean_windows),
                                  clean_windows.names)
    result = make_estimator("output-error", {}).fit(
        windows, rng=0, holds={"hold": {"Cmd": float(truth[j])}})
    assert result.success, result.message
    assert result.theta[j] == truth[j] and result.held == {"Cmd": float(truth[j])}
    np.testing.assert_allclose(result.theta[free], truth[free], rtol=RECOVERY_RTOL)
    wrong = make_estimator("output-error", {}).fit(
        windows, rng=0, holds={"hold": {"Cmd": 1.2 * float(truth[j])}})
    assert not wrong.success  # a held value 20 % off: the fit check refuses
