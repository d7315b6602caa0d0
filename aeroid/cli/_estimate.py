"""``aeroid estimate`` and ``aeroid methods`` (dispatched from :mod:`aeroid.cli`).

User errors (unreadable or invalid flight, unknown method or option, malformed
``--option``) raise the classes of :data:`aeroid.errors.USER_ERRORS`; the CLI prints
them as one line and exits with status 2.

Progress: a fit of a method that reports progress (the paper's PSO methods, every
iteration) shows a tqdm bar on stderr while it runs, and the bar is removed when the
fit ends. It is shown only when stderr is a terminal, and never with ``--quiet`` or
``--no-progress`` or when ``--json`` output goes to a pipe or file (:func:`progress_wanted`).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import math
import sys
import textwrap
from typing import Any

from aeroid.cli._reference import check_reference, reference_from_args
from aeroid.cli._windows import read_windows, window_notes, window_table, windows_json
from aeroid.errors import AirframeError, EstimatorError, UsageError
from aeroid.estimation import (
    CoefficientSpec,
    ProgressEvent,
    available,
    get_estimator,
    load_errors,
    make_estimator,
)
from aeroid.flights import read_column_map, read_flight
from aeroid.model import load_airframe

__all__ = ["ProgressBar", "estimate", "method_names", "methods", "methods_table",
           "option_text", "parse_options", "progress_wanted", "read_column_map",
           "split_options", "with_mass_sd"]

#: Width of wrapped option descriptions in ``aeroid methods --options``.
TEXT_WIDTH = 88


def parse_options(pairs: list[str] | None) -> dict[str, str]:
    """Return ``{key: value text}`` from ``["key=value", ...]``.

    Raises
    ------
    EstimatorError
        ``--option 'x': expected KEY=VALUE`` for a malformed pair or a repeated key.
    """
    options: dict[str, str] = {}
    for pair in pairs or []:
        key, sep, value = pair.partition("=")
        key = key.strip()
        if not sep or not key or not value.strip():
            raise EstimatorError(f"--option {pair!r}: expected KEY=VALUE")
        if key in options:
            raise EstimatorError(f"--option {key!r} given twice")
        options[key] = value.strip()
    return options


def progress_wanted(*, quiet: bool, json_output: bool, stderr_tty: bool,
                    stdout_tty: bool) -> bool:
    """Return True when ``aeroid estimate`` should draw a progress bar.

    Only on a terminal (a bar in a log file is noise), never with ``--quiet``, and not
    when ``--json`` goes to a pipe or file (a script is reading; it wants no chatter).
    """
    return not quiet and stderr_tty and not (json_output and not stdout_tty)


class ProgressBar:
    """A progress listener that draws one tqdm bar per stage on stderr.

    Parameters
    ----------
    label : str
        Prefix of the bar (the method's name).
    """

    def __init__(self, label: str) -> None:
        self.label = label
        self._bar: Any = None
        self._key: tuple[str, int] | None = None

    def __call__(self, event: ProgressEvent) -> None:
        """Show ``event`` (a new stage or total starts a new bar)."""
        from tqdm import tqdm

        key = (event.stage, event.total)
        if key != self._key:
            self.close()
            self._key = key
            self._bar = tqdm(total=event.total, desc=f"{self.label} {event.stage}".strip(),
                             unit="it", file=sys.stderr, leave=False, dynamic_ncols=True)
        if math.isfinite(event.cost):
            self._bar.set_postfix_str(f"best cost {event.cost:.4g}", refresh=False)
        self._bar.update(event.done - self._bar.n)

    def close(self) -> None:
        """Remove the current bar, if any."""
        if self._bar is not None:
            self._bar.close()
        self._bar, self._key = None, None


def method_names(spec: str) -> list[str]:
    """Return the methods of ``--method``: one name, ``a,b,c``, or ``all`` (every installed).

    Raises
    ------
    EstimatorError
        For an empty or repeated name, or one that is not installed (one line listing the
        available ones).
    """
    if spec.strip() == "all":
        return sorted(available(refresh=True))
    names = [n.strip() for n in spec.split(",")]
    if not all(names):
        raise EstimatorError(f"--method {spec!r}: an empty method name (give NAME, A,B or all)")
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise EstimatorError(f"--method {spec!r}: {', '.join(repeated)} given twice")
    for name in names:
        get_estimator(name)  # EstimatorError naming the available methods
    return names


def split_options(methods: list[str], options: dict[str, str]) -> dict[str, dict[str, str]]:
    """Return each method's share of ``options`` (those it takes).

    Raises
    ------
    EstimatorError
        For an option no method of ``methods`` takes (one line naming the methods).
    """
    shares: dict[str, dict[str, str]] = {}
    for name in methods:
        allowed = get_estimator(name).option_names()
        shares[name] = {k: v for k, v in options.items() if k in allowed}
    unused = sorted(k for k in options if not any(k in share for share in shares.values()))
    if unused:
        raise EstimatorError(f"option(s) {', '.join(unused)} taken by none of "
                             f"{', '.join(methods)} (see 'aeroid methods --options NAME')")
    return shares


def _read(args: argparse.Namespace, path: Any = None) -> Any:
    airframe = load_airframe(args.airframe) if getattr(args, "airframe", None) else None
    columns = read_column_map(args.columns) if getattr(args, "columns", None) else None
    flight = read_flight(args.flight if path is None else path, airframe=airframe,
                         columns=columns, degrees=bool(getattr(args, "degrees", False)))
    from aeroid.cli._thrust import with_thrust  # --thrust-curve, or the airframe's curve

    return with_thrust(with_mass_sd(flight, getattr(args, "mass_sd", None)), args)


def holds_from_args(args: argparse.Namespace) -> CoefficientSpec:
    """Return the ``--hold NAME=VALUE`` and ``--prior NAME=MEAN:SD`` of the command line.

    Raises
    ------
    EstimatorError
        One line for a malformed item, an unknown name, an sd <= 0, or a coefficient
        both held and given a prior.
    """
    return CoefficientSpec.parse(getattr(args, "hold", None) or (),
                                 getattr(args, "prior", None) or ())


def with_mass_sd(flight: Any, mass_sd: float | None) -> Any:
    """Return ``flight`` with its airframe's ``mass_sd_kg`` set to ``--mass-sd`` (None: as is).

    The replacement is said in one line (logger ``aeroid``, INFO).

    Raises
    ------
    AirframeError
        ``--mass-sd: ...`` for a value that is not in [0, mass_kg).
    """
    if mass_sd is None:
        return flight
    try:
        airframe = flight.airframe.replace(mass_sd_kg=mass_sd)
    except AirframeError as exc:
        raise AirframeError(f"--mass-sd: {exc}") from None
    old = flight.airframe.mass_sd_kg
    logging.getLogger("aeroid").info(
        f"--mass-sd: mass {airframe.mass_kg:g} +- {mass_sd:g} kg"
        + (f" (the airframe's mass_sd_kg {old:g} replaced)" if old else ""))
    return dataclasses.replace(flight, airframe=airframe)


def _fit(estimator: Any, flight: Any, args: argparse.Namespace, label: str) -> Any:
    bar = None
    if progress_wanted(quiet=bool(getattr(args, "quiet", False)
                                  or getattr(args, "no_progress", False)),
                       json_output=bool(getattr(args, "json", False)),
                       stderr_tty=sys.stderr.isatty(), stdout_tty=sys.stdout.isatty()):
        bar = ProgressBar(label)
    try:
        return estimator.fit(flight, rng=getattr(args, "seed", None), progress=bar,
                             holds=holds_from_args(args))
    finally:
        if bar is not None:
            bar.close()


#: Said after the fits when the airframe has no ``[prior]``.
NO_PRIOR = ("the airframe has no [prior]: the reference missile's coefficients were the "
            "start of every method (and the centre of the PSO box); give [prior] in the "
            "airframe file")


def _report_notes(flight: Any) -> list[str]:
    """What reading the log did, the flight's validation warnings and a missing prior."""
    notes = [f"reading: {n}" for n in flight.notes]
    notes += [f"flight: {w}" for w in flight.check()[1]]
    return notes + ([NO_PRIOR] if flight.airframe.prior is None else [])


def estimate(args: argparse.Namespace) -> int:
    """Run ``aeroid estimate``: read, fit (which validates), print a table or JSON.

    With several methods (``--method a,b`` or ``all``), each is fitted in turn and one
    side-by-side table is printed; each ``--option`` goes to the methods that take it.
    With ``--report DIR``, ``DIR/report.md`` and its figures (one method) or one folder
    per method and ``DIR/comparison.md`` (several).

    Returns 0, or 1 when a method failed (``success=False``: the result, with its
    message, is still printed), so scripts can tell.
    """
    options = parse_options(getattr(args, "option", None))
    holds_from_args(args)  # a bad --hold or --prior is said before the log is read
    from aeroid.cli._axial import estimate_log, is_suite_log

    if is_suite_log(args):  # a flight computer's suite log, fitted as it is (axial-drag)
        return estimate_log(args, options, with_mass_sd)
    single = "," not in args.method and args.method.strip() != "all"
    names = [args.method.strip()] if single else method_names(args.method)
    if single:
        estimators = {names[0]: make_estimator(names[0], options)}
        shares = {names[0]: options}
    else:
        shares = split_options(names, options)
        estimators = {n: make_estimator(n, shares[n]) for n in names}
    curve = reference_from_args(args)  # a bad curve file or area: before the log
    # a Flight, or Windows (several files, --windows)
    flight = read_windows(args, _read, estimators.values())
    several = hasattr(flight, "names")
    check_reference(curve, flight)  # the conversion said, a missing overlap warned
    drag = {} if curve is None else {"reference": curve}
    report = getattr(args, "report", None)
    fmt = getattr(args, "report_format", "md")
    if report is None and fmt != "md":
        raise UsageError("--report-format is the format of --report DIR: give --report")
    if report is not None:  # before the fits: an unwritable folder is said at once
        from aeroid.report import make_directory

        make_directory(report)
    results = {name: _fit(est, flight, args, name) for name, est in estimators.items()}
    if flight.airframe.prior is None:
        logging.getLogger("aeroid").info(NO_PRIOR)
    json_output = bool(getattr(args, "json", False))
    if single:
        result = results[names[0]]
        if report is not None:
            from aeroid.report import write_report, write_windows_report

            writer = write_windows_report if several else write_report
            path = writer(result, flight, report,
                          notes=window_notes(flight, _report_notes, NO_PRIOR), fmt=fmt, **drag)
            print(f"aeroid: wrote {path}", file=sys.stderr)
        if json_output:
            out = result.to_json_dict()
            if several:
                out["windows"] = windows_json(flight, result)
            print(json.dumps(out, indent=2, allow_nan=False))
        else:
            print(result.summary(flight.true_coefficients))
            if several:
                print(window_table(result))
        return 0 if result.success else 1
    from aeroid.report import (
        compare_results,
        comparison_markdown,
        comparison_text,
        options_note,
        result_notes,
    )

    notes = options_note(list(options), shares) + result_notes(results)
    table = compare_results(results, shares, flight.true_coefficients)
    if report is not None:
        from aeroid.report import (
            html_page,
            report_name,
            write_report,
            write_text_atomic,
            write_windows_report,
        )

        links = {}
        reading = window_notes(flight, _report_notes, NO_PRIOR)
        for name, result in results.items():
            writer = write_windows_report if several else write_report
            writer(result, flight, report / name, notes=reading, fmt=fmt, **drag)
            links[name] = f"{name}/{report_name('report', fmt)}"
        text = comparison_markdown(table, notes, links)
        if fmt == "html":
            text = html_page(text, "Methods side by side")
        path = write_text_atomic(report / report_name("comparison", fmt), text)
        print(f"aeroid: wrote {path} and one report per method", file=sys.stderr)
    if json_output:
        methods_json = [r.to_json_dict() for r in results.values()]
        if several:
            for entry, r in zip(methods_json, results.values(), strict=True):
                entry["windows"] = windows_json(flight, r)
        print(json.dumps({"methods": methods_json, "options_applied": shares}, indent=2,
                         allow_nan=False))
    else:
        print(comparison_text(table, notes))
        if several:
            for name, r in results.items():
                print(f"{name}: " + window_table(r))
    return 0 if all(r.success for r in results.values()) else 1


def methods_table(indent: str = "") -> str:
    """Return one line per installed method: its name and description."""
    classes = available(refresh=True)
    width = max((len(n) for n in classes), default=0)
    lines = []
    for name in sorted(classes):
        cls = classes[name]
        text = cls.description or (cls.__doc__ or "").strip().split("\n")[0]
        lines += textwrap.wrap(text, TEXT_WIDTH, initial_indent=f"{indent}{name:<{width}}  ",
                               subsequent_indent=" " * (len(indent) + width + 2),
                               break_on_hyphens=False) or [name]
    return "\n".join(lines)


def _value_text(value: Any) -> str:
    """Return an option value as it would be typed: TOML-like (true, [1, 2], none)."""
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_value_text(v) for v in value) + "]"
    return str(value)


def option_text(name: str) -> str:
    """Return a method's options for people: ``name : type = default`` and a description.

    Raises
    ------
    EstimatorError
        For an unknown method (one line listing the available ones).
    """
    cls = get_estimator(name)
    infos = cls.describe_options()
    lines = [f"{name}: {cls.description}".rstrip(": ")]
    if not infos:
        lines.append("no options")
        return "\n".join(lines)
    lines.append("options (aeroid estimate ... --option KEY=VALUE; lists as [1, 2]):")
    for info in infos:
        lines.append(f"  {info.name} : {info.type} = {_value_text(info.default)}")
        text = info.description or "(undocumented)"
        lines += textwrap.wrap(text, TEXT_WIDTH, initial_indent=" " * 6,
                               subsequent_indent=" " * 6)
    return "\n".join(lines)


def methods(args: argparse.Namespace) -> int:
    """Run ``aeroid methods``: list every estimator (or one method's options) and any
    plug-in that failed to load."""
    if getattr(args, "options", None):
        print(option_text(args.options))
        return 0
    print(methods_table())
    print("\nA method's options: aeroid methods --options NAME")
    errors = load_errors()
    if errors:
        print("\nplug-ins that failed to load:")
        for name in sorted(errors):
            print(f"  {name}: {errors[name]}")
    return 0
