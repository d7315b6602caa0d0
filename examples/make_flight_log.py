"""Write the example flight log of the README ("Your own flight log").

The log is what a flight-test logger might write: the reference airframe's flight
(``aeroid/data/reference-scenario.toml``, 1 s at 500 Hz) with a tactical-grade IMU's
Gaussian noise, columns named by the logger, angles in degrees and rates in deg/s,
8 significant digits, no alpha/beta columns (aeroid derives them from u, v, w) and no
sidecar. Run from the repository root::

    python examples/make_flight_log.py

It rewrites ``examples/flight-log.csv``, ``examples/airframe.toml`` and
``examples/columns.toml``; the committed files are its output.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aeroid.flights import GaussianNoise, load_scenario, simulate_scenario

HERE = Path(__file__).resolve().parent
#: Seed of the example's sensor noise.
SEED = 2024
#: Logger column -> aeroid channel (written as examples/columns.toml).
COLUMNS = {
    "time_s": "t",
    "acc_nose_x_mps2": "ax1", "acc_nose_y_mps2": "ay1", "acc_nose_z_mps2": "az1",
    "acc_tail_x_mps2": "ax2", "acc_tail_y_mps2": "ay2", "acc_tail_z_mps2": "az2",
    "gyro_x_dps": "p", "gyro_y_dps": "q", "gyro_z_dps": "r",
    "fin_deg": "delta",
    "vel_x_mps": "u", "vel_y_mps": "v", "vel_z_mps": "w",
    "roll_deg": "phi", "pitch_deg": "theta", "yaw_deg": "psi",
}
DEGREES = {"p", "q", "r", "delta", "phi", "theta", "psi"}

AIRFRAME = """\
# The example airframe: aeroid's reference rolling airframe (see the README,
# "Your own flight log"). SI units; the key says where not.

[airframe]
diameter_m = 0.127                      # reference diameter D; S = pi D^2 / 4
length_m = 2.79                         # optional, informative
mass_kg = 70.0
Ix_kgm2 = 0.18
Iy_kgm2 = 40.0
Iz_kgm2 = 40.0
thrust_N = 740.0                        # along body +x through the c.g.
delta_max_deg = 8.0                     # ON-OFF fin deflection
accel1_position_m = [0.6, 0.0, 0.0]     # nose triad from the c.g., body axes
accel2_position_m = [-0.6, 0.01, 0.01]  # tail triad

[atmosphere]                            # exactly one of altitude_m, density_kgm3, per_sample
altitude_m = 10000.0                    # ISA: 0.4127 kg/m^3

[prior]                                 # optional: the pre-flight prediction to start from
Cx = -1.0
Cza = -12.0
Czd = -1.2
Czq = -160.0
Cl0 = 0.04
Clp = -5.0
Cma = -32.0
Cmd = -20.0
Cmq = -2000.0
"""


def main() -> None:
    """Simulate, rename, convert and write the three example files."""
    scenario = load_scenario(None)
    flight = simulate_scenario(scenario, GaussianNoise(), rng=SEED)
    log = pd.DataFrame({
        name: np.degrees(flight[channel]) if channel in DEGREES else flight[channel]
        for name, channel in COLUMNS.items()})
    log.to_csv(HERE / "flight-log.csv", index=False, float_format="%.8g")
    (HERE / "airframe.toml").write_text(AIRFRAME)
    lines = ["# Logger column = aeroid channel (README, \"Your own flight log\").", ""]
    lines += [f'{name} = "{channel}"' for name, channel in COLUMNS.items()]
    (HERE / "columns.toml").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
