"""The research prototype (:mod:`.prototype`): its kernel is aeroid's equations, and with
issue 10's inputs its output-error fit recovers the JSBSim flights.

Marked ``slow``: the compiled kernel takes ~25 s to build on a cold cache, each fit 2-5 s
(``python -m pytest -m slow tests/crossengine``).
"""

from __future__ import annotations

import numpy as np
import pytest

from aeroid.model import FinLaw, constants, state_derivative

from . import _kernel
from . import prototype as pt

jsbsim = pytest.importorskip("jsbsim", reason="the cross-engine tests need JSBSim "
                                                  "(the dev or crossengine extra)")

pytestmark = pytest.mark.slow

#: Same algebra in scalar numba and batched numpy: rounding only.
KERNEL_RTOL = 1e-12
#: Output-error with the true switch instants (or the located law) and per-sample density
#: on the noise-free flight (measured: worst 0.0011 %, Czq).
PROTOTYPE_NOISE_FREE_PCT = 0.005
#: The 1 ms delay (measured 1000.025 us +- 0.001 us): the integration's resolution.
DELAY_ATOL_S = 1e-7


def test_kernel_derivative_equals_aeroid(climb):
    flight, truth = climb
    af = truth.airframe
    cst = np.array([af.area_m2, af.diameter_m, af.mass_kg, af.ix_kgm2, af.iy_kgm2,
                    af.iz_kgm2, af.thrust_n])
    states, delta = flight.states(), flight["delta"]
    rho, grav = truth.data["rho"].to_numpy(), truth.data["gravity"].to_numpy()
    expected = state_derivative(states, delta, truth.coefficients,
                                constants(af)._replace(rho=rho, gravity=grav))
    got = np.empty_like(expected)
    for k in range(len(states)):
        _kernel.derivative(states[k], delta[k], truth.coefficients, rho[k], grav[k], cst, got[k])
    scale = np.max(np.abs(expected), axis=0)
    np.testing.assert_array_less(np.max(np.abs(got - expected), axis=0) / scale, KERNEL_RTOL)


def _inputs(flight, truth, delta_mode):
    config = truth.config
    fields = {"t": flight.t, "rho": truth.data["rho"].to_numpy(),
              "gravity": truth.data["gravity"].to_numpy()}
    if delta_mode == "events":
        fields.update(switch_times=truth.switch_times, switch_values=truth.switch_values,
                      initial_delta=truth.initial_delta)
    else:
        fields.update(pt.logged_events(flight, "midpoint"), delta_mode="law",
                      relay=FinLaw(delta_max_rad=np.radians(config.delta_max_deg),
                                   command_amplitude=config.command_amplitude,
                                   command_phase_deg=config.command_phase_deg))
    return pt.Inputs(**fields)


@pytest.mark.parametrize("delta_mode", ["events", "law"])
def test_prototype_output_error_recovers_the_noise_free_flight(climb, delta_mode):
    flight, truth = climb
    fit = pt.fit_output_error(flight, _inputs(flight, truth, delta_mode))
    error = np.abs(fit.theta / truth.coefficients - 1.0) * 100.0
    assert np.max(error) < PROTOTYPE_NOISE_FREE_PCT


def test_prototype_estimates_the_actuator_delay(climb_delayed):
    flight, truth = climb_delayed
    fit = pt.fit_output_error(flight, _inputs(flight, truth, "law"), estimate_delay=True)
    assert abs(fit.delay_s - truth.config.fin_delay_s) < DELAY_ATOL_S
    error = np.abs(fit.theta / truth.coefficients - 1.0) * 100.0
    assert np.max(error) < PROTOTYPE_NOISE_FREE_PCT
