"""Output-error with a steady wind as parameters (issue 26).

References: the numba forward model with the wind in its constants (another evaluation
of the same equations) for the CasADi record's outputs; central differences for its
exact wind sensitivities; the fit check's verdict on a windy flight fitted in still air
(a known-wrong model) and on the same flight fitted with the wind.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from closeness import assert_close_in_norm

import aeroid
from aeroid.flights import NoNoise, Wind, make_noise, simulate
from aeroid.model import (
    ForwardModel,
    Record,
    constants,
    exogenous_table,
    symbolic_record,
    with_steady_wind,
)

#: CasADi's record and the numba forward model evaluate the same RK4 steps in another
#: order: rounding (measured ~1e-12 of each channel's range).
SAME_RTOL = 1e-9
#: Central difference of 1e-3 m/s on outputs analytic in the wind: truncation ~1e-9.
FD_STEP = 1e-3
FD_RTOL = 1e-6
#: 5 m/s of steady wind: 3 m/s along the reference flight's path (north), 4 across (east).
WIND = (3.0, 4.0, 0.0)
#: The verdicts' margins: a coefficient or wind component further than this many of its
#: own standard errors from the truth is a wrong estimate (the issue's criterion).
WITHIN_SE = 3.0


@pytest.fixture(scope="module")
def windy_flight(reference_scenario):
    s = reference_scenario
    windy = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND))
    return simulate(s.airframe, s.coefficient_vector, windy, make_noise("gaussian"), rng=3)


@pytest.mark.parametrize("varying", [False, True], ids=["constant", "per-sample"])
def test_the_wind_parameters_are_the_models_wind(reference_scenario, varying) -> None:
    s = reference_scenario
    flight = simulate(s.airframe, s.coefficient_vector, s.manoeuvre, NoNoise(), rng=0)
    const = constants(s.airframe)
    n = flight.n_samples
    exo = exogenous_table(const, n, {"mass": np.linspace(70.0, 69.5, n)}) if varying else None
    record = Record.held(flight["delta"], flight.dt, exo)
    x0 = flight.states()[0]
    pos = s.airframe.accel_positions
    sim, jac, _ = symbolic_record(const, flight.dt, 2, n, (), (), False, 1, varying,
                                  wind_free=True)
    d, pieces, table = record.symbolic_inputs()
    scale = np.concatenate([s.coefficient_vector, np.ones(3)])

    def outputs(wind):
        p = np.concatenate([np.ones(s.coefficient_vector.size), wind])
        return np.array(sim(p, scale, x0, d, pieces, table, pos.ravel()))

    # the outputs are the forward model's with the wind in its constants
    windy_const, windy_record = with_steady_wind(const, record, WIND)
    reference = ForwardModel(windy_const, windy_record, pos, substeps=2,
                             backend="numba").outputs(x0, s.coefficient_vector)[0]
    assert_close_in_norm(outputs(np.array(WIND)), reference, SAME_RTOL, axis=0)
    assert np.max(np.abs(reference - outputs(np.zeros(3)))) > 0.1  # the wind matters
    # the exact sensitivities are the central differences
    p = np.concatenate([np.ones(s.coefficient_vector.size), WIND])
    _, dy = jac(p, scale, x0, d, pieces, table, pos.ravel())
    dy = np.array(dy).reshape(9, n, -1)  # (output, sample, parameter): dY[j, k n_p + i]
    for j in range(3):
        step = np.zeros(3)
        step[j] = FD_STEP
        fd = (outputs(np.array(WIND) + step) - outputs(np.array(WIND) - step)) / (2 * FD_STEP)
        assert_close_in_norm(dy[:, :, -3 + j].T, fd, FD_RTOL, err_msg=f"wind {j}")


def test_still_air_output_error_is_refused_on_a_windy_flight(windy_flight) -> None:
    """The verdict on a known-wrong model: 5 m/s of wind fitted as still air (said: the
    default, auto, estimates the wind on this flight, whose metadata declares it)."""
    result = aeroid.make_estimator("output-error", {"estimate_wind": False}).fit(
        windy_flight, rng=0)
    assert not result.success
    assert "does not fit" in result.message or "white" in result.message
    assert "wind_ned_mps" not in result.info


def test_output_error_estimates_the_wind_within_its_standard_errors(windy_flight,
                                                                    reference_scenario
                                                                    ) -> None:
    est = aeroid.make_estimator("output-error", {"estimate_wind": True})
    result = est.fit(windy_flight, rng=0)
    assert result.success, result.message
    err = np.abs(result.theta - reference_scenario.coefficient_vector) / result.stderr
    assert np.all(err < WITHIN_SE), dict(zip(aeroid.NAMES, err.round(2), strict=True))
    wind, sd = np.array(result.info["wind_ned_mps"]), np.array(result.info["wind_stderr_mps"])
    assert np.all(np.abs(wind - WIND) < WITHIN_SE * sd), (wind, sd)
    # the crosswind is determined to a fraction of a m/s; along the path it trades with
    # every coefficient (the dynamic pressure), so its sd is large (measured ~5 m/s)
    assert sd[1] < 0.5
    notice = [w for w in result.warnings if w.startswith("estimate_wind:")]
    assert len(notice) == 1 and "east" in notice[0]
    # predict uses the fitted wind: the residuals are the noise
    predicted = aeroid.estimation.predict(result, windy_flight)
    rms = np.sqrt(np.mean((predicted["az2"].to_numpy() - windy_flight["az2"]) ** 2))
    assert rms < 1.2 * make_noise("gaussian").accel_sd_mps2


def test_the_option_is_named_in_the_methods_options(capsys) -> None:
    from aeroid.cli import main

    assert main(["methods", "--options", "output-error"]) == 0
    text = capsys.readouterr().out
    assert "  estimate_wind : bool or {auto} = auto\n      Also estimate a steady wind" in text


def test_output_error_is_still_refused_in_turbulence(reference_scenario) -> None:
    """Moderate Dryden turbulence (sd 3 m/s) on the windy flight: a steady wind does not
    explain gusts, and the verdict says so (measured: refused on 12/12 flights with sd
    0.3-3 m/s, by size or by whiteness)."""
    s = reference_scenario
    gusty = dataclasses.replace(s.manoeuvre, wind=Wind(steady_ned_mps=WIND,
                                                       turbulence_sd_mps=3.0))
    flight = simulate(s.airframe, s.coefficient_vector, gusty, make_noise("gaussian"), rng=2)
    result = aeroid.make_estimator("output-error", {"estimate_wind": True}).fit(flight, rng=0)
    assert not result.success
