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
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from aeroid.errors import AeroidWarning, AirframeError
from aeroid.model import _atmosphere as atmosphere
from aeroid.model._actuator import FinLaw
from aeroid.model._airframe_form import (
    AIRFRAME_KEYS,
    AIRFRAME_TABLES,
    ATMOSPHERE_CHANNELS,
    ATMOSPHERE_KEYS,
    SCENARIO_TABLES,
    airframe_fields,
    prior_tuple,
)
from aeroid.model._coefficients import NAMES, nominal
from aeroid.model._fileform import (
    dumps_toml,
    is_number,
    numbers,
    read_toml,
)

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
    delta_max_deg : float
        ON-OFF fin deflection [deg], > 0.
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

    Exactly one of ``altitude_m``, ``given_density_kgm3`` and ``atmosphere_channel``
    is given.
    """

    diameter_m: float
    mass_kg: float
    ix_kgm2: float
    iy_kgm2: float
    iz_kgm2: float
    thrust_n: float
    delta_max_deg: float
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

    def __post_init__(self) -> None:
        for name in ("diameter_m", "length_m", "mass_kg", "ix_kgm2", "iy_kgm2", "iz_kgm2"):
            value = getattr(self, name)
            if value is None and name == "length_m":
                continue
            if not (is_number(value) and math.isfinite(value) and value > 0):
                raise AirframeError(f"airframe: {name} must be a positive number, got {value!r}")
            object.__setattr__(self, name, float(value))
        for name in ("thrust_n", "delta_max_deg"):
            value = getattr(self, name)
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
        self._check_atmosphere()
        self._check_ranges()
        if self.prior is not None:
            object.__setattr__(self, "prior", prior_tuple(self.prior))
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

    def _check_atmosphere(self) -> None:
        stated = [k for k, a in ATMOSPHERE_KEYS.items() if getattr(self, a) is not None]
        if len(stated) != 1:
            raise AirframeError(
                "airframe: state the atmosphere with exactly one of altitude_m, density_kgm3 "
                f"or per_sample (got {', '.join(stated) or 'none'})")
        for key in ("altitude_m", "density_kgm3"):
            value = getattr(self, ATMOSPHERE_KEYS[key])
            if value is None:
                continue
            if not (is_number(value) and math.isfinite(value)):
                raise AirframeError(f"airframe: {key} must be a finite number, got {value!r}")
            low, high = LIMITS[key]
            if not low <= value <= high:
                raise AirframeError(f"airframe: {key} {value:g} is outside {low:g}..{high:g}"
                                    + (" (give density_kgm3 above 20 km)"
                                       if key == "altitude_m" else ""))
            object.__setattr__(self, ATMOSPHERE_KEYS[key], float(value))
        channel = self.atmosphere_channel
        if channel is not None and channel not in ATMOSPHERE_CHANNELS:
            raise AirframeError(f"airframe: per_sample must be one of "
                                f"{', '.join(map(repr, ATMOSPHERE_CHANNELS))}, got {channel!r}")

    def _check_ranges(self) -> None:
        for name in ("diameter_m", "length_m"):
            value = getattr(self, name)
            low, high = LIMITS[name]
            if value is not None and not low <= value <= high:
                raise AirframeError(f"airframe: {name} {value:g} is outside {low:g}..{high:g} "
                                    "(metres?)")
        if self.thrust_n < 0:
            raise AirframeError(f"airframe: thrust_n must be >= 0 (thrust acts along body +x; "
                                f"a coasting airframe has 0), got {self.thrust_n:g}")
        low, high = LIMITS["delta_max_deg"]
        if not low < self.delta_max_deg <= high:
            raise AirframeError(f"airframe: delta_max_deg must be in ({low:g}, {high:g}] deg, "
                                f"got {self.delta_max_deg:g}")
        if self.delta_max_deg < DELTA_MAX_WARN_DEG:
            warnings.warn(f"airframe: delta_max_deg {self.delta_max_deg:g} deg is very small "
                          f"(radians? {self.delta_max_deg:g} rad = "
                          f"{math.degrees(self.delta_max_deg):.3g} deg)",
                          AeroidWarning, stacklevel=4)
        gap = float(np.linalg.norm(np.subtract(self.accel1_position_m, self.accel2_position_m)))
        if gap < MIN_SENSOR_SEPARATION_M:
            raise AirframeError(
                f"airframe: accelerometer triads {gap:.3g} m apart (need at least "
                f"{MIN_SENSOR_SEPARATION_M:g} m: at one point the angular acceleration of "
                f"eq. 29 is rank-deficient)")
        if self.length_m is not None:
            for name in ("accel1_position_m", "accel2_position_m"):
                if float(np.linalg.norm(getattr(self, name))) > self.length_m:
                    raise AirframeError(f"airframe: {name} {list(getattr(self, name))} is "
                                        f"farther from the c.g. than length_m {self.length_m:g}")

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
        """ON-OFF fin deflection [rad]."""
        return math.radians(self.delta_max_deg)

    @property
    def accel_positions(self) -> np.ndarray:
        """Both triad positions, shape (2, 3) [m]."""
        return np.array([self.accel1_position_m, self.accel2_position_m])

    @property
    def accel_position_sd(self) -> np.ndarray:
        """Standard deviation of each position component, shape (2, 3) [m] (0: known)."""
        return np.array([self.accel1_position_sd_m, self.accel2_position_sd_m])

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
