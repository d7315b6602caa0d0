"""Whether the log says still air: the rule behind ``estimate_wind = "auto"`` (issue 26).

A log says still air when

1. its metadata declares it (``metadata["wind"]``: ``"still"``, or a ``[wind]`` table
   with no steady component and no turbulence: :func:`aeroid.flights.declared_wind`;
   the simulators write the air they flew, still air included). The declaration stands
   against the air data: where they disagree (the air-data verdict,
   :func:`aeroid.estimation.air_data_verdict`, says "steady wind" or "turbulence") the
   reason says so, but from the log alone a probe's calibration looks the same (measured:
   10 of 10 still-air flights with ``benchmarks/bench_air_data_outputs.py``'s probe,
   factor +2 %, offsets 2 and -1 mrad, were called "turbulence"); a wrong declaration is
   the fit check's to catch (the still-air model in a 5 m/s wind: refused 50/50); or
2. it declares nothing, and its air data see all three components and the verdict calls
   them still air (a steady wind within 3 standard errors of zero, gusts below the probe
   noise's limit).

The verdict is read only where it sees all three components (:data:`ALL_COMPONENTS`:
``alpha``, ``beta`` and ``airspeed`` logged): the angles alone do not see the wind along
the path, the component that scales the dynamic pressure and with it every coefficient,
and its standard error there is not the wind's (measured, ``benchmarks/bench_wind_auto.py``:
2 of 50 still-air logs with 0.1 deg vanes and no airspeed called "steady wind" on that
component, 0.005 m/s at 3.2-3.5 se; 0 of 50 with the airspeed). Anything else is not
still air: a declared wind (steady or turbulent), the verdict's "steady wind" or
"turbulence" on a log that declares nothing, and a log that says nothing (no
declaration, and no airspeed beside its angles). Several windows are still air only when
every window is.
"""

from __future__ import annotations

from dataclasses import dataclass

from aeroid.estimation._air_data import has_air_data
from aeroid.estimation._air_verdict import air_data_verdict
from aeroid.flights import Flight, Windows, declared_wind, describe_wind, is_still

#: The channels the verdict needs to see every wind component.
ALL_COMPONENTS = ("alpha", "beta", "airspeed")


@dataclass(frozen=True)
class LogAir:
    """What a log says about its air.

    Attributes
    ----------
    still : bool
        The log says still air (module docstring).
    reason : str
        Why, in words (``"its metadata declares still air"``, ``"the log does not say
        the air was still"``, ...).
    declared : str or None
        The declared air in words, or None when the log declares nothing.
    verdict : str or None
        The air-data verdict's kind (``"still air"``, ``"steady wind"``,
        ``"turbulence"``), or None without air data.
    """

    still: bool
    reason: str
    declared: str | None = None
    verdict: str | None = None

    def as_info(self) -> dict[str, object]:
        """As ``info["estimate_wind"]``'s ``log_air``."""
        return {"still": self.still, "reason": self.reason, "declared": self.declared,
                "verdict": self.verdict}


def log_air(flight: Flight | Windows, owner: str = "") -> LogAir:
    """Return what ``flight`` (or every window of ``windows``) says about its air.

    Raises
    ------
    FlightError
        One line: a malformed ``metadata["wind"]``.
    """
    if isinstance(flight, Windows):
        said = {name: log_air(part, owner) for name, part in flight.items()}
        moving = {name: a for name, a in said.items() if not a.still}
        if not moving:
            return LogAir(True, f"every window says still air ({next(iter(said.values())).reason})")
        name, first = next(iter(moving.items()))
        return LogAir(False, f"window {name!r}: {first.reason}", first.declared, first.verdict)
    where = str(flight.metadata.get("source", "flight"))
    wind = declared_wind(flight.metadata, where)
    seen = all(c in flight.channels for c in ALL_COMPONENTS)
    verdict = air_data_verdict(flight, owner or "log") if seen and has_air_data(flight) \
        else None
    kind = None if verdict is None else verdict.kind
    steady = "" if verdict is None else ", ".join(
        f"{a} {w:+.2f}" for a, w in zip("NED", verdict.steady_ned_mps, strict=True))
    if wind is not None:
        declared = describe_wind(wind)
        if not is_still(wind):
            return LogAir(False, f"its metadata declares {declared}", declared, kind)
        if kind is not None and kind != "still air":
            return LogAir(True, f"its metadata declares still air (its air data say {kind}, "
                          f"steady part {steady} m/s: the declaration taken, a probe's "
                          "calibration looks the same)", declared, kind)
        return LogAir(True, "its metadata declares still air", declared, kind)
    if kind == "still air":
        return LogAir(True, "its air data (alpha, beta, airspeed) say still air", None, kind)
    if kind is not None:
        return LogAir(False, f"the log does not declare its air and its air data say {kind}",
                      None, kind)
    missing = ("no metadata wind, no air data" if not has_air_data(flight) else
               "no metadata wind; its air data lack an airspeed, so the wind along the path "
               "is unseen")
    return LogAir(False, f"the log does not say the air was still ({missing})")


__all__ = ["ALL_COMPONENTS", "LogAir", "log_air"]
