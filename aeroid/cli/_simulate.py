"""``aeroid simulate``: simulate a scenario's flight and write it (called by :mod:`aeroid.cli`).

User errors (missing or malformed scenario, missing output folder) raise the classes
of :data:`aeroid.errors.USER_ERRORS`; the CLI prints them as one line and exits with
status 2.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from aeroid.errors import UsageError

__all__ = ["simulate"]


def _exists(folder: Path) -> bool:
    """Whether ``folder`` exists; a name the system refuses (too long, a loop) says why."""
    try:
        folder.stat()
    except FileNotFoundError:
        return False
    except OSError as exc:
        raise UsageError(f"-o: folder {folder}: {exc.strerror or exc}") from None
    return True


def simulate(args: argparse.Namespace) -> int:
    """Run ``aeroid simulate``: simulate, write the flight and its sidecar, say where."""
    from aeroid.flights import load_scenario, noise_for
    from aeroid.flights import simulate as simulate_flight
    from aeroid.model import read_toml, reference_scenario_data

    if not _exists(args.output.parent):
        raise UsageError(f"{args.output}: folder {args.output.parent} does not exist")
    scenario = load_scenario(args.scenario)
    data = read_toml(args.scenario) if args.scenario else reference_scenario_data()
    noise = noise_for(data, args.noise)
    flight = simulate_flight(scenario.airframe, scenario.coefficient_vector,
                             scenario.manoeuvre, noise, rng=args.seed,
                             tables=scenario.tables)  # coefficient tables in Mach, if any
    try:
        sidecar = flight.write(args.output)
    except OSError as exc:  # a full disk, /proc, a name over 255 bytes, no permission
        raise UsageError(f"-o {args.output}: cannot write the flight: "
                         f"{exc.strerror or exc}") from None
    print(f"wrote {args.output} ({flight.n_samples} samples, noise {args.noise}, "
          f"seed {args.seed}) and {sidecar}")
    return 0
