"""Several windows or flights in one fit on the command line (``aeroid estimate``).

``aeroid estimate a.csv b.csv ...`` fits the files together (each with its own sidecar),
``aeroid estimate log.csv --windows 5-6,8-9`` those time ranges of one log: the
coefficients shared, each window with its own start, inputs, delay and IMU errors
(:class:`aeroid.flights.Windows`). The text output adds a table of each window's own
parameters, the JSON one entry per window (:func:`windows_json`).
"""

from __future__ import annotations

import argparse
import logging
import math
from collections.abc import Callable, Iterable
from typing import Any

from aeroid.errors import EstimatorError, UsageError

__all__ = ["read_windows", "window_notes", "window_table", "windows_json"]


def read_windows(args: argparse.Namespace, read: Callable[[argparse.Namespace, Any], Any],
                 estimators: Iterable[Any] = ()) -> Any:
    """Return the flight of ``args.flight``, or a :class:`aeroid.flights.Windows`.

    ``read(args, path)`` reads one file as ``aeroid estimate`` does. Several files: one
    window each (named by the file's stem, or its path when two stems
    are the same), each read with its own sidecar and the same ``--airframe`` /
    ``--columns``. ``--windows START-END,...`` on one file: those time ranges of it
    (:func:`aeroid.flights.cut_windows`). What was done is said in one line (logger
    ``aeroid``, INFO).

    Raises
    ------
    UsageError
        ``--windows`` with several files.
    EstimatorError
        Several windows for a method of ``estimators`` that cannot fit them (before any
        file is read).
    FlightError
        A bad window spec, a range outside the log, overlapping ranges.
    """
    from aeroid.flights import Windows, cut_windows

    paths = list(args.flight) if isinstance(args.flight, list | tuple) else [args.flight]
    spec = getattr(args, "windows", None)
    if spec is not None and len(paths) > 1:
        raise UsageError("--windows cuts time ranges out of one log; give one file with "
                         "--windows, or several files without it")
    if len(paths) == 1 and spec is None:
        return read(args, paths[0])
    unable = [e.name for e in estimators if not getattr(e, "supports_windows", False)]
    if unable:
        raise EstimatorError(f"{', '.join(unable)}: fit(s) one flight at a time; cannot fit "
                             "several windows (methods that can: output-error, ekf, ukf, "
                             "equation-error)")
    if len(paths) == 1:
        windows = cut_windows(read(args, paths[0]), str(spec))
        what = f"{len(windows)} windows of {paths[0]} ({spec} s)"
    else:
        stems = [p.stem for p in paths]
        names = stems if len(set(stems)) == len(stems) else [str(p) for p in paths]
        windows = Windows(tuple(read(args, p) for p in paths), tuple(names))
        what = f"{len(windows)} flights ({', '.join(names)})"
    logging.getLogger("aeroid").info(f"fitting {what} together: the coefficients shared, "
                                     "each window its own start, inputs, delay and biases")
    return windows


def window_notes(data: Any, notes_of: Callable[[Any], list[str]], no_prior: str
                 ) -> list[str]:
    """``notes_of`` (a flight's report notes) of every window, each line naming its window;
    the missing-prior note ``no_prior`` once."""
    if not hasattr(data, "names"):
        return notes_of(data)
    notes = [f"window {name}: {n}" for name, f in data.items()
             for n in notes_of(f) if n != no_prior]
    return notes + ([no_prior] if data.airframe.prior is None else [])


def window_table(result: Any) -> str:
    """The per-window parameters of a fit of several windows, one line each ('' if none)."""
    values = result.info.get("window_parameters")
    if not isinstance(values, dict):
        return ""
    stderr = result.info.get("window_parameter_stderr") or {}
    lines = ["per-window parameters (estimate +- std err):"]
    for name, params in values.items():
        shown = [f"{k} = {v:.6g} +- {stderr.get(name, {}).get(k, math.nan):.3g}"
                 for k, v in params.items() if isinstance(v, float | int)]
        lines.append(f"  {name}: " + ("; ".join(shown) if shown else "none estimated"))
    return "\n".join(lines)


def windows_json(data: Any, result: Any) -> list[dict[str, Any]]:
    """One entry per window: name, source, samples, time range, parameters and std errors."""
    values = result.info.get("window_parameters") or {}
    stderr = result.info.get("window_parameter_stderr") or {}

    def clean(v: Any) -> Any:
        if isinstance(v, list):
            return [clean(x) for x in v]
        return None if isinstance(v, float) and not math.isfinite(v) else v

    return [{"name": name, "source": f.metadata.get("source"), "samples": f.n_samples,
             "t_s": [float(f.t[0]), float(f.t[-1])],
             "parameters": {k: clean(v) for k, v in values.get(name, {}).items()},
             "stderr": {k: clean(v) for k, v in stderr.get(name, {}).items()}}
            for name, f in data.items()]
