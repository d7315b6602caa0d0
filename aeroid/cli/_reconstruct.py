"""``aeroid reconstruct``: a sensor-suite log in, the reconstructed states out.

Registered by :mod:`aeroid.cli` (:func:`add_parser`, :func:`reconstruct`). User errors
(a missing or malformed log, an unknown unit, a missing output folder) raise the
classes of :data:`aeroid.errors.USER_ERRORS`: one line, exit status 2. A source whose
residual check is NOT consistent with its stated sd ends it with exit status 1
(:data:`aeroid.cli._exits.EXIT_NOT_SUCCESS`), after everything asked for is written and a
last line on stderr names the sources.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from aeroid.cli._exits import EXIT_DONE, EXIT_NOT_SUCCESS
from aeroid.errors import UsageError

__all__ = ["add_parser", "reconstruct"]


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the ``reconstruct`` sub-command to ``sub``."""
    p = sub.add_parser(
        "reconstruct", help="reconstruct states and IMU errors from a sensor-suite log",
        description=("Flight-path reconstruction: a kinematic EKF and RTS smoother driven "
                     "by the log's IMU, aided by its GNSS, barometer and INS, estimates "
                     "u v w, attitude, NED position and the IMU's biases and scale "
                     "factors, with their sd, at the IMU's rate."),
        epilog="examples:\n"
               "  aeroid reconstruct suite.toml -o states.csv\n"
               "  aeroid reconstruct suite.toml -o states.csv --flight flight.csv\n"
               "  aeroid reconstruct suite.toml -o states.csv --report report/\n"
               "  aeroid reconstruct suite.toml -o states.csv --flight raw.csv --raw-imu\n"
               "  aeroid estimate raw.csv --method output-error --option "
               "imu_errors=bias+scale\n\n"
               "Exit status: 0 done, every source's residual check consistent; 1 a\n"
               "source NOT consistent with its stated sd (every file still written);\n"
               "2 bad input.",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("log", type=Path, help="suite log TOML (its CSV files beside it)")
    p.add_argument("-o", "--output", type=Path, required=True,
                   help="CSV of the reconstruction (t, states, their sd_*, corrected IMU)")
    p.add_argument("--airframe", type=Path, help="airframe TOML (wins over the log's)")
    p.add_argument("--flight", type=Path,
                   help="also write aeroid's single-rate flight CSV (for 'aeroid estimate')")
    p.add_argument("--per-sample-density", action="store_true",
                   help="the flight's density per sample: rho = p / (R T) when the "
                        "barometer logs pressure and temperature, else ISA at the "
                        "reconstructed altitude (default: the airframe's atmosphere)")
    p.add_argument("--report", type=Path, metavar="DIR",
                   help="write DIR/reconstruction.md and PNG figures: each aiding source's "
                        "innovations against their sd band, the states with their sd band, "
                        "the instrument errors with their sd")
    p.add_argument("--raw-imu", action="store_true",
                   help="the flight's IMU channels as logged, not corrected (for an "
                        "estimator that fits the IMU's errors: output-error's imu_errors)")
    p.add_argument("--aiding", action="store_true",
                   help="--flight's sidecar also carries the log's GNSS velocity samples at "
                        "their own times (for output-error's aiding = gnss-velocity)")


def reconstruct(args: argparse.Namespace) -> int:
    """Run ``aeroid reconstruct``: read, reconstruct, write, print the residual check."""
    from aeroid.flights import read_suite_log
    from aeroid.model import load_airframe
    from aeroid.reconstruction import reconstruct as run

    for out in (args.output, args.flight):
        if out is not None and not out.parent.exists():
            raise UsageError(f"{out}: folder {out.parent} does not exist")
    for flag in ("raw_imu", "aiding"):
        if getattr(args, flag) and args.flight is None:
            raise UsageError(f"--{flag.replace('_', '-')}: it sets --flight's file; give --flight")
    if args.report is not None:  # before the filter: an unwritable folder is said at once
        from aeroid.report import make_directory

        make_directory(args.report)
    log = read_suite_log(args.log)
    airframe = load_airframe(args.airframe) if args.airframe else None
    result = run(log, airframe=airframe)
    result.table.to_csv(args.output, index=False, float_format="%.17g")
    for note in result.notes:
        print(f"aeroid: {note}")
    for source, stats in result.nis.items():
        low, high = stats["interval"]
        verdict = "consistent" if stats["consistent"] else "NOT consistent"
        print(f"{source}: mean NIS per dof {stats['mean_nis_per_dof']:.3f} over "
              f"{stats['n_updates']} updates, {verdict} with the stated noise sd "
              f"(chi-square interval {low:.2f}-{high:.2f})")
    refused = [source for source, stats in result.nis.items() if not stats["consistent"]]
    print(f"wrote {args.output} ({len(result.table)} samples)")
    if args.report is not None:
        from aeroid.report import write_reconstruction_report

        print(f"wrote {write_reconstruction_report(result, args.report)} and its figures")
    if args.flight is not None:
        atmosphere = "per-sample" if args.per_sample_density else "airframe"
        imu = "raw" if args.raw_imu else "corrected"
        flight = result.to_flight(atmosphere=atmosphere, imu=imu, aiding=args.aiding)
        sidecar = flight.write(args.flight)
        density = next(n for n in flight.metadata["notes"] if n.startswith("flight density"))
        print(f"wrote {args.flight} and {sidecar} ({density}; IMU: {imu})")
    if refused:
        print(f"aeroid: the residual check refused {', '.join(refused)} (mean NIS outside its "
              f"chi-square interval): exit status {EXIT_NOT_SUCCESS}", file=sys.stderr)
        return EXIT_NOT_SUCCESS
    return EXIT_DONE
