"""A motor's thrust curve on its own clock, used only inside the burn window (issue 25).

References: the rocket equation (constant thrust, mass falling linearly, no drag, no
gravity along the body axis: du = T / k ln(m_a / m_b), k the mass flow), F = m a for the
accelerometers, scipy's quad for the curve's impulse, and the fit check for a burn fitted
without the curve.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import quad

from aeroid.errors import AeroidError, AirframeError, FlightError
from aeroid.estimation import make_estimator
from aeroid.estimation._fitcheck import RATIO_LIMIT
from aeroid.flights import (
    GaussianNoise,
    exogenous,
    load_scenario,
    read_flight,
    simulate,
    simulate_scenario,
    with_thrust_curve,
)
from aeroid.model import (
    N_COEFFICIENTS,
    ThrustCurve,
    load_airframe,
    read_thrust_curve,
    save_airframe,
)

BURNOUT = "studies/scenarios/rocket_burnout.toml"
#: The rocket equation against RK4 of a linear-in-time mass and constant thrust: RK4 is
#: exact for polynomials of degree 4, 1/m is not one; at 1 ms steps it agrees to ~1e-12.
ROCKET_EQUATION_RTOL = 1e-9


def _curve(**changes: object) -> ThrustCurve:
    base = dict(time_s=[0.0, 0.1, 3.0, 3.2], thrust_n=[0.0, 400.0, 380.0, 0.0], origin_s=1.2,
                burn_s=(1.2, 4.0), mass_kg=[14.0, 13.9, 12.1, 12.0])
    base.update(changes)
    return ThrustCurve(**base)  # type: ignore[arg-type]


def test_thrust_only_inside_the_burn_window_and_on_its_own_clock() -> None:
    curve = _curve()
    t = np.array([1.0, 1.2, 1.3, 2.0, 4.0, 4.0001, 4.3])
    expected = np.interp(t - 1.2, curve.time_s, curve.thrust_n)
    expected[(t < 1.2) | (t > 4.0)] = 0.0  # the curve's tail after 4.0 s is not used
    np.testing.assert_allclose(curve.thrust(t), expected, rtol=0, atol=1e-12)
    assert curve.thrust(np.array([4.3]))[0] == 0.0 and np.interp(3.1, curve.time_s,
                                                                   curve.thrust_n) > 0
    # the mass holds the burn's end values beyond it
    np.testing.assert_allclose(curve.mass(np.array([0.0, 10.0])),
                               np.interp([0.0, 2.8], curve.time_s, curve.mass_kg))


def test_impulse_equals_quad_of_the_curve() -> None:
    curve = _curve()

    def force(s: float) -> float:
        return float(np.interp(s, curve.time_s, curve.thrust_n))

    pts = list(curve.time_s)
    assert curve.impulse() == pytest.approx(quad(force, 0.0, 3.2, points=pts)[0], rel=1e-10)
    used = quad(force, 0.0, 4.0 - 1.2, points=pts[:3])[0]
    assert curve.impulse(*curve.burn_s) == pytest.approx(used, rel=1e-10)
    assert "impulse 1058" in curve.describe() or f"impulse {used:.6g}" in curve.describe()


def test_simulated_burn_obeys_the_rocket_equation_and_f_equals_ma() -> None:
    scenario = load_scenario(BURNOUT)
    m0, m1, thrust, burn = 14.0, 10.0, 600.0, 2.0
    curve = ThrustCurve(time_s=[0.0, burn], thrust_n=[thrust, thrust], origin_s=0.5,
                        burn_s=(0.5, 0.5 + burn), mass_kg=[m0, m1])
    airframe = scenario.airframe.replace(thrust_curve=curve)
    manoeuvre = dataclasses.replace(scenario.manoeuvre, window_s=(0.0, 3.0),
                                    initial_state=(100.0, 0, 0, 0, 0, 0, 0, 0, 0))
    flight = simulate(airframe, np.zeros(N_COEFFICIENTS), manoeuvre)  # no aerodynamics
    t, u = flight.t, flight["u"]
    a, b = int(np.argmin(abs(t - 0.6))), int(np.argmin(abs(t - 2.4)))
    rate = (m0 - m1) / burn

    def mass(time: float) -> float:
        return m0 - rate * (time - 0.5)

    # level and not rotating: gravity is along body z, so u changes by T / m alone
    du = thrust / rate * math.log(mass(t[a]) / mass(t[b]))
    assert u[b] - u[a] == pytest.approx(du, rel=ROCKET_EQUATION_RTOL)
    assert u[int(np.argmin(abs(t - 0.4)))] == pytest.approx(100.0, abs=1e-9)  # before it
    np.testing.assert_allclose(flight["ax1"][a:b], thrust / np.array([mass(x) for x in
                                                                      t[a:b]]), rtol=1e-12)
    np.testing.assert_allclose(flight["thrust"], curve.thrust(t))
    np.testing.assert_allclose(flight["mass"], curve.mass(t))


def test_flight_gets_the_channels_and_refuses_a_burn_without_mass() -> None:
    scenario = load_scenario(BURNOUT)
    flight = simulate_scenario(scenario, GaussianNoise(), rng=1)
    bare = dataclasses.replace(flight, data=flight.data.drop(columns=["thrust", "mass"]))
    with pytest.raises(FlightError, match="no 'thrust' channel"):
        exogenous(bare)  # an airframe curve is never ignored
    made, note = with_thrust_curve(bare)
    np.testing.assert_array_equal(made["thrust"], flight["thrust"])
    np.testing.assert_array_equal(made["mass"], flight["mass"])
    assert "161 of 501 samples inside the burn" in note and "0..1.6 s" in note
    with pytest.raises(FlightError, match="use one"):
        with_thrust_curve(made)  # a second thrust
    no_mass = dataclasses.replace(scenario.airframe.thrust_curve, mass_kg=None)
    with pytest.raises(FlightError, match=r"161 samples \(0..1.6 s\) are inside the burn"):
        with_thrust_curve(dataclasses.replace(bare, airframe=bare.airframe.replace(
            thrust_curve=None)), no_mass)
    coast = dataclasses.replace(bare, data=bare.data[bare.data["t"] > 1.65])
    coasting, note = with_thrust_curve(coast, no_mass)  # after the burn: no mass needed
    assert np.all(coasting["thrust"] == 0) and "mass" not in coasting.channels
    assert "no sample inside the burn" in note
    with pytest.raises(AirframeError, match="thrust_N = 0"):
        with_thrust_curve(dataclasses.replace(coast, airframe=coast.airframe.replace(
            thrust_curve=None, thrust_n=50.0)), no_mass)


def test_file_forms_read_back_and_bad_files_are_one_line_errors(tmp_path) -> None:
    (tmp_path / "motor.csv").write_text("time_s,thrust_N,mass_kg\n0,0,14\n0.1,400,13.9\n"
                                        "3.0,380,12.1\n3.2,0,12\n")
    curve = read_thrust_curve(tmp_path / "motor.csv", origin_s=1.2, burn_s=(1.2, 4.0))
    assert curve == _curve(source="x")
    scenario = load_scenario(BURNOUT)
    text = (tmp_path / "a.toml")
    save_airframe(scenario.airframe.replace(thrust_curve=curve), text)
    assert load_airframe(text).thrust_curve == curve
    body = text.read_text().split("[thrust_curve]")[0]
    text.write_text(body + '[thrust_curve]\nfile = "motor.csv"\norigin_s = 1.2\n'
                    'burn_s = [1.2, 4.0]\n')
    assert load_airframe(text).thrust_curve == curve  # relative to the airframe file
    cases = {
        "time_s,thrust_N,extra\n0,1,2\n1,1,2\n": "not used: extra",
        "time_s,thrust_N\n0,1\n0,1\n": "value 2: 0 after 0",
        "time_s,thrust_N\n0,1\n1,-5\n": "thrust_N value 2 is -5",
        "time_s,thrust_N\n0,1\n1,x\n": "column thrust_N line 3 is not a finite number",
        "time_s\n0\n1\n": "missing: thrust_n",
    }
    for i, (content, message) in enumerate(cases.items()):
        path = tmp_path / f"bad{i}.csv"
        path.write_text(content)
        with pytest.raises(AirframeError, match=message) as info:
            read_thrust_curve(path, origin_s=0.0, burn_s=(0.0, 1.0))
        assert "\n" not in str(info.value) and str(info.value).startswith(str(path))
    with pytest.raises(AirframeError, match="outside the curve"):
        _curve(burn_s=(5.0, 6.0))
    with pytest.raises(AirframeError, match="start < end"):
        _curve(burn_s=(3.0, 2.0))
    with pytest.raises(AeroidError, match="either file"):
        ThrustCurve.from_table({"origin_s": 0.0, "burn_s": [0, 1]})


@pytest.fixture(scope="module")
def burn_flight():
    scenario = load_scenario(BURNOUT)
    manoeuvre = dataclasses.replace(scenario.manoeuvre, window_s=(0.0, 3.0))
    return simulate(scenario.airframe, scenario.coefficient_vector, manoeuvre,
                    GaussianNoise(), rng=7)


def test_fit_across_the_burn_with_the_curve_and_refused_without(burn_flight) -> None:
    estimator = make_estimator("output-error", {})
    with_curve = estimator.fit(burn_flight, rng=1)
    assert with_curve.success, with_curve.message
    truth = burn_flight.true_coefficients
    for name in ("Cx", "Cl0", "Clp", "Cma"):
        j = with_curve.names.index(name)
        assert abs(with_curve.theta[j] - truth[j]) < 3 * with_curve.stderr[j], name
    # the same log as if the motor were not known: the airframe's constant thrust (0)
    bare = dataclasses.replace(burn_flight, data=burn_flight.data.drop(
        columns=["thrust", "mass"]), airframe=burn_flight.airframe.replace(thrust_curve=None))
    without = estimator.fit(bare, rng=1)
    assert not without.success
    check = without.info["fit_check"]  # the fit check's verdict, not only the optimiser's
    assert check["ratio"][check["worst"]] > RATIO_LIMIT
    check = with_curve.info["fit_check"]
    assert check["ratio"][check["worst"]] < RATIO_LIMIT


def test_written_flight_carries_its_curve(tmp_path, burn_flight) -> None:
    burn_flight.write(tmp_path / "burn.csv")
    back = read_flight(tmp_path / "burn.csv")
    assert back.airframe.thrust_curve == burn_flight.airframe.thrust_curve
    np.testing.assert_allclose(back["thrust"], burn_flight["thrust"])
