"""Command line: ``aeroid simulate | estimate | methods | study``.

Bad input (a missing file, malformed TOML, an unknown option value, an invalid
flight) exits with status 2 and one line on stderr saying what and where; ``--debug``
shows the traceback instead.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

from aeroid import __version__
from aeroid.errors import UsageError


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line on stderr (exit status 2)."""

    def error(self, message: str) -> NoReturn:
        """Print ``PROG: error: MESSAGE (see PROG --help)`` and exit with status 2."""
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())} "
                     f"(see {self.prog} --help)\n")


def _add_simulate(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("simulate", help="simulate a flight of a scenario and write it as CSV")
    p.add_argument("--scenario", type=Path, help="scenario TOML (default: embedded reference)")
    p.add_argument("--noise", choices=["paper", "gaussian", "none"], default="paper",
                   help="sensor noise model (default: paper, eq. 43)")
    p.add_argument("--seed", type=int, default=None, help="random seed of the noise")
    p.add_argument("-o", "--output", type=Path, required=True, help="flight CSV to write")


def _add_estimate(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("estimate", help="estimate the nine coefficients from a flight")
    p.add_argument("flight", type=Path, help="flight CSV (or .parquet)")
    p.add_argument("--method", required=True, help="estimator name (see 'aeroid methods')")
    p.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                   help="estimator option (repeatable)")
    p.add_argument("--seed", type=int, default=None, help="random seed of the estimator")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument("--airframe", type=Path, help="airframe TOML (a log without sidecar)")
    p.add_argument("--columns", type=Path, help="TOML column map {file name = channel}")
    p.add_argument("--degrees", action="store_true", help="angles in deg, rates in deg/s")


def _add_methods(sub: argparse._SubParsersAction) -> None:
    sub.add_parser("methods", help="list the available estimators")


def _add_study(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("study", help="run a Monte Carlo study (default: the quick study)")
    p.add_argument("study", nargs="?", type=Path, help="study TOML (default: quick study)")
    p.add_argument("--runs", type=int, help="override the number of runs")
    p.add_argument("--jobs", type=int, default=1, help="local worker processes")
    p.add_argument("--scheduler", help="Dask scheduler address")
    p.add_argument("--dask-local", type=int, metavar="N", help="start a local Dask cluster")
    p.add_argument("--out", type=Path, help="output folder (default: results/<study>)")
    p.add_argument("--resume", action="store_true",
                   help="complete the study in --out (same design and code): run only "
                        "what is missing")
    p.add_argument("--overwrite", action="store_true",
                   help="move a previous study's results in --out into previous-N/ first")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser."""
    parser = _Parser(prog="aeroid", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"aeroid {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = parser.add_subparsers(dest="command", required=True)
    _add_simulate(sub)
    _add_estimate(sub)
    _add_methods(sub)
    _add_study(sub)
    return parser


def cmd_simulate(args: argparse.Namespace) -> int:
    """Run ``aeroid simulate``."""
    from aeroid.flights._scenario import load_scenario, noise_for, reference_scenario_data
    from aeroid.flights._simulate import simulate
    from aeroid.model._airframe import read_toml

    scenario = load_scenario(args.scenario)
    data = read_toml(args.scenario) if args.scenario else reference_scenario_data()
    noise = noise_for(data, args.noise)
    flight = simulate(scenario.airframe, scenario.coefficient_vector, scenario.manoeuvre,
                      noise, rng=args.seed)
    if not args.output.parent.exists():
        raise UsageError(f"{args.output}: folder {args.output.parent} does not exist")
    sidecar = flight.write(args.output)
    print(f"wrote {args.output} ({flight.n_samples} samples, noise {args.noise}, "
          f"seed {args.seed}) and {sidecar}")
    return 0


def _dispatch(args: argparse.Namespace) -> int:
    if args.command == "simulate":
        return cmd_simulate(args)
    if args.command in ("estimate", "methods"):
        from aeroid.cli import _estimate as commands

        return commands.estimate(args) if args.command == "estimate" else commands.methods(args)
    from aeroid.cli import _study as study_commands

    return study_commands.study(args)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``aeroid`` command; returns the exit status."""
    from aeroid.errors import USER_ERRORS

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return _dispatch(args)
    except USER_ERRORS as exc:
        if args.debug:
            raise
        message = " ".join(str(exc).split("\n")) or type(exc).__name__
        print(f"aeroid: error: {message}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        hint = ("; finished fits are saved: rerun with --resume to complete the study"
                if args.command == "study" else "")
        print(f"aeroid: interrupted{hint}", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
