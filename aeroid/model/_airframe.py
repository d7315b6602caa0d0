"""The airframe: geometry, mass, inertia, thrust, fin throw, sensor positions, atmosphere, prior.

The file's tables and their keys are read by :mod:`aeroid.model._airframe_form`
(its docstring shows the file).

There is no default atmosphere: leaving it out used to mean sea level, which made every
coefficient of a flight at altitude 25-66 % low. ``per_sample`` names the flight channel
of a density that changes within the window (a climb): every estimator and the
simulator's record interpolate it in time inside the integration
(:func:`aeroid.flights.exogenous`); ``Airframe.density_kgm3`` has no single value then.
Unknown tables and keys, booleans or text where numbers belong and values outside
physical ranges (:data:`LIMITS`) are one-line errors naming the file and the key. Files
written by :func:`save_airframe` and by ``Flight.write`` (the JSON sidecar holds the
same tables) read back equal.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from aeroid.errors import AirframeError
from aeroid.model import _atmosphere as atmosphere
from aeroid.model._actuator import FinLaw
from aeroid.model._airframe_checks import check_atmosphere, check_ranges
from aeroid.model._airframe_form import (
    AIRFRAME_KEYS,
    AIRFRAME_TABLES,
    ATMOSPHERE_CHANNELS,
    ATMOSPHERE_KEYS,
    LIMITS,
    SCENARIO_TABLES,
    airframe_fields,
    check_fin,
    check_holds,
    coefficient_pairs,
    prior_tuple,
)
from aeroid.model._coefficients import NAMES, nominal
from aeroid.model._fileform import (
    dumps_toml,
    is_number,
    numbers,
    read_toml,
)
from aeroid.model._tables import MachTables, TableSpec
from aeroid.model._thrust import ThrustCurve

#: Each mass constant -> the attribute of its standard deviation (0: taken as exact).
MASS_SD_FIELDS = {"mass_kg": "mass_sd_kg", "ix_kgm2": "ix_sd_kgm2", "iy_kgm2": "iy_sd_kgm2",
                  "iz_kgm2": "iz_sd_kgm2"}


@dataclass(frozen=True, kw_only=True)
class Airframe:
    """A rolling airframe with constant mass properties and a stated atmosphere.

    Attributes
    ----------
    diameter_m : float
        Reference diameter D [m] (reference area S = pi D^2 / 4).
    length_m : float or None
        Length [m]; informative only.
    mass_kg : float
        Mass [kg].
    ix_kgm2, iy_kgm2, iz_kgm2 : float
        Principal moments of inertia [kg m^2]; no products of inertia.
    mass_sd_kg, ix_sd_kgm2, iy_sd_kgm2, iz_sd_kgm2 : float
        Standard deviation of the mass [kg] and of each inertia [kg m^2] (default 0:
        taken as exact; below the value itself). A positive one is a consider parameter:
        :meth:`aeroid.estimation.Estimator.fit` adds its share to the coefficients'
        covariance (:func:`aeroid.estimation.consider_covariance`).
    thrust_n : float
        Thrust [N] along body +x through the c.g., known to every estimator; >= 0.
    delta_max_deg : float or None
        ON-OFF fin deflection [deg], > 0; required with ``fin = "relay"``, absent with
        ``fin = "passive"``.
    accel1_position_m, accel2_position_m : tuple of 3 float
        Accelerometer triad positions from the c.g. in body axes [m]; distinct.
    accel1_position_sd_m, accel2_position_sd_m : tuple of 3 float
        Standard deviation of each position component [m] (default 0: known). A
        component with a positive sd is uncertain: output-error estimates it under that
        Gaussian prior, the EKF/UKF carry it in their state (option
        ``positions``).
    altitude_m : float or None
        Flight altitude [m] for the ISA density (held constant: the model has no
        position equations).
    given_density_kgm3 : float or None
        Air density [kg/m^3] stated directly (file key ``density_kgm3``).
    atmosphere_channel : str or None
        Name of the flight channel carrying the atmosphere per sample (file key
        ``per_sample``: ``"rho"``, ``"altitude"`` (ISA density) or ``"qbar"`` (density
        from the dynamic pressure and the measured speed).
    prior : tuple of float (one per coefficient) or None
        Pre-flight coefficient prediction in :data:`aeroid.model.NAMES` order.
    fin_law : FinLaw or None
        The fin law (``[fin_law]``), its ``delta_max_rad`` this airframe's.
    fin : {"relay", "passive"}
        ``relay`` (default): the moving ON-OFF fin of ``delta_max_deg``; ``passive``:
        no moving fin (fixed fins: a sounding rocket's), so a log needs no fin column
        (its deflection is zero), a non-zero one is refused, and the fin terms Czd and
        Cmd are held at zero in every fit (:data:`FIN_KINDS`; issue 25).
    hold, prior_sd : tuple of (name, float)
        ``[hold]``: coefficients every fit holds at a value; ``[prior_sd]``: the sd of a
        Gaussian prior centred on ``[prior]`` (needed); :func:`aeroid.estimation.airframe_holds`.
    tables : TableSpec or None
        Coefficients the fits take as tables in Mach (``[tables]``;
        :meth:`mach_tables`); None: every coefficient constant.
    thrust_curve : ThrustCurve or None
        ``[thrust_curve]``: the motor's thrust on its own clock, used inside its burn
        window only (needs ``thrust_n`` 0): the simulator flies it, a flight gets its
        ``thrust`` (and ``mass``) channels from it (:func:`aeroid.flights.with_thrust_curve`).

    Exactly one of ``altitude_m``, ``given_density_kgm3`` and ``atmosphere_channel``
    is given.
    """

    diameter_m: float
    mass_kg: float
    ix_kgm2: float
    iy_kgm2: float
    iz_kgm2: float
    thrust_n: float
    delta_max_deg: float | None = None
    accel1_position_m: tuple[float, float, float]
    accel2_position_m: tuple[float, float, float]
    accel1_position_sd_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    accel2_position_sd_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    mass_sd_kg: float = 0.0
    ix_sd_kgm2: float = 0.0
    iy_sd_kgm2: float = 0.0
    iz_sd_kgm2: float = 0.0
    length_m: float | None = None
    altitude_m: float | None = None
    given_density_kgm3: float | None = None
    atmosphere_channel: str | None = None
    prior: tuple[float, ...] | None = field(default=None)
    fin_law: FinLaw | None = None
    fin: str = "relay"
    hold: tuple[tuple[str, float], ...] = ()
    prior_sd: tuple[tuple[str, float], ...] = ()
    tables: TableSpec | None = None
    thrust_curve: ThrustCurve | None = None

    def __post_init__(self) -> None:
        for name in ("diameter_m", "length_m", "mass_kg", "ix_kgm2", "iy_kgm2", "iz_kgm2"):
            value = getattr(self, name)
            if value is None and name == "length_m":
                continue
            if not (is_number(value) and math.isfinite(value) and value > 0):
                raise AirframeError(f"airframe: {name} must be a positive number, got {value!r}")
            object.__setattr__(self, name, float(value))
        check_fin(self.fin, self.delta_max_deg, self.fin_law)
        for name in ("hold", "prior_sd"):  # issue 25: held coefficients, priors' sd
            object.__setattr__(self, name, coefficient_pairs(getattr(self, name), name))
        check_holds(self.hold, self.prior_sd, self.prior)
        for name in ("thrust_n", "delta_max_deg"):
            value = getattr(self, name)
            if value is None and self.fin == "passive":
                continue
            if not (is_number(value) and math.isfinite(value)):
                raise AirframeError(f"airframe: {name} must be a finite number, got {value!r}")
            object.__setattr__(self, name, float(value))
        for name in ("accel1_position_m", "accel2_position_m", "accel1_position_sd_m",
                     "accel2_position_sd_m"):
            value = getattr(self, name)
            try:
                vec = numbers(value, 3, f"airframe: {name}")
            except AirframeError:
                raise AirframeError(
                    f"airframe: {name} must be 3 finite numbers, got {value!r}") from None
            if name.endswith("_sd_m") and any(v < 0 for v in vec):
                raise AirframeError(f"airframe: {name} must be >= 0 [m], got {list(vec)}")
            object.__setattr__(self, name, vec)
        self._check_mass_sd()
        check_atmosphere(self)
        check_ranges(self)
        if self.prior is not None:
            object.__setattr__(self, "prior", prior_tuple(self.prior))
        if self.tables is not None and not isinstance(self.tables, TableSpec):
            raise AirframeError(f"airframe: tables must be a TableSpec, got {self.tables!r}")
        if self.tables is not None and self.tables.temperature_k is None \
                and self.altitude_m is None:
            raise AirframeError("airframe: [tables] needs the speed of sound for Mach: give "
                                "[tables] temperature_K, or [atmosphere] altitude_m for ISA")
        if self.thrust_curve is not None and (not isinstance(self.thrust_curve, ThrustCurve)
                                              or self.thrust_n != 0):
            raise AirframeError(f"airframe: a [thrust_curve] needs thrust_N = 0 (the curve is "
                                f"the thrust), got thrust_N = {self.thrust_n:g}")
        if self.fin_law is not None and not (isinstance(self.fin_law, FinLaw) and math.isclose(
                self.fin_law.delta_max_rad, self.delta_max_rad, rel_tol=1e-12)):
            raise AirframeError(f"airframe: fin_law must be a FinLaw with delta_max_rad "
                                f"{self.delta_max_rad:g} (delta_max_deg), got {self.fin_law!r}")

    def _check_mass_sd(self) -> None:
        for name, sd_name in MASS_SD_FIELDS.items():
            sd, value = getattr(self, sd_name), getattr(self, name)
            if not (is_number(sd) and math.isfinite(sd) and 0 <= sd < value):
                raise AirframeError(f"airframe: {sd_name} must be a number in [0, {name} = "
                                    f"{value:g}), got {sd!r}")
            object.__setattr__(self, sd_name, float(sd))

    # Derived quantities -------------------------------------------------------------
    @property
    def area_m2(self) -> float:
        """Reference area S = pi D^2 / 4 [m^2]."""
        return math.pi * self.diameter_m**2 / 4.0

    @property
    def density_kgm3(self) -> float:
        """Air density [kg/m^3]: the given one, or ISA at :attr:`altitude_m`.

        Raises
        ------
        AirframeError
            For a per-sample atmosphere: the density is then the flight's.
        """
        if self.given_density_kgm3 is not None:
            return self.given_density_kgm3
        if self.altitude_m is None:
            raise AirframeError(
                f"airframe: no single density: the atmosphere is per sample (channel "
                f"{self.atmosphere_channel!r}); take the flight's values "
                "(aeroid.flights.sample_constants)")
        return float(atmosphere.density(self.altitude_m))

    @property
    def speed_of_sound_mps(self) -> float:
        """ISA speed of sound at :attr:`altitude_m` [m/s] (needs an altitude)."""
        if self.altitude_m is None:
            raise AirframeError("airframe: the speed of sound needs [atmosphere] altitude_m")
        return float(atmosphere.speed_of_sound(self.altitude_m))

    @property
    def delta_max_rad(self) -> float:
        """ON-OFF fin deflection [rad].

        Raises
        ------
        AirframeError
            For a passive fin (it has no throw).
        """
        if self.delta_max_deg is None:
            raise AirframeError('airframe: fin = "passive" has no fin throw (delta_max_deg)')
        return math.radians(self.delta_max_deg)

    @property
    def accel_positions(self) -> np.ndarray:
        """Both triad positions, shape (2, 3) [m]."""
        return np.array([self.accel1_position_m, self.accel2_position_m])

    @property
    def accel_position_sd(self) -> np.ndarray:
        """Standard deviation of each position component, shape (2, 3) [m] (0: known)."""
        return np.array([self.accel1_position_sd_m, self.accel2_position_sd_m])

    def mach_tables(self, states: np.ndarray | None = None,
                    temperature_k: np.ndarray | None = None) -> MachTables | None:
        """Return the coefficient tables of a flight of this airframe (None: no ``[tables]``).

        ``states`` (n, 9): the flight's, to choose knots given as a count from its Mach
        range; the speed of sound from ``[tables] temperature_K`` or ISA at the altitude,
        or from ``temperature_k`` (n,) [K], the flight's logged air temperature per sample.
        """
        return None if self.tables is None else self.tables.resolve(self.altitude_m, states,
                                                                    temperature_k)
    @property
    def mass_sd(self) -> dict[str, float]:
        """The uncertain mass constants: attribute (``mass_kg``, ...) -> sd (> 0 only)."""
        return {name: getattr(self, sd) for name, sd in MASS_SD_FIELDS.items()
                if getattr(self, sd) > 0}

    def prior_vector(self) -> np.ndarray:
        """Return the prior coefficients (nominal values when none is given), (N_COEFFICIENTS,)."""
        return nominal() if self.prior is None else np.array(self.prior)

    def replace(self, **changes: Any) -> Airframe:
        """Return a copy with some fields replaced (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    # Serialisation -----------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """Return the file form: ``{"airframe": {...}, "atmosphere": {...}, "prior": {...}}``."""
        table: dict[str, Any] = {}
        for key, attr in AIRFRAME_KEYS.items():
            value = getattr(self, attr)
            if key.endswith("_sd_m") and not any(value):
                continue  # known positions: the default, left out of the file
            if attr in MASS_SD_FIELDS.values() and value == 0:
                continue  # exact mass constants: the default, left out of the file
            if value is not None:
                table[key] = list(value) if isinstance(value, tuple) else value
        atmos = {key: getattr(self, attr) for key, attr in ATMOSPHERE_KEYS.items()
                 if getattr(self, attr) is not None}
        out: dict[str, Any] = {"airframe": table, "atmosphere": atmos}
        if self.prior is not None:
            out["prior"] = dict(zip(NAMES, self.prior, strict=True))
        if self.fin_law is not None:
            out["fin_law"] = self.fin_law.to_table()
        if self.fin == "relay":
            table.pop("fin", None)  # the default, left out of the file
        out.update({k: dict(v) for k, v in (("hold", self.hold), ("prior_sd", self.prior_sd)) if v})
        if self.tables is not None:
            out["tables"] = self.tables.to_table()
        if self.thrust_curve is not None:
            out["thrust_curve"] = self.thrust_curve.to_table()
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, source: str = "airframe",
                  other_tables: tuple[str, ...] = ()) -> Airframe:
        """Build an airframe from the file form (:meth:`to_dict`; the file: :mod:`._airframe_form`).

        Parameters
        ----------
        data : mapping
            The parsed file.
        source : str
            The file (or other origin) named in error messages.
        other_tables : tuple of str
            Further tables the caller reads itself (a scenario file's); any other
            table is an error.

        Raises
        ------
        AirframeError
            One line naming ``source`` and the missing, unknown or invalid table or key.
        """
        kwargs, law_table = airframe_fields(data, source=source, other_tables=other_tables)
        try:
            airframe = cls(**kwargs)
        except AirframeError as exc:
            raise AirframeError(f"{source}: {exc}") from None
        if law_table is None:
            return airframe
        law = FinLaw.from_table(law_table, delta_max_rad=airframe.delta_max_rad,
                                where=f"{source}: [fin_law]")
        return airframe.replace(fin_law=law)


def load_airframe(path: str | Path) -> Airframe:
    """Load an airframe file (tables ``[airframe]``, ``[atmosphere]``, optional ``[prior]``)."""
    return Airframe.from_dict(read_toml(path), source=str(path))


def save_airframe(airframe: Airframe, path: str | Path) -> None:
    """Write ``airframe`` as a TOML airframe file readable by :func:`load_airframe`."""
    Path(path).write_text(dumps_toml(airframe.to_dict()))


def reference_scenario_data() -> dict[str, Any]:
    """Return the parsed embedded reference scenario file."""
    text = (resources.files("aeroid") / "data" / "reference-scenario.toml").read_text()
    return tomllib.loads(text)


def reference_airframe() -> Airframe:
    """Return the embedded reference airframe (``reference-scenario.toml``).

    The reference file has no ``[prior]`` table; the prior then defaults to the
    nominal coefficients (see :meth:`Airframe.prior_vector`).
    """
    return Airframe.from_dict(reference_scenario_data(), source="reference-scenario.toml",
                              other_tables=SCENARIO_TABLES)


__all__ = ["AIRFRAME_KEYS", "AIRFRAME_TABLES", "ATMOSPHERE_CHANNELS", "ATMOSPHERE_KEYS",
           "Airframe", "LIMITS", "MASS_SD_FIELDS", "SCENARIO_TABLES", "dumps_toml", "load_airframe",
           "read_toml", "reference_airframe", "reference_scenario_data", "save_airframe"]
