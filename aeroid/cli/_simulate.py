"""``aeroid simulate``: simulate a scenario's flight and write it (called by :mod:`aeroid.cli`).

User errors (missing or malformed scenario, missing output folder) raise the classes
of :data:`aeroid.errors.USER_ERRORS`; the CLI prints them as one line and exits with
status 2.
"""

from __future__ import annotations

import argparse

from aeroid.errors import UsageError

__all__ = ["simulate"]


def simulate(args: argparse.Namespace) -> int:
    """Run ``aeroid simulate``: simulate, write the flight and its sidecar, say where."""
    from aeroid.flights._scenario import load_scenario, noise_for, reference_scenario_data
    from aeroid.flights._simulate import simulate as simulate_flight
    from aeroid.model._airframe import read_toml

    if not args.output.parent.exists():
        raise UsageError(f"{args.output}: folder {args.output.parent} does not exist")
    scenario = load_scenario(args.scenario)
    data = read_toml(args.scenario) if args.scenario else reference_scenario_data()
    noise = noise_for(data, args.noise)
    flight = simulate_flight(scenario.airframe, scenario.coefficient_vector,
                             scenario.manoeuvre, noise, rng=args.seed)
    sidecar = flight.write(args.output)
    print(f"wrote {args.output} ({flight.n_samples} samples, noise {args.noise}, "
          f"seed {args.seed}) and {sidecar}")
    return 0
