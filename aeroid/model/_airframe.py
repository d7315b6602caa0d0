"""The airframe: geometry, mass, inertia, thrust, fin throw, sensor positions, prior.

An airframe file is the ``[airframe]`` table of the reference scenario file
(``aeroid/data/reference-scenario.toml``), optionally with a ``[prior]`` table of the
nine coefficients (the pre-flight prediction, e.g. DATCOM or CFD, that estimators start
from) and an ``[atmosphere]`` table (``altitude_m``). Files written by hand, by other
tools and by :func:`save_airframe` share this format.
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
from aeroid.model._coefficients import NAMES, as_vector, nominal

_AIRFRAME_KEYS = {
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
}



@dataclass(frozen=True, kw_only=True)
class Airframe:
    """A rolling airframe with constant mass properties.

    Attributes
    ----------
    diameter_m, length_m : float
        Reference diameter D [m] (reference area S = pi D^2 / 4) and length [m].
    mass_kg : float
        Mass [kg].
    ix_kgm2, iy_kgm2, iz_kgm2 : float
        Principal moments of inertia [kg m^2]; no products of inertia.
    thrust_n : float
        Thrust [N] along body +x through the c.g., known to every estimator.
    delta_max_deg : float
        ON-OFF fin deflection [deg].
    accel1_position_m, accel2_position_m : tuple of 3 float
        Accelerometer triad positions from the c.g. in body axes [m].
    altitude_m : float
        Flight altitude [m] for the ISA density (held constant: the model has no
        position equations).
    prior : tuple of 9 float or None
        Pre-flight coefficient prediction in :data:`aeroid.model.NAMES` order.
    """

    diameter_m: float
    length_m: float
    mass_kg: float
    ix_kgm2: float
    iy_kgm2: float
    iz_kgm2: float
    thrust_n: float
    delta_max_deg: float
    accel1_position_m: tuple[float, float, float]
    accel2_position_m: tuple[float, float, float]
    altitude_m: float = 0.0
    prior: tuple[float, ...] | None = field(default=None)

    def __post_init__(self) -> None:
        for name in ("diameter_m", "length_m", "mass_kg", "ix_kgm2", "iy_kgm2", "iz_kgm2"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise AirframeError(f"airframe: {name} must be a positive number, got {value!r}")
        for name in ("thrust_n", "delta_max_deg", "altitude_m"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value)):
                raise AirframeError(f"airframe: {name} must be a finite number, got {value!r}")
        for name in ("accel1_position_m", "accel2_position_m"):
            value = getattr(self, name)
            try:
                vec = tuple(float(x) for x in value)
            except (TypeError, ValueError):
                raise AirframeError(f"airframe: {name} must be 3 numbers, got {value!r}") from None
            if len(vec) != 3 or not all(math.isfinite(x) for x in vec):
                raise AirframeError(f"airframe: {name} must be 3 finite numbers, got {value!r}")
            object.__setattr__(self, name, vec)
        if self.prior is not None:
            try:
                prior = as_vector(self.prior)
            except ValueError as exc:
                raise AirframeError(f"airframe prior: {exc}") from None
            if prior.shape != (9,) or not np.all(np.isfinite(prior)):
                raise AirframeError("airframe prior: expected 9 finite values")
            object.__setattr__(self, "prior", tuple(float(x) for x in prior))

    # Derived quantities -------------------------------------------------------------
    @property
    def area_m2(self) -> float:
        """Reference area S = pi D^2 / 4 [m^2]."""
        return math.pi * self.diameter_m**2 / 4.0

    @property
    def density_kgm3(self) -> float:
        """ISA air density at :attr:`altitude_m` [kg/m^3]."""
        return float(atmosphere.density(self.altitude_m))

    @property
    def speed_of_sound_mps(self) -> float:
        """ISA speed of sound at :attr:`altitude_m` [m/s]."""
        return float(atmosphere.speed_of_sound(self.altitude_m))

    @property
    def delta_max_rad(self) -> float:
        """ON-OFF fin deflection [rad]."""
        return math.radians(self.delta_max_deg)

    @property
    def accel_positions(self) -> np.ndarray:
        """Both triad positions, shape (2, 3) [m]."""
        return np.array([self.accel1_position_m, self.accel2_position_m])

    def prior_vector(self) -> np.ndarray:
        """Return the prior coefficients (nominal values when none is given), shape (9,)."""
        return nominal() if self.prior is None else np.array(self.prior)

    def replace(self, **changes: Any) -> Airframe:
        """Return a copy with some fields replaced (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    # Serialisation -----------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """Return the file form: ``{"airframe": {...}, "atmosphere": {...}, "prior": {...}}``."""
        table: dict[str, Any] = {}
        for key, attr in _AIRFRAME_KEYS.items():
            value = getattr(self, attr)
            table[key] = list(value) if isinstance(value, tuple) else value
        out: dict[str, Any] = {"airframe": table, "atmosphere": {"altitude_m": self.altitude_m}}
        if self.prior is not None:
            out["prior"] = dict(zip(NAMES, self.prior, strict=True))
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, source: str = "airframe") -> Airframe:
        """Build an airframe from the file form (see :meth:`to_dict`).

        Raises
        ------
        AirframeError
            One line naming ``source`` and the missing, unknown or invalid key.
        """
        if "airframe" not in data:
            raise AirframeError(f"{source}: no [airframe] table")
        table = data["airframe"]
        missing = [k for k in _AIRFRAME_KEYS if k not in table]
        if missing:
            raise AirframeError(f"{source}: [airframe] is missing {', '.join(missing)}")
        unknown = sorted(set(table) - set(_AIRFRAME_KEYS))
        if unknown:
            raise AirframeError(f"{source}: [airframe] has unknown key(s) {', '.join(unknown)}")
        kwargs: dict[str, Any] = {attr: table[key] for key, attr in _AIRFRAME_KEYS.items()}
        kwargs["altitude_m"] = float(data.get("atmosphere", {}).get("altitude_m", 0.0))
        if "prior" in data:
            kwargs["prior"] = data["prior"]
        try:
            return cls(**kwargs)
        except AirframeError as exc:
            raise AirframeError(f"{source}: {exc}") from None


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(float(value)) if isinstance(value, float) else str(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def dumps_toml(data: Mapping[str, Mapping[str, Any]]) -> str:
    """Write a two-level mapping (tables of scalars and lists) as TOML text."""
    lines: list[str] = []
    for table, entries in data.items():
        lines.append(f"[{table}]")
        lines.extend(f"{key} = {_toml_value(value)}" for key, value in entries.items())
        lines.append("")
    return "\n".join(lines)


def read_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file, turning every failure into a one-line ``AirframeError``."""
    path = Path(path)
    try:
        with path.open("rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise AirframeError(f"{path}: no such file") from None
    except tomllib.TOMLDecodeError as exc:
        raise AirframeError(f"{path}: malformed TOML ({exc})") from None
    except OSError as exc:
        raise AirframeError(f"{path}: cannot read ({exc.strerror})") from None


def load_airframe(path: str | Path) -> Airframe:
    """Load an airframe from a TOML file (the scenario file format's tables)."""
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
    return Airframe.from_dict(reference_scenario_data(), source="reference-scenario.toml")
