"""The model, written once: coefficients, airframe, atmosphere, actuator, equations, RK4.

This is the kernel-level tier of aeroid: what estimators, simulators and floors evaluate.
The equations of motion (paper eqs. 2-16) and the lever-arm accelerometers (eq. 28) are
defined once, by name; numpy, numba and CasADi evaluate the same definitions.

Namespaces: :mod:`equations <aeroid.model._equations>` (the equations by name),
:mod:`symbolic <aeroid.model._symbolic>` (CasADi), :mod:`fileform
<aeroid.model._fileform>` (reading and checking aeroid's TOML and JSON files: one-line
errors naming the file and key; the flights' readers use it) and :mod:`tables
<aeroid.model._tables>` (coefficients as tables in Mach: the hat basis,
:class:`MachTables`).
"""

from aeroid.model import _equations as equations
from aeroid.model import _fileform as fileform
from aeroid.model import _symbolic as symbolic
from aeroid.model import _tables as tables
from aeroid.model._actuator import FIN_LAW_KEYS, FinLaw, Profile, RelayActuator, Track, profile
from aeroid.model._airframe import LIMITS as AIRFRAME_LIMITS
from aeroid.model._airframe import (
    MASS_SD_FIELDS,
    SCENARIO_TABLES,
    Airframe,
    dumps_toml,
    load_airframe,
    read_toml,
    reference_airframe,
    reference_scenario_data,
    save_airframe,
)
from aeroid.model._atmosphere import (
    AIR_TEMPERATURE_RANGE_K,
    G0,
    GAMMA,
    H_TROPOPAUSE,
    LAPSE,
    P0,
    R_AIR,
    T0,
    check_air_temperature,
    density,
    pressure_altitude,
    speed_of_sound_at,
)
from aeroid.model._atmosphere import pressure as isa_pressure
from aeroid.model._atmosphere import temperature as isa_temperature
from aeroid.model._buffered import Buffered
from aeroid.model._coefficients import (
    LABELS,
    N_COEFFICIENTS,
    NAMES,
    NOMINAL,
    as_dict,
    as_vector,
    lateral_from_pitch,
    nominal,
)
from aeroid.model._compile_clock import CompileClock, compile_clock, compiling
from aeroid.model._compiled import kernels_cached
from aeroid.model._curve_csv import read_curve_csv
from aeroid.model._dynamics import (
    ACCEL_CHANNELS,
    FM_NAMES,
    N_STATE,
    OUTPUT_CHANNELS,
    PHI,
    PSI,
    RATE_CHANNELS,
    STATE_NAMES,
    THETA,
    Constants,
    P,
    Q,
    R,
    U,
    V,
    W,
    accelerometers,
    aero_forces_moments,
    air_data,
    as_coefficients,
    as_state,
    constants,
    derivative_from_forces,
    regressors,
    state_derivative,
)
from aeroid.model._equations import Coefficients, Loads, State, Trig
from aeroid.model._forward import ForwardModel, symbolic_record
from aeroid.model._inputs import (
    EXOGENOUS,
    Pieces,
    Record,
    Schedule,
    exogenous_table,
    with_exogenous,
)
from aeroid.model._integrate import HAVE_NUMBA, propagate, rk4, rk4_step
from aeroid.model._sensitivity import DEFAULT_REL_STEP, SENSITIVITY_BLOCK_BYTES
from aeroid.model._tables import MachTables, TableSpec
from aeroid.model._thrust import ThrustCurve, read_thrust_curve
from aeroid.model._wind import with_steady_wind, with_wind_symbols

__all__ = [
    "ACCEL_CHANNELS", "OUTPUT_CHANNELS", "RATE_CHANNELS", "Coefficients", "Loads", "State",
    "Trig", "as_coefficients", "as_state", "equations", "Buffered", "ForwardModel",
    "symbolic", "symbolic_record", "EXOGENOUS", "Pieces", "Record", "Schedule",
    "exogenous_table", "with_exogenous", "kernels_cached",
    "CompileClock", "compile_clock", "compiling",
    "FM_NAMES", "G0", "HAVE_NUMBA", "LABELS", "NAMES", "NOMINAL", "N_COEFFICIENTS", "N_STATE",
    "PHI", "PSI", "STATE_NAMES", "THETA", "MASS_SD_FIELDS", "Airframe", "Constants", "P", "Q", "R",
    "RelayActuator", "U", "V", "W", "accelerometers", "aero_forces_moments", "air_data",
    "as_dict", "as_vector", "constants", "derivative_from_forces", "dumps_toml",
    "lateral_from_pitch", "load_airframe", "nominal", "propagate",
    "read_toml", "reference_airframe", "reference_scenario_data", "regressors", "rk4",
    "rk4_step", "save_airframe", "state_derivative",
    "FinLaw", "SENSITIVITY_BLOCK_BYTES",
    "AIRFRAME_LIMITS", "DEFAULT_REL_STEP", "FIN_LAW_KEYS", "Profile", "SCENARIO_TABLES", "Track",
    "density", "fileform", "profile",
    "GAMMA", "H_TROPOPAUSE", "LAPSE", "P0", "R_AIR", "T0", "isa_pressure", "isa_temperature",
    "pressure_altitude",
    "AIR_TEMPERATURE_RANGE_K", "check_air_temperature", "speed_of_sound_at",
    "MachTables", "TableSpec", "tables",
    "ThrustCurve", "read_thrust_curve", "read_curve_csv",
    "with_steady_wind", "with_wind_symbols",
]
