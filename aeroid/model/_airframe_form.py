"""The airframe file's tables: their keys, and reading them into an airframe's fields.

File format (TOML; the ``[airframe]``, ``[atmosphere]`` and ``[prior]`` tables of the
reference scenario file ``aeroid/data/reference-scenario.toml``)::

    [airframe]
    diameter_m = 0.127                      # reference diameter D; S = pi D^2 / 4
    length_m = 2.79                         # optional, informative (used in no equation)
    mass_kg = 70.0
    mass_sd_kg = 2.0                        # optional sd of mass_kg (also Ix_sd_kgm2, ...):
                                            # a consider parameter (aeroid.estimation)
    Ix_kgm2 = 0.18
    Iy_kgm2 = 40.0
    Iz_kgm2 = 40.0
    thrust_N = 740.0                        # along body +x, >= 0
    delta_max_deg = 8.0                     # ON-OFF fin deflection, > 0
    # fin = "passive"                       # optional: no moving fin (then no
                                            #   delta_max_deg); default "relay"
    accel1_position_m = [0.6, 0.0, 0.0]     # triad positions from the c.g., body axes
    accel2_position_m = [-0.6, 0.01, 0.01]

    [atmosphere]                            # required: exactly one of
    altitude_m = 10000.0                    #   ISA density at this altitude, or
    # density_kgm3 = 0.4127                 #   this density, or
    # per_sample = "rho"                    #   a flight channel: "rho", "altitude" or "qbar"

    [prior]                                 # optional: the nine coefficients to start from
    Cx = -0.98                              # (all nine names; default: the nominal values)

    [hold]                                  # optional: coefficients every fit holds
    Czd = 0.0
    [prior_sd]                              # optional: a Gaussian prior N([prior], sd^2)
    Cmq = 300.0

    [fin_law]                               # optional: the relay law (aeroid.model.FinLaw)
    command_amplitude = 0.5                 # A, or [[t_s, A], ...] (piecewise linear)
    command_phase_deg = 60.0                # phi0, or [[t_s, deg], ...]
    delay_s = 0.0                           # optional actuator delay
    rate_limit_dps = 8000.0                 # optional fin rate limit (default none)
    evaluation = "continuous"               # optional: or "latched" (at the log's samples),
                                            # or control_rate_Hz = f (a clock of its own)

    [tables]                                # optional: coefficients as tables in Mach
    Cx = [1.1, 1.4, 1.7, 2.0, 2.2]          # knots [Mach] (aeroid.model.TableSpec), or a
    Cmq = 3                                 # count chosen from the flight's Mach range
    temperature_K = 255.7                   # optional: else ISA at [atmosphere] altitude_m

    [thrust_curve]                          # optional: the motor (aeroid.model.ThrustCurve)
    file = "motor.csv"                      # time_s, thrust_N[, mass_kg] on its own clock
    origin_s = 1.2                          # the log-clock time of the curve's t = 0
    burn_s = [1.2, 4.7]                     # log clock: the thrust is used only here

:meth:`aeroid.model.Airframe.from_dict` builds the airframe from what
:func:`airframe_fields` reads here; the checks of the values themselves (ranges, the
one atmosphere) are the airframe's own.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from aeroid.errors import AirframeError
from aeroid.model._coefficients import NAMES
from aeroid.model._fileform import check_keys, check_table, number, numbers, text
from aeroid.model._tables import TableSpec
from aeroid.model._thrust import ThrustCurve

#: File key -> attribute of ``[airframe]``.
AIRFRAME_KEYS = {
    "diameter_m": "diameter_m",
    "length_m": "length_m",
    "mass_kg": "mass_kg",
    "Ix_kgm2": "ix_kgm2",
    "Iy_kgm2": "iy_kgm2",
    "Iz_kgm2": "iz_kgm2",
    "thrust_N": "thrust_n",
    "delta_max_deg": "delta_max_deg",
    "accel1_position_m": "accel1_position_m",
    "accel2_position_m": "accel2_position_m",
    "accel1_position_sd_m": "accel1_position_sd_m",
    "accel2_position_sd_m": "accel2_position_sd_m",
    "fin": "fin",
    "mass_sd_kg": "mass_sd_kg",
    "Ix_sd_kgm2": "ix_sd_kgm2",
    "Iy_sd_kgm2": "iy_sd_kgm2",
    "Iz_sd_kgm2": "iz_sd_kgm2",
}
#: File key of each mass constant's standard deviation (optional, default 0: exact).
MASS_SD_KEYS = {"mass_kg": "mass_sd_kg", "Ix_kgm2": "Ix_sd_kgm2", "Iy_kgm2": "Iy_sd_kgm2",
                "Iz_kgm2": "Iz_sd_kgm2"}
#: ``length_m`` appears in no equation, so it may be left out; the positions' and the
#: mass constants' standard deviations default to 0 (known positions, exact mass);
#: ``fin`` to ``"relay"``, whose ``delta_max_deg`` the airframe itself requires (a
#: passive fin has none).
OPTIONAL_AIRFRAME_KEYS = ("length_m", "accel1_position_sd_m", "accel2_position_sd_m", "fin",
                          "delta_max_deg", *MASS_SD_KEYS.values())
#: File key -> attribute of ``[atmosphere]`` (exactly one is given).
ATMOSPHERE_KEYS = {"altitude_m": "altitude_m", "density_kgm3": "given_density_kgm3",
                   "per_sample": "atmosphere_channel"}
#: Flight channels a per-sample atmosphere may name (:func:`aeroid.flights.exogenous`).
ATMOSPHERE_CHANNELS = ("rho", "altitude", "qbar")
#: Physical ranges [unit of the key], each with its reason; outside: AirframeError.
LIMITS: dict[str, tuple[float, float]] = {
    # 1 mm (a dart) to 10 m (a launch vehicle); a diameter in mm or cm lands outside.
    "diameter_m": (1e-3, 10.0),
    # 100 m exceeds any airframe; a length in mm lands outside.
    "length_m": (1e-3, 100.0),
    # Dead Sea shore to 20 km: the ISA model here holds its 216.65 K layer above 11 km
    # and is wrong above 20 km (give density_kgm3 for a flight higher up).
    "altitude_m": (-500.0, 20_000.0),
    # the air at 65 km to the densest surface air (1.42 kg/m^3 at -40 C) with margin.
    "density_kgm3": (1e-4, 1.5),
    # a fin throw is positive; beyond 45 deg a fin stalls and the linear Czd/Cmd mean nothing.
    "delta_max_deg": (0.0, 45.0),
}
#: A fin throw below this [deg] is accepted with a warning: 0.14 "deg" is 8 deg in radians.
DELTA_MAX_WARN_DEG = 1.0
#: Closest accelerometer triads [m]. At R1 == R2 the two triads measure the same point
#: and the angular acceleration of eq. 29 is rank-deficient; closer than 1 mm their
#: difference is far below any accelerometer's noise.
MIN_SENSOR_SEPARATION_M = 1e-3
#: The tables of an airframe file.
AIRFRAME_TABLES = ("airframe", "atmosphere", "prior", "fin_law", "hold", "prior_sd",
                   "tables", "thrust_curve")
#: The fin of an airframe (its field ``fin``): the moving ON-OFF fin, or none.
FIN_KINDS: tuple[str, ...] = ("relay", "passive")
#: The tables a scenario file adds (read by ``aeroid.flights.scenario_from_dict``).
SCENARIO_TABLES = ("actuator", "initial_state", "recording", "coefficients", "noise",
                   "wind", "air")


def airframe_fields(data: Mapping[str, Any], *, source: str = "airframe",
                    other_tables: tuple[str, ...] = ()) -> tuple[dict[str, Any], Any]:
    """Read an airframe file's tables into the airframe's field values.

    Parameters
    ----------
    data : mapping
        The parsed file.
    source : str
        The file (or other origin) named in error messages.
    other_tables : tuple of str
        Further tables the caller reads itself (a scenario file's); any other table is
        an error.

    Returns
    -------
    fields : dict
        Keyword arguments of :class:`aeroid.model.Airframe` (without ``fin_law``).
    fin_law : mapping or None
        The ``[fin_law]`` table as written (read by ``FinLaw.from_table``, which needs the
        airframe's fin throw), or None when the file has none.

    Raises
    ------
    AirframeError
        One line naming ``source`` and the missing, unknown or invalid table or key.
    """
    data = check_table(data, source)
    known = (*AIRFRAME_TABLES, *other_tables)
    unknown = sorted(str(t) for t in data if t not in known)
    if unknown:
        hint = ("; a scenario file? an airframe file has only [airframe], [atmosphere], "
                "[prior], [fin_law], [hold], [prior_sd], [tables] and [thrust_curve] (starting "
                "values go in "
                "[prior])"
                if set(unknown) & set(SCENARIO_TABLES) else "")
        raise AirframeError(f"{source}: unknown table(s) {', '.join(unknown)} "
                            f"(allowed: {', '.join(known)}){hint}")
    for name in (t for t in AIRFRAME_TABLES if t in data):  # `airframe = 5` is no table
        check_table(data[name], f"{source}: [{name}]")
    for name in ("airframe", "atmosphere"):
        if name not in data:
            what = ("exactly one of altitude_m, density_kgm3 or per_sample; aeroid "
                    "assumes no sea level" if name == "atmosphere" else "the airframe")
            raise AirframeError(f"{source}: no [{name}] table ({what})")
    table = check_table(data["airframe"], f"{source}: [airframe]")
    required = [k for k in AIRFRAME_KEYS if k not in OPTIONAL_AIRFRAME_KEYS]
    check_keys(table, AIRFRAME_KEYS, f"{source}: [airframe]", required)
    kwargs: dict[str, Any] = {}
    for key, attr in AIRFRAME_KEYS.items():
        if key not in table:
            continue
        where = f"{source}: [airframe] {key}"
        kwargs[attr] = (numbers(table[key], 3, where) if key.startswith("accel")
                        else text(table[key], where) if key == "fin"
                        else number(table[key], where))
    atmos = check_table(data["atmosphere"], f"{source}: [atmosphere]")
    check_keys(atmos, ATMOSPHERE_KEYS, f"{source}: [atmosphere]")
    for key, attr in ATMOSPHERE_KEYS.items():
        if key in atmos:
            where = f"{source}: [atmosphere] {key}"
            kwargs[attr] = (text(atmos[key], where) if key == "per_sample"
                            else number(atmos[key], where))
    if "prior" in data:
        prior = check_table(data["prior"], f"{source}: [prior]")
        check_keys(prior, NAMES, f"{source}: [prior]", required=NAMES)
        kwargs["prior"] = tuple(number(prior[n], f"{source}: [prior] {n}") for n in NAMES)
    for name in ("hold", "prior_sd"):  # some coefficients: held, or a prior's sd
        if name in data:
            table = check_table(data[name], f"{source}: [{name}]")
            check_keys(table, NAMES, f"{source}: [{name}]")
            kwargs[name] = tuple((n, number(table[n], f"{source}: [{name}] {n}"))
                                 for n in NAMES if n in table)
    if "tables" in data:
        kwargs["tables"] = TableSpec.from_table(data["tables"], f"{source}: [tables]")
    if "thrust_curve" in data:  # a file named there: relative to the airframe file's folder
        kwargs["thrust_curve"] = ThrustCurve.from_table(
            data["thrust_curve"], f"{source}: [thrust_curve]", Path(source).parent)
    return kwargs, data.get("fin_law")


def prior_tuple(prior: Any) -> tuple[float, ...]:
    """Return a prior (mapping of the names :data:`NAMES`, or one value per name) as floats."""
    if isinstance(prior, Mapping):
        check_keys(prior, NAMES, "airframe prior", required=NAMES)
        prior = [prior[n] for n in NAMES]
    try:
        return numbers(prior, len(NAMES), "airframe prior")
    except AirframeError:
        raise AirframeError(f"airframe prior: expected {len(NAMES)} finite values, got {prior!r}"
                            ) from None


__all__ = ["AIRFRAME_KEYS", "AIRFRAME_TABLES", "FIN_KINDS", "check_fin", "check_holds",
           "coefficient_pairs", "ATMOSPHERE_CHANNELS", "ATMOSPHERE_KEYS",
           "OPTIONAL_AIRFRAME_KEYS", "SCENARIO_TABLES", "airframe_fields", "prior_tuple",
           "DELTA_MAX_WARN_DEG", "LIMITS", "MIN_SENSOR_SEPARATION_M", "MASS_SD_KEYS"]


def check_fin(fin: Any, delta_max_deg: Any, fin_law: Any) -> None:
    """Raise AirframeError (one line) unless the fin declaration is consistent.

    ``relay`` needs ``delta_max_deg``; ``passive`` has neither ``delta_max_deg`` nor a
    fin law.
    """
    if fin not in FIN_KINDS:
        raise AirframeError(f"airframe: fin must be one of {', '.join(FIN_KINDS)}, got {fin!r}")
    if fin == "relay" and delta_max_deg is None:
        raise AirframeError("airframe: delta_max_deg is required for a moving fin (or "
                            'declare fin = "passive": no moving fin)')
    if fin == "passive" and (delta_max_deg is not None or fin_law is not None):
        what = "delta_max_deg" if delta_max_deg is not None else "[fin_law]"
        raise AirframeError(f'airframe: fin = "passive" has no moving fin, so no {what}; '
                            "remove it")


def coefficient_pairs(value: Any, name: str) -> tuple[tuple[str, float], ...]:
    """Return ``[hold]`` or ``[prior_sd]`` (a mapping or pairs) as (name, float) pairs in
    :data:`NAMES` order; one-line AirframeError for an unknown name or a bad number."""
    pairs = dict(value.items() if isinstance(value, Mapping) else value or ())
    check_keys(pairs, NAMES, f"airframe: [{name}]")
    return tuple((n, number(pairs[n], f"airframe: [{name}] {n}")) for n in NAMES if n in pairs)


def check_holds(hold: tuple[tuple[str, float], ...], prior_sd: tuple[tuple[str, float], ...],
                prior: Any) -> None:
    """Raise AirframeError (one line): an sd <= 0, a coefficient both held and given a
    prior, or ``[prior_sd]`` without ``[prior]`` (its mean: no default is assumed)."""
    bad = [n for n, sd in prior_sd if not sd > 0]
    if bad:
        raise AirframeError(f"airframe: [prior_sd] {bad[0]} must be > 0 (hold it in [hold] "
                            "instead)")
    both = sorted(set(dict(hold)) & set(dict(prior_sd)))
    if both:
        raise AirframeError(f"airframe: {', '.join(both)} both in [hold] and [prior_sd] "
                            "(choose one)")
    if prior_sd and prior is None:
        raise AirframeError("airframe: [prior_sd] needs [prior]: the priors' means")
