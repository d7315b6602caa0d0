"""``aeroid estimate LOG.toml --method axial-drag``: a flight computer's files, fitted as they are.

A sensor-suite log (the TOML that ``aeroid reconstruct`` reads, its CSV files beside it:
:func:`aeroid.flights.read_suite_log`) is told from a flight by its ``.toml`` suffix
(flights are CSV or Parquet). Only a method that reads a suite log itself fits it: one
whose class says ``reads_suite_log = True`` (the axial-drag method: an axial
accelerometer against a GNSS track, no reconstruction). Every other method fits a
flight, and is refused in one line saying to run ``aeroid reconstruct`` first. ``--method
all`` on a suite log fits the methods that read one (today axial-drag alone) and says so
in one line.

What the log's fit takes: ``--airframe`` (wins over the log's ``[log] airframe``, as in
``aeroid reconstruct``), ``--mass-sd``, ``--option``, ``--seed``, ``--json``,
``--report`` (``report.md`` with the Cx table against Mach:
:func:`aeroid.report.write_log_report`) and ``--reference-curve`` with
``--reference-area``; the conversion is said before the fit, a Mach range that misses
the curve's after it (the record's Mach range is that of the fitted track). Refused in
one line, before the log is read: several files, ``--windows``, ``--columns`` and
``--degrees`` (the log's TOML states its columns and units), and a method that does not
read a suite log. A motor: the airframe's ``[thrust_curve]``, or ``--thrust-curve CSV
--thrust-origin S --burn START:END`` replacing it (said in one line); the method puts its
thrust and mass into the fit where the log reaches into the burn.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from aeroid.errors import UsageError

__all__ = ["SUITE_SUFFIX", "estimate_log", "is_suite_log", "log_methods"]

#: The suffix of a suite log's TOML (a flight is CSV or Parquet).
SUITE_SUFFIX = ".toml"
#: Flags a suite log does not take, with the reason (said in one line).
NOT_WITH_A_LOG = {
    "windows": "a suite log is fitted over its whole span",
    "columns": "the log's TOML states its columns and units",
    "degrees": "the log's TOML states its columns and units",
}


def is_suite_log(args: argparse.Namespace) -> bool:
    """Whether ``aeroid estimate`` was given a suite log (a ``.toml`` file).

    Raises
    ------
    UsageError
        For a suite log among several files (a suite log is fitted alone).
    """
    files = [Path(f) for f in getattr(args, "flight", ())]
    logs = [f for f in files if f.suffix.lower() == SUITE_SUFFIX]
    if logs and len(files) > 1:
        raise UsageError(f"{logs[0]}: a suite log is fitted alone (several files are "
                         "windows of flights); give the one LOG.toml")
    return bool(logs)


def _reads_log(name: str) -> bool:
    from aeroid.estimation import get_estimator

    return bool(getattr(get_estimator(name), "reads_suite_log", False))


def log_methods(spec: str, path: Path) -> list[str]:
    """Return the methods of ``--method`` that fit the suite log ``path``.

    ``all``: every installed method that reads a suite log, said in one line (none
    installed: refused). A named method that does not read one is refused.

    Raises
    ------
    EstimatorError
        For an unknown method (one line naming the installed ones).
    UsageError
        For a method that fits a flight: run ``aeroid reconstruct`` first.
    """
    from aeroid.estimation import available, get_estimator

    flight = "flight.csv"
    reconstruct = (f"run 'aeroid reconstruct {path} -o states.csv --flight {flight}' first "
                   f"and fit {flight}")
    if spec.strip() == "all":
        installed = sorted(available(refresh=True))
        names = [n for n in installed if _reads_log(n)]
        if not names:
            raise UsageError(f"{path}: a suite log, and no installed method reads one; "
                             f"{reconstruct}")
        others = len(installed) - len(names)
        logging.getLogger("aeroid").info(
            f"--method all on a suite log: {', '.join(names)} (the installed methods that "
            f"read a suite log); the other {others} fit a flight: {reconstruct}")
        return names
    names = [n.strip() for n in spec.split(",")]
    for name in names:
        get_estimator(name)  # EstimatorError naming the installed methods
    refused = [n for n in names if not _reads_log(n)]
    if refused:
        readers = [n for n in sorted(available()) if _reads_log(n)]
        raise UsageError(f"{path}: a sensor-suite log; {', '.join(refused)} "
                         f"{'fits' if len(refused) == 1 else 'fit'} a flight: {reconstruct} "
                         f"({', '.join(readers) or 'no installed method'} reads a suite log "
                         "itself)")
    return names


def _refuse_flags(args: argparse.Namespace, path: Path) -> None:
    for flag, why in NOT_WITH_A_LOG.items():
        if getattr(args, flag, None):
            raise UsageError(f"--{flag.replace('_', '-')} is not taken with a suite log "
                             f"({path}): {why}")


def _read(args: argparse.Namespace, path: Path,
          with_mass_sd: Callable[[Any, float | None], Any]) -> Any:
    from aeroid.cli._thrust import curve_from_args
    from aeroid.flights import read_suite_log
    from aeroid.model import load_airframe

    curve = curve_from_args(args)  # --thrust-curve with its origin and burn: before the log
    log = read_suite_log(path)
    if getattr(args, "airframe", None):
        airframe = load_airframe(args.airframe)
        if log.airframe is not None:
            logging.getLogger("aeroid").info(f"--airframe {args.airframe}: replaces the "
                                             f"log's airframe file")
        log = dataclasses.replace(log, airframe=airframe)
    if log.airframe is None:
        raise UsageError(f"{path}: no airframe (the log's [log] airframe = \"FILE\", or "
                         "--airframe FILE): the mass, area and atmosphere are needed")
    if curve is not None:
        own = log.airframe.thrust_curve is not None
        log = dataclasses.replace(log, airframe=log.airframe.replace(thrust_curve=curve))
        logging.getLogger("aeroid").info(
            f"--thrust-curve: {curve.describe()}"
            + (" (the airframe's [thrust_curve] replaced)" if own else ""))
    return with_mass_sd(log, getattr(args, "mass_sd", None))


def estimate_log(args: argparse.Namespace, options: dict[str, str],
                 with_mass_sd: Callable[[Any, float | None], Any]) -> int:
    """Run ``aeroid estimate`` on a suite log (module docstring); return the exit status.

    ``options``: the parsed ``--option`` pairs; ``with_mass_sd``: the command's
    ``--mass-sd`` replacement (:func:`aeroid.cli._estimate.with_mass_sd`). Several
    methods (``a,b`` or ``all`` with more than one reader) are fitted in turn and their
    results printed one after the other (JSON: ``{"methods": [...]}``), each with its own
    ``--report`` folder. Returns 0, or 1 when a method failed (its result still printed).
    """
    from aeroid.cli._reference import reference_from_args
    from aeroid.estimation import CoefficientSpec, get_estimator, make_estimator

    path = Path(args.flight[0])
    _refuse_flags(args, path)
    names = log_methods(args.method, path)
    shares = {n: {k: v for k, v in options.items()
                  if k in get_estimator(n).option_names()} for n in names}
    unused = sorted(k for k in options if not any(k in s for s in shares.values()))
    if unused:
        raise UsageError(f"option(s) {', '.join(unused)} taken by none of {', '.join(names)} "
                         "(see 'aeroid methods --options NAME')")
    estimators = {n: make_estimator(n, shares[n]) for n in names}
    holds = CoefficientSpec.parse(getattr(args, "hold", None) or (),
                                  getattr(args, "prior", None) or ())
    curve = reference_from_args(args)  # a bad curve file or area: before the log
    report = getattr(args, "report", None)
    fmt = getattr(args, "report_format", "md")
    if report is None and fmt != "md":
        raise UsageError("--report-format is the format of --report DIR: give --report")
    log = _read(args, path, with_mass_sd)
    if curve is not None:
        from aeroid.report import conversion_note

        logging.getLogger("aeroid").info(conversion_note(log.airframe.area_m2, curve.area_m2))
    if report is not None:  # before the fits: an unwritable folder is said at once
        from aeroid.report import make_directory

        make_directory(report)
    results = {n: est.fit(log, rng=getattr(args, "seed", None),
                          holds=None if holds.empty else holds)
               for n, est in estimators.items()}
    if curve is not None:
        _warn_overlap(results, curve)
    if report is not None:
        from aeroid.report import write_log_report

        for name, result in results.items():
            folder = report if len(results) == 1 else report / name
            written = write_log_report(result, log, folder, fmt=fmt, reference=curve)
            print(f"aeroid: wrote {written}", file=sys.stderr)
    if getattr(args, "json", False):
        out = [r.to_json_dict() for r in results.values()]
        print(json.dumps(out[0] if len(out) == 1 else {"methods": out}, indent=2,
                         allow_nan=False))
    else:
        print("\n\n".join(r.summary() for r in results.values()))
    return 0 if all(r.success for r in results.values()) else 1


def _warn_overlap(results: dict[str, Any], curve: Any) -> None:
    """Warn (once per method) when the fitted track's Mach range misses the curve's."""
    import warnings

    from aeroid.errors import AeroidWarning
    from aeroid.report import overlap_note

    for result in results.values():
        given = result.info.get("mach_range")
        note = None if given is None else overlap_note((given[0], given[1]), curve)
        if note:
            warnings.warn(f"{result.estimator}: {note}", AeroidWarning, stacklevel=2)
