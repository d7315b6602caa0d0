"""Measure what breaks aeroid's estimators on JSBSim flights, and what mends them.

Run by hand (not collected by pytest; 5 minutes on two cores; results.md holds a run)::

    PYTHONPATH=. python -m tests.crossengine.measure            # every table
    PYTHONPATH=. python -m tests.crossengine.measure today      # one table

Tables (markdown, mean |error| % per coefficient, then the mean over the nine):

* ``today``: aeroid's estimators as they are, on the noise-free flights and with
  aeroid's default Gaussian IMU noise (0.05 m/s^2, 0.005 rad/s; seeds 1-5).
* ``effects``: the output-error prototype (:mod:`.prototype`) on the noise-free
  flights with one model input changed at a time, and the equation-error fit with
  per-sample density.
* ``noise``: the prototype with the inputs that suffice, on Gaussian-noise flights: the
  error in units of its Cramér-Rao standard deviation.
* ``delay``: a flight with a 1 ms actuator delay, with and without an estimated delay.
* ``engine``: what the engine's world adds (planet curvature, gravity variation, Earth
  rotation) and how the engine renders the relay (per frame or sub-frame, frame rate).
"""

from __future__ import annotations

import dataclasses
import sys
import time

import numpy as np

import aeroid
from aeroid.model import G0, NAMES, RelayActuator

from . import prototype as pt
from .jsbsim_flight import FlightConfig, Truth, make_flight

#: The flights of the tables: the default climb and a slower, flatter, lower one with
#: another fin law.
FLIGHTS: dict[str, FlightConfig] = {
    "climb": FlightConfig(),
    "loft": FlightConfig(name="xe_loft", altitude_m=1200.0, speed_mps=430.0, theta_deg=20.0,
                         command_amplitude=0.45, command_phase_deg=-50.0, p_radps=20.0,
                         window_s=(0.4, 1.4)),
}
NOISE = aeroid.GaussianNoise()
SEEDS = (1, 2, 3, 4, 5)
#: aeroid's EAM-PSO at a reduced budget (the default 450 x 200 takes minutes per fit).
EAM_OPTIONS = {"n_particles": 60, "n_iterations": 100}


def _row(label: str, errors: np.ndarray, extra: str = "") -> str:
    cells = " | ".join(f"{e:.3g}" for e in errors)
    return f"| {label} | {cells} | {np.mean(errors):.3g} |{extra}"


def _header(first: str, extra: str = "") -> str:
    names = " | ".join(NAMES)
    return (f"| {first} | {names} | mean |{extra}\n"
            f"|---|{'---|' * len(NAMES)}---|{'---|' if extra else ''}")


def _error(theta: np.ndarray, truth: Truth) -> np.ndarray:
    return np.abs(theta / truth.coefficients - 1.0) * 100.0


def table_today() -> None:
    """aeroid's estimators as they are."""
    methods = [("output-error", {}), ("equation-error", {}), ("ekf", {}),
               ("eam-pso", EAM_OPTIONS)]
    for key, config in FLIGHTS.items():
        clean, truth = make_flight(config)
        print(f"\n### today, flight {key}\n")
        print(_header("method (noise)", " success |"))
        for name, options in methods:
            est = aeroid.make_estimator(name, options)
            res = est.fit(clean, rng=1)
            print(_row(f"{name} (none)", _error(res.theta, truth), f" {res.success} |"))
            errs, ok = [], 0
            for seed in SEEDS:
                noisy, _ = make_flight(config, noise=NOISE, rng=seed)
                res = est.fit(noisy, rng=seed)
                errs.append(_error(res.theta, truth))
                ok += bool(res.success)
            print(_row(f"{name} (Gaussian, {len(SEEDS)} seeds)", np.mean(errs, axis=0),
                       f" {ok}/{len(SEEDS)} |"))


def _inputs(flight, truth: Truth, *, delta: str, rho: bool, gravity: bool,
            substeps: int = 2) -> pt.Inputs:
    d = truth.data
    fields: dict = {"t": flight.t, "substeps": substeps,
                    "rho": d["rho"].to_numpy() if rho else flight.airframe.density_kgm3,
                    "gravity": d["gravity"].to_numpy() if gravity else G0}
    if delta in ("hold", "midpoint"):
        fields.update(pt.logged_events(flight, delta))
    elif delta == "events":
        fields.update(switch_times=truth.switch_times, switch_values=truth.switch_values,
                      initial_delta=truth.initial_delta)
    elif delta == "law":  # the first delay_s of the window from the logged deflection
        c = truth.config
        fields.update(pt.logged_events(flight, "midpoint"))
        fields.update(delta_mode="law", relay=RelayActuator(
            delta_max_rad=np.radians(c.delta_max_deg), command_amplitude=c.command_amplitude,
            command_phase_rad=np.radians(c.command_phase_deg)))
    return pt.Inputs(**fields)


#: (label, delta input, per-sample rho, per-sample gravity, estimate delay)
EFFECTS = (
    ("hold, one density, g0 (aeroid today)", "hold", False, False, False),
    ("hold + per-sample density", "hold", True, False, False),
    ("hold + estimated delay", "hold", False, False, True),
    ("hold + estimated delay + per-sample density", "hold", True, False, True),
    ("midpoint", "midpoint", False, False, False),
    ("midpoint + per-sample density", "midpoint", True, False, False),
    ("midpoint + estimated delay + per-sample density", "midpoint", True, False, True),
    ("true switch instants (events), one density", "events", False, False, False),
    ("events + per-sample density", "events", True, False, False),
    ("events + per-sample density + per-sample gravity", "events", True, True, False),
    ("law (switch located in the step), one density", "law", False, False, False),
    ("law + per-sample density", "law", True, False, False),
    ("law + per-sample density + per-sample gravity", "law", True, True, False),
)


def table_effects() -> None:
    """One model input at a time, noise-free flights."""
    for key, config in FLIGHTS.items():
        flight, truth = make_flight(config)
        print(f"\n### output-error prototype, flight {key} (noise-free)\n")
        print(_header("model input", " delay [us] |"))
        for label, delta, rho, grav, delay in EFFECTS:
            fit = pt.fit_output_error(flight, _inputs(flight, truth, delta=delta, rho=rho,
                                                      gravity=grav), estimate_delay=delay)
            extra = f" {fit.delay_s * 1e6:.2f} +- {fit.delay_sd * 1e6:.2f} |" if delay else " |"
            print(_row(label, _error(fit.theta, truth), extra))
        print(f"\n### equation-error, flight {key} (noise-free)\n")
        print(_header("regressors"))
        today = aeroid.make_estimator("equation-error").fit(flight, rng=1)
        print(_row("aeroid today (one density)", _error(today.theta, truth)))
        theta = pt.equation_error_per_sample_density(flight)
        print(_row("prototype, one density", _error(theta, truth)))
        theta = pt.equation_error_per_sample_density(flight, truth.data["rho"].to_numpy())
        print(_row("prototype, per-sample density", _error(theta, truth)))


def table_noise() -> None:
    """The sufficient inputs with Gaussian noise: errors in Cramér-Rao sd."""
    for key, config in FLIGHTS.items():
        print(f"\n### output-error prototype with Gaussian noise, flight {key}: "
              f"|error| / Cramér-Rao sd, then mean |error| %\n")
        print(_header("model input (seed)", " max |z| |"))
        errs: dict[str, list] = {"events": [], "law": [], "law from prior": []}
        for seed in SEEDS:
            flight, truth = make_flight(config, noise=NOISE, rng=seed)
            fits = {"events": pt.fit_output_error(flight, _inputs(
                flight, truth, delta="events", rho=True, gravity=True))}
            law = _inputs(flight, truth, delta="law", rho=True, gravity=True)
            fits["law from prior"] = pt.fit_output_error(flight, law)
            first = pt.fit_output_error(flight, _inputs(flight, truth, delta="midpoint",
                                                        rho=True, gravity=True))
            fits["law"] = pt.fit_output_error(flight, law, theta0=first.theta)
            for name, fit in fits.items():
                z = np.abs(fit.theta - truth.coefficients) / fit.stderr
                errs[name].append(_error(fit.theta, truth))
                if name != "law from prior":
                    print(_row(f"{name} + density + gravity ({seed})", z, f" {np.max(z):.2f} |"))
        for name, found in errs.items():
            print(_row(f"{name}: mean |error| %", np.mean(found, axis=0), " |"))
        print("\n(law: started from a midpoint-input fit; law from prior: started from the "
              "airframe prior)")


def table_delay() -> None:
    """A flight with a 1 ms actuator delay: which inputs find it."""
    config = dataclasses.replace(FLIGHTS["climb"], name="xe_delayed", fin_delay_s=0.001)
    flight, truth = make_flight(config)
    print("\n### 1 ms actuator delay, flight climb (noise-free, output-error prototype)\n")
    print(_header("model input", " delay [us] |"))
    rows = (("hold (aeroid today)", "hold", False), ("midpoint", "midpoint", False),
            ("midpoint + estimated delay", "midpoint", True), ("law, no delay", "law", False),
            ("law + estimated delay", "law", True), ("true switch instants", "events", False))
    for label, delta, delay in rows:
        fit = pt.fit_output_error(flight, _inputs(flight, truth, delta=delta, rho=True,
                                                  gravity=True), estimate_delay=delay)
        extra = f" {fit.delay_s * 1e6:.3f} +- {fit.delay_sd * 1e6:.3f} |" if delay else " |"
        print(_row(label + " + density", _error(fit.theta, truth), extra))


def table_engine() -> None:
    """The engine's world and frame rate."""
    base = FLIGHTS["climb"]
    print("\n### the engine's world, flight climb (noise-free, output-error prototype)\n")
    print(_header("planet / model input"))
    for planet in ("flat", "sphere", "earth"):
        flight, truth = make_flight(dataclasses.replace(base, planet=planet))
        for grav in (False, True):
            fit = pt.fit_output_error(flight, _inputs(flight, truth, delta="events", rho=True,
                                                      gravity=grav))
            label = f"{planet}: events + density" + (" + gravity" if grav else ", g0")
            print(_row(label, _error(fit.theta, truth)))
    print("\n### JSBSim's relay rendering and frame rate, flight climb (noise-free)\n")
    print(_header("switching, frame rate / model input"))
    for switching in ("subframe", "frame"):
        for rate in (8000.0, 16000.0, 32000.0, 64000.0):
            flight, truth = make_flight(dataclasses.replace(base, frame_rate_hz=rate,
                                                            switching=switching))
            for delta in ("events", "law"):
                fit = pt.fit_output_error(flight, _inputs(flight, truth, delta=delta, rho=True,
                                                          gravity=True))
                print(_row(f"{switching}, {rate / 1000:g} kHz: {delta} + density + gravity",
                           _error(fit.theta, truth)))


TABLES = {"today": table_today, "effects": table_effects, "noise": table_noise,
          "delay": table_delay, "engine": table_engine}


def main(argv: list[str]) -> None:
    """Print the tables named in ``argv`` (default: all) with their run time."""
    for name in argv or list(TABLES):
        start = time.perf_counter()
        TABLES[name]()
        print(f"\n({name}: {time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main(sys.argv[1:])
