"""``aeroid estimate --thrust-curve CSV --thrust-origin S --burn A:B`` (issue 25).

The log of studies/scenarios/rocket_burnout.toml (the last 1.6 s of a burn, then coast)
is written without its thrust and mass columns and without the curve in its sidecar, as
a flight computer's would be; the motor file is the scenario's curve. The fit with the
three flags gets back the truth; the same command line's refusals are one line each.
"""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import pytest

from aeroid.cli import main
from aeroid.flights import GaussianNoise, load_scenario, simulate_scenario
from aeroid.model import NAMES

ROOT = Path(__file__).resolve().parents[2]
#: Output-error's estimates within this many of their own standard errors (the
#: burnout scenario's truth, rng 5: within 1.5, measured).
WITHIN_SE = 3.0


@pytest.fixture(scope="module")
def burn_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("burn")
    scenario = load_scenario(ROOT / "studies" / "scenarios" / "rocket_burnout.toml")
    flight = simulate_scenario(scenario, GaussianNoise(), rng=5)
    curve = scenario.airframe.thrust_curve
    bare = dataclasses.replace(flight, data=flight.data.drop(columns=["thrust", "mass"]),
                               airframe=flight.airframe.replace(thrust_curve=None))
    log = folder / "log.csv"
    bare.write(log)
    motor = folder / "motor.csv"
    motor.write_text("time_s,thrust_N,mass_kg\n" + "".join(
        f"{t!r},{f!r},{m!r}\n" for t, f, m in zip(curve.time_s.tolist(), curve.thrust_n.tolist(),
                                                   curve.mass_kg.tolist(), strict=True)))
    no_mass = folder / "motor-no-mass.csv"
    no_mass.write_text("time_s,thrust_N\n" + "".join(
        f"{t!r},{f!r}\n" for t, f in zip(curve.time_s.tolist(), curve.thrust_n.tolist(),
                                          strict=True)))
    return log, motor, no_mass, dict(zip(NAMES, scenario.coefficient_vector, strict=True))


def test_estimate_with_a_thrust_curve_says_what_it_used(burn_files, capsys):
    log, motor, _, truth = burn_files
    status = main(["estimate", str(log), "--method", "output-error", "--json",
                   "--thrust-curve", str(motor), "--thrust-origin", "-0.5", "--burn", "0:1.6"])
    out = capsys.readouterr()
    assert status == 0, out.err
    notes = [line for line in out.err.splitlines() if "thrust curve of 6 points" in line]
    assert len(notes) == 1
    assert "its t = 0 at -0.5 s on the log clock; used inside the burn window 0..1.6 s only" \
        in notes[0] and "161 of 501 samples inside the burn" in notes[0]
    result = json.loads(out.out)
    for name in ("Cx", "Cl0", "Clp", "Cma"):
        assert abs(result["coefficients"][name] - truth[name]) < WITHIN_SE * \
            result["stderr"][name], name


def test_a_burn_without_its_mass_and_missing_flags_are_refused(burn_files, capsys):
    log, motor, no_mass, _ = burn_files
    assert main(["estimate", str(log), "--method", "output-error", "--thrust-curve",
                 str(no_mass), "--thrust-origin", "-0.5", "--burn", "0:1.6"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "161 samples (0..1.6 s) are inside the burn window 0..1.6 s" \
        in err[0] and "no mass along the burn" in err[0]
    assert main(["estimate", str(log), "--method", "output-error", "--thrust-curve",
                 str(motor), "--thrust-origin", "-0.5"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == ("aeroid: error: --thrust-curve, --thrust-origin, --burn go together "
                   "(missing --burn): aeroid assumes no time origin or burn window")
    assert main(["estimate", str(log), "--method", "output-error", "--thrust-curve",
                 str(motor), "--thrust-origin", "-0.5", "--burn", "2:1"]) == 2
    assert "--burn: expected START < END" in capsys.readouterr().err


def test_the_same_log_without_the_curve_fails_the_fit_check(burn_files, capsys):
    log, *_ = burn_files
    status = main(["estimate", str(log), "--method", "output-error"])
    out = capsys.readouterr().out
    assert status == 1 and "output-error: FAILED" in out
    found = re.search(r"fit check: residual RMS / data noise ([0-9.e+]+) at worst "
                      r"\(\w+; limit ([0-9.]+)", out)
    assert float(found[1]) > float(found[2])  # refused by the fit check (measured ~500x)
