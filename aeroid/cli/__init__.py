"""Command line: ``aeroid simulate | estimate | methods | study``.

Bad input (a missing file, malformed TOML, an unknown option value, an invalid flight,
a number out of range) exits with status 2 and one line on stderr saying what and
where; ``--debug`` shows the traceback instead. Warnings about input that is accepted
but suspect (:class:`aeroid.errors.AeroidWarning`) are one line each on stderr,
``aeroid: warning: MESSAGE``.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import textwrap
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

from aeroid import __version__
from aeroid.cli._exits import (
    NamedStream,
    Terminated,
    WarningLines,
    catch_sigterm,
    drop_stdout,
    os_message,
    restore_sigterm,
)
from aeroid.errors import AeroidWarning

#: Most local worker processes (``--jobs``, ``--dask-local``). Each is a Python process
#: with numpy, numba and CasADi loaded (~150 MB): 256 is more than any machine we target
#: has cores, and far below what would exhaust the process table or the memory.
MAX_WORKERS = 256

_DESCRIPTION = """\
aeroid: estimate the nine aerodynamic coefficients of a rolling airframe from flight
data (accelerometers, rates, attitude), with the paper's EAM-PSO, EBM-PSO, SEBM-PSO and
baselines (EKF, UKF, output-error, equation-error, pyswarms), and compare them in
seeded Monte Carlo studies."""

_EPILOG = """\
examples:
  aeroid simulate --seed 1 -o flight.csv        # the paper's reference flight
  aeroid estimate flight.csv --method sebm-pso  # fit it, print estimates and errors
  aeroid methods                                # list the methods
  aeroid methods --options eam-pso              # a method's options
  aeroid study --runs 5                         # a small Monte Carlo study

Run 'aeroid COMMAND --help' for a command's options. Exit status: 0 done, 1 the method
failed (estimate: result still printed) or a residual check is NOT consistent
(reconstruct: files still written), 2 bad input (one line on stderr)."""


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line on stderr (exit status 2).

    ``epilog_factory`` (optional) makes the epilog when help is shown, so help that
    lists the installed methods costs nothing on other calls.
    """

    def __init__(self, *args: Any, epilog_factory: Callable[[], str] | None = None,
                 **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", argparse.RawDescriptionHelpFormatter)
        super().__init__(*args, **kwargs)
        self._epilog_factory = epilog_factory

    def format_help(self) -> str:
        """Return the help text (with the lazily made epilog, if any)."""
        if self._epilog_factory is not None:
            self.epilog = self._epilog_factory()
        return super().format_help()

    def error(self, message: str) -> NoReturn:
        """Print ``PROG: error: MESSAGE (see PROG --help)`` and exit with status 2."""
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())} "
                     f"(see {self.prog} --help)\n")


def _para(text: str) -> str:
    """Return ``text`` wrapped for help output (the formatter keeps line breaks as given)."""
    return textwrap.fill(" ".join(text.split()), 80)


def _int_in(low: int, high: int | None = None) -> Callable[[str], int]:
    """Return an argparse type: an integer in ``[low, high]`` (no upper bound for None)."""
    def parse(text: str) -> int:
        value = int(text)  # ValueError: argparse says "invalid int value: 'x'"
        if value < low or (high is not None and value > high):
            span = f">= {low}" if high is None else f"in [{low}, {high}]"
            raise argparse.ArgumentTypeError(f"must be an integer {span}, got {value}")
        return value

    parse.__name__ = "int"
    return parse


def _add_simulate(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "simulate", help="simulate a flight of a scenario and write it as CSV",
        description=_para("Simulate the flight of a scenario (default: the paper's reference "
                    "scenario) with a sensor-noise model and write it as CSV (or Parquet) "
                          "with a JSON sidecar holding the airframe and the true "
                          "coefficients."),
        epilog="examples:\n"
               "  aeroid simulate --seed 1 -o flight.csv\n"
               "  aeroid simulate --noise none -o clean.csv\n"
               "  aeroid simulate --scenario my-scenario.toml --noise gaussian --seed 7 \\\n"
               "      -o f.parquet")
    p.add_argument("--scenario", type=Path, help="scenario TOML (default: embedded reference)")
    p.add_argument("--noise", choices=["paper", "gaussian", "none"], default="paper",
                   help="sensor noise model (default: paper, eq. 43)")
    p.add_argument("--seed", type=_int_in(0), default=None,
                   help="random seed of the noise, an integer >= 0")
    p.add_argument("-o", "--output", type=Path, required=True, help="flight CSV to write")
    p.add_argument("--quiet", action="store_true",
                   help="no notices (simulate draws no progress bar)")


def _methods_epilog() -> str:
    from aeroid.cli._estimate import methods_table

    return ("examples:\n"
            "  aeroid estimate flight.csv --method sebm-pso\n"
            "  aeroid estimate flight.csv --method eam-pso --seed 1 \\\n"
            "      --option n_particles=100 --option n_iterations=50\n"
            "  aeroid estimate log.csv --airframe airframe.toml --columns map.toml \\\n"
            "      --degrees --method equation-error --json\n"
            "  aeroid estimate flight.csv --method output-error --report fit-report\n"
            "  aeroid estimate flight.csv --method output-error --report drag \\\n"
            "      --reference-curve design_cd.csv --reference-area 0.0129\n"
            "  aeroid estimate flight.csv --method all --option n_iterations=20\n"
            "  aeroid estimate axial-log/rocket.toml --method axial-drag --mass-sd 0.3 \\\n"
            "      --report axial-report     # a flight computer's suite log itself\n\n"
            "methods ('aeroid methods --options NAME' lists a method's options):\n"
            + methods_table(indent="  ") + "\n\n"
            "Exit status: 0 done, 1 the method failed (its result is still printed), "
            "2 bad input.")


def _add_estimate(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "estimate", help="estimate the nine coefficients from a flight",
        description=_para("Estimate the nine aerodynamic coefficients from one flight log by one "
                    "method (or several, side by side) and print them with their standard "
                    "errors (and, for a simulated flight, the error against its true "
                    "coefficients); --report writes a report with figures of the model "
                    "against the data. A log without aeroid's JSON sidecar needs "
                    "--airframe."),
        epilog_factory=_methods_epilog)
    p.add_argument("flight", type=Path, nargs="+",
                   help="flight CSV (or .parquet); several files are fitted together as "
                        "windows with shared coefficients (each with its own sidecar); or "
                        "one suite log TOML (as 'aeroid reconstruct' reads it) for a method "
                        "that reads one (axial-drag)")
    p.add_argument("--windows", metavar="START-END[,START-END...]",
                   help="fit these time ranges [s] of the one log together (shared "
                        "coefficients; per window its own start, inputs, delay and biases)")
    p.add_argument("--method", required=True, metavar="NAME[,NAME...]|all",
                   help="estimator name (see 'aeroid methods'), several joined by commas, "
                        "or 'all': one side-by-side table")
    p.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                   help="estimator option (repeatable; see 'aeroid methods --options NAME'); "
                        "with several methods, given to those that take it")
    p.add_argument("--seed", type=_int_in(0), default=None,
                   help="random seed of the estimator, an integer >= 0")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument("--report", type=Path, metavar="DIR",
                   help="write DIR/report.md with PNG figures (several methods: one folder "
                        "per method and DIR/comparison.md; HTML: --report-format html)")
    p.add_argument("--report-format", choices=["md", "html"], default="md",
                   help="md: markdown (default); html: the same report as one HTML page "
                        "per report (report.html, comparison.html) beside its PNG figures")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no notices")
    p.add_argument("--airframe", type=Path, help="airframe TOML (a log without sidecar)")
    p.add_argument("--columns", type=Path,
                   help="TOML column map {file name = channel, \"\" to drop, or "
                        "{channel = \"p\", unit = \"deg/s\"}}")
    p.add_argument("--degrees", action="store_true",
                   help="angles in deg, rates in deg/s (columns without a unit in the map)")
    # held and prior coefficients (issue 25): aeroid.estimation.CoefficientSpec.parse
    p.add_argument("--hold", action="append", default=[], metavar="NAME=VALUE",
                   help="hold a coefficient at a value, not estimated (repeatable)")
    p.add_argument("--prior", action="append", default=[], metavar="NAME=MEAN:SD",
                   help="a Gaussian prior on a coefficient, sd > 0 (repeatable)")
    p.add_argument("--mass-sd", type=float, metavar="KG",
                   help="standard deviation of the airframe's mass [kg] (replaces the file's "
                        "mass_sd_kg): its share enters the standard errors")
    # a motor's thrust curve, used in its burn window only (issue 25): aeroid/cli/_thrust.py
    p.add_argument("--thrust-curve", type=Path, metavar="CSV",
                   help="the motor's thrust curve (time_s, thrust_N, optional mass_kg) on "
                        "its own clock; needs --thrust-origin and --burn")
    p.add_argument("--thrust-origin", type=float, metavar="S",
                   help="the log-clock time [s] of the thrust curve's t = 0")
    p.add_argument("--burn", metavar="START:END",
                   help="the log-clock window [s] where the motor burns: thrust 0 outside")
    # a design tool's drag curve beside the fitted Cx (issue 25): aeroid/cli/_reference.py
    p.add_argument("--reference-curve", type=Path, metavar="CSV",
                   help="a reference drag curve (columns Mach, Cd) drawn beside the fitted "
                        "Cx in the --report folder (drag_vs_reference.png); needs "
                        "--reference-area")
    p.add_argument("--reference-area", type=float, metavar="M2",
                   help="the reference curve's own reference area [m^2]: Cd = -Cx "
                        "S_aeroid / S_ref")


def _add_methods(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "methods", help="list the available estimators (or one method's options)",
        description=_para("List every installed estimator (built-ins and plug-ins of the "
                    "'aeroid.estimators' entry-point group) with a one-line description, "
                    "or, with --options, one method's options: type, default, meaning."),
        epilog="examples:\n  aeroid methods\n  aeroid methods --options sebm-pso")
    p.add_argument("--options", metavar="NAME", help="show the options of method NAME")


def _add_study(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "study", help="run a Monte Carlo study (default: the quick study)",
        description=_para("Run a seeded Monte Carlo study: simulate the runs of each noise "
                    "condition, fit every estimator, and write results and a report. "
                    "Without a file it runs the quick default study."),
        epilog="examples:\n"
               "  aeroid study --runs 5\n"
               "  aeroid study studies/paper_table5.toml --jobs 4\n"
               "  aeroid study studies/paper_table5.toml --jobs 4 --resume   "
               "# after an interruption")
    p.add_argument("study", nargs="?", type=Path, help="study TOML (default: quick study)")
    p.add_argument("--runs", type=_int_in(1), help="override the number of runs")
    p.add_argument("--jobs", type=_int_in(1, MAX_WORKERS), default=1,
                   help="local worker processes")
    p.add_argument("--scheduler", help="Dask scheduler address")
    p.add_argument("--dask-local", type=_int_in(1, MAX_WORKERS), metavar="N",
                   help="start a local Dask cluster")
    p.add_argument("--out", type=Path, help="output folder (default: results/<study>)")
    p.add_argument("--resume", action="store_true",
                   help="complete the study in --out (same design and code): run only "
                        "what is missing")
    p.add_argument("--overwrite", action="store_true",
                   help="move a previous study's results in --out into previous-N/ first")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no notices")


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser."""
    parser = _Parser(prog="aeroid", description=_DESCRIPTION, epilog=_EPILOG)
    parser.add_argument("--version", action="version", version=f"aeroid {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _add_simulate(sub)
    _add_estimate(sub)
    _add_methods(sub)
    _add_study(sub)
    from aeroid.cli._reconstruct import add_parser as add_reconstruct

    add_reconstruct(sub)
    return parser


def _dispatch(args: argparse.Namespace) -> int:
    if args.command == "simulate":
        from aeroid.cli._simulate import simulate

        return simulate(args)
    if args.command in ("estimate", "methods"):
        from aeroid.cli import _estimate as commands

        return commands.estimate(args) if args.command == "estimate" else commands.methods(args)
    if args.command == "reconstruct":
        from aeroid.cli._reconstruct import reconstruct

        return reconstruct(args)
    from aeroid.cli import _study as study_commands

    return study_commands.study(args)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``aeroid`` command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    quiet = bool(getattr(args, "quiet", False))
    notices = _notices(quiet)
    stdout, sys.stdout = sys.stdout, NamedStream(sys.stdout, "standard output")
    sigterm = catch_sigterm()
    try:
        return _run(args)
    finally:
        sys.stdout = stdout
        restore_sigterm(sigterm)
        logging.getLogger("aeroid").removeHandler(notices)


def _run(args: argparse.Namespace) -> int:
    """Dispatch the command; every way it can end is one line on stderr and a status."""
    from aeroid.errors import USER_ERRORS

    resume = ("; run the same command with --resume to complete only what is missing"
              if args.command == "study" else "")
    try:
        from aeroid.model import compile_clock

        lines = WarningLines()
        # a numba compilation in this process is named as it starts and timed as it ends
        # (the notice handler prints it; --quiet drops it); nothing when all is cached
        with compile_clock(logging.getLogger("aeroid").info), warnings.catch_warnings():
            warnings.simplefilter("default", AeroidWarning)
            warnings.showwarning = lines
            try:
                status = _dispatch(args)
            finally:
                lines.summary()
        sys.stdout.flush()  # a full disk behind '> file' shows here, not at exit
        return status
    except BrokenPipeError:
        drop_stdout()
        return _fail(args, "standard output was closed before everything was written "
                     "(broken pipe)")
    except USER_ERRORS as exc:
        return _fail(args, " ".join(str(exc).split("\n")) or type(exc).__name__)
    except OSError as exc:  # output that cannot be written, a name too long, a loop...
        if getattr(exc, "filename", None) == "standard output":
            drop_stdout()
        return _fail(args, os_message(exc))
    except RecursionError:
        return _fail(args, "input nested too deeply to read (thousands of levels)")
    except Terminated:
        print(f"aeroid: terminated by SIGTERM{resume}", file=sys.stderr)
        return 128 + signal.SIGTERM
    except KeyboardInterrupt:
        print(f"aeroid: interrupted{resume}", file=sys.stderr)
        return 130


def _fail(args: argparse.Namespace, message: str) -> int:
    """Print ``aeroid: error: MESSAGE`` (or re-raise with --debug); return status 2."""
    if args.debug:
        raise  # noqa: PLE0704 - called only from an except block of _run
    print(f"aeroid: error: {message}", file=sys.stderr)
    return 2


class _NoticeHandler(logging.Handler):
    """Prints aeroid's notices (logger ``aeroid``, level INFO) as ``aeroid: message``.

    A notice already printed by this command is not printed again (a study's fits each
    say that they take the fin law: once is enough); warnings always are.
    """

    def __init__(self, level: int) -> None:
        super().__init__(level=level)
        self._said: set[str] = set()

    def emit(self, record: logging.LogRecord) -> None:
        """Write one line on stderr."""
        message = record.getMessage()
        if record.levelno < logging.WARNING:
            if message in self._said:
                return
            self._said.add(message)
        print(f"aeroid: {message}", file=sys.stderr)


def _notices(quiet: bool) -> logging.Handler:
    """Attach the notice handler for one command (silent with ``--quiet``)."""
    handler = _NoticeHandler(level=logging.WARNING if quiet else logging.INFO)
    logger = logging.getLogger("aeroid")
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    return handler


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
