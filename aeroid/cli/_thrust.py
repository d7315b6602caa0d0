"""``aeroid estimate --thrust-curve CSV --thrust-origin S --burn START:END`` (issue 25).

The three flags go together (a curve without its origin or burn window would assume
one): the curve file (``time_s, thrust_N[, mass_kg]`` on the motor's clock), the log-clock
time of its t = 0, and the log-clock window where the motor burns. The curve then
replaces the airframe's ``[thrust_curve]`` if it has one (said); an airframe (or sidecar)
curve without the flags is used the same way. Either is made into the flight's ``thrust``
(and ``mass``) channels by :func:`aeroid.flights.with_thrust_curve`, which says in one
line what was used and refuses a burn without the mass along it.
"""

from __future__ import annotations

import argparse
import logging
import math
from typing import Any

from aeroid.errors import UsageError
from aeroid.flights import with_thrust_curve
from aeroid.model import ThrustCurve, read_thrust_curve

FLAGS = ("--thrust-curve", "--thrust-origin", "--burn")


def parse_burn(text: str) -> tuple[float, float]:
    """Return ``START:END`` [s] as two floats (one-line UsageError otherwise)."""
    parts = str(text).split(":")
    try:
        start, end = (float(p) for p in parts)
    except ValueError:
        raise UsageError(f"--burn: expected START:END in seconds on the log's clock, got "
                         f"{text!r}") from None
    if not (math.isfinite(start) and math.isfinite(end) and start < end):
        raise UsageError(f"--burn: expected START < END, finite [s], got {text!r}")
    return start, end


def curve_from_args(args: argparse.Namespace) -> ThrustCurve | None:
    """Return the command line's thrust curve, or None without the flags."""
    given = [getattr(args, "thrust_curve", None), getattr(args, "thrust_origin", None),
             getattr(args, "burn", None)]
    if all(v is None for v in given):
        return None
    missing = [f for f, v in zip(FLAGS, given, strict=True) if v is None]
    path, origin, burn = given
    if missing or path is None or origin is None or burn is None:
        raise UsageError(f"{', '.join(FLAGS)} go together (missing {', '.join(missing)}): "
                         "aeroid assumes no time origin or burn window")
    return read_thrust_curve(path, origin_s=float(origin), burn_s=parse_burn(burn))


def with_thrust(flight: Any, args: argparse.Namespace) -> Any:
    """Return ``flight`` with the thrust curve's channels (module docstring), said in one line."""
    curve = curve_from_args(args)
    own = getattr(flight.airframe, "thrust_curve", None)
    if curve is None and own is None:
        return flight
    if curve is None and own is not None and "thrust" in flight.channels:  # a flight written
        # with its curve's channels (aeroid simulate, Flight.write after with_thrust_curve)
        logging.getLogger("aeroid").info(f"thrust: the flight's 'thrust' channel (from the "
                                         f"airframe's [thrust_curve]: {own.describe()})")
        return flight
    flight, note = with_thrust_curve(flight, curve)
    if curve is not None and own is not None:
        note += " (the airframe's [thrust_curve] replaced by --thrust-curve)"
    logging.getLogger("aeroid").info(note)
    return flight


__all__ = ["curve_from_args", "parse_burn", "with_thrust"]
