"""Flight data and simulation: the Flight type, its files, noise models, scenarios, simulate."""

from aeroid.flights._agreement import (
    AGREE_RTOL,
    REFUSE_PER_SWITCH,
    THROW_RTOL,
    WARN_PER_SWITCH,
    Agreement,
    InputChoice,
    check_input,
    input_agreement,
)
from aeroid.flights._air_temperature import (
    AIR_TEMPERATURE,
    air_temperature,
    flight_mach_tables,
    speed_of_sound_note,
    unused_note,
)
from aeroid.flights._channels import (
    AIR_DATA_CHANNELS,
    ANGLE_CHANNELS,
    CHANNELS,
    OPTIONAL_CHANNELS,
    REQUIRED_CHANNELS,
    STATE_CHANNELS,
    UNITS,
)
from aeroid.flights._declared_air import (
    DECLARED_WIND_KEY,
    declared_wind,
    describe_wind,
    is_still,
    wind_metadata,
)
from aeroid.flights._files import read_column_map, read_flight, write_flight
from aeroid.flights._flight import Flight, make_flight
from aeroid.flights._mounting import (
    Mounting,
    axis_map,
    euler_mounting,
    matrix_mounting,
    used_samples,
)
from aeroid.flights._noise import (
    ACCEL_CHANNELS,
    NOISE_FORMS,
    RATE_CHANNELS,
    GaussianNoise,
    NoiseModel,
    NoNoise,
    PaperNoise,
    make_noise,
    noise_from_dict,
)
from aeroid.flights._pitot import (
    PITOT_CHANNELS,
    PITOT_KEY,
    mach_from_pitot,
    pitot_ratio,
    pitot_ratio_slope,
    probe_pressures,
)
from aeroid.flights._pitot_airspeed import PitotAirspeed, pitot_airspeed, with_pitot_airspeed
from aeroid.flights._probe_position import AIR_DATA_PROBE_KEY, air_data_probe_position
from aeroid.flights._record import (
    INPUTS,
    exogenous,
    flight_record,
    model_constants,
    resolve_input,
    sample_constants,
    schedule,
)
from aeroid.flights._scenario import (
    EVALUATIONS,
    Manoeuvre,
    Scenario,
    load_scenario,
    noise_for,
    reference_scenario,
    scenario_from_dict,
)
from aeroid.flights._sidecar import FORMAT, sidecar_path
from aeroid.flights._simulate import (
    Truth,
    record_flight,
    simulate,
    simulate_scenario,
    simulate_truth,
)
from aeroid.flights._suite import (
    IMU_ERROR_KINDS,
    SensorSuite,
    SuiteSimulation,
    body_to_ned,
    imu_error_names,
    log_trajectory,
    simulate_suite,
    wrap_angle,
)
from aeroid.flights._suite_air import AirProbe, air_group_airspeed
from aeroid.flights._suite_log import (
    GROUPS,
    SI_UNITS,
    SensorGroup,
    SuiteLog,
    mounted_group,
    read_suite_log,
)
from aeroid.flights._suite_truth import imu_manoeuvre
from aeroid.flights._suite_write import write_suite_log
from aeroid.flights._thrust_flight import sample_thrust, with_thrust_curve
from aeroid.flights._turbulence import (
    MIL_SCALE_LENGTH_M,
    WIND_KEYS,
    Wind,
    dryden_autocorrelation,
    path_axes,
    shaping_filters,
)
from aeroid.flights._windows import (
    Windows,
    check_window_ranges,
    cut_windows,
    parse_window_spec,
)

__all__ = [
    "INPUTS", "exogenous", "flight_record", "model_constants", "sample_constants", "schedule",
    "resolve_input", "AGREE_RTOL", "REFUSE_PER_SWITCH", "THROW_RTOL", "WARN_PER_SWITCH",
    "Agreement", "InputChoice", "check_input", "input_agreement", "AIR_DATA_CHANNELS",
    "ACCEL_CHANNELS", "ANGLE_CHANNELS", "NOISE_FORMS", "CHANNELS", "FORMAT", "OPTIONAL_CHANNELS",
    "RATE_CHANNELS", "REQUIRED_CHANNELS", "STATE_CHANNELS", "UNITS", "Flight", "GaussianNoise",
    "Manoeuvre", "NoNoise", "NoiseModel", "PaperNoise", "Scenario", "load_scenario",
    "make_flight", "make_noise", "noise_for", "noise_from_dict", "read_column_map",
    "read_flight", "record_flight", "reference_scenario", "scenario_from_dict", "sidecar_path",
    "simulate", "simulate_scenario", "simulate_truth", "write_flight",
    "EVALUATIONS", "Truth", "NOISE_FORMS",
    "GROUPS", "SI_UNITS", "SensorGroup", "SensorSuite", "SuiteLog", "SuiteSimulation",
    "IMU_ERROR_KINDS", "body_to_ned", "imu_error_names", "imu_manoeuvre", "log_trajectory",
    "read_suite_log", "simulate_suite",
    "wrap_angle", "write_suite_log",
    "Mounting", "axis_map", "euler_mounting", "matrix_mounting", "mounted_group",
    "used_samples",
    "Windows", "check_window_ranges", "cut_windows", "parse_window_spec",
    "MIL_SCALE_LENGTH_M", "WIND_KEYS", "Wind", "dryden_autocorrelation", "path_axes",
    "shaping_filters",
    "sample_thrust", "with_thrust_curve",
    "AIR_TEMPERATURE", "air_temperature", "flight_mach_tables", "speed_of_sound_note",
    "unused_note",
    "PITOT_CHANNELS", "PITOT_KEY", "PitotAirspeed", "mach_from_pitot", "pitot_airspeed",
    "pitot_ratio", "pitot_ratio_slope", "probe_pressures", "with_pitot_airspeed",
    "AirProbe", "air_group_airspeed", "AIR_DATA_PROBE_KEY", "air_data_probe_position",
    "DECLARED_WIND_KEY", "declared_wind", "describe_wind", "is_still", "wind_metadata",
]
