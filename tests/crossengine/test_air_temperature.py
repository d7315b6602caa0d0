"""JSBSim's Mach in warm air against aeroid's Mach from the logged temperature (issue 23).

The cross-engine airframe (``FlightConfig()``: Mach 1.63 at 2500 m, climbing) flown by
JSBSim with ``atmosphere/delta-T`` = 36 R (ISA + 20 K). Logged at 400 Hz for 0.25 s:
JSBSim's ``velocities/mach``, its true airspeed ``velocities/vt-fps`` and its air
temperature ``atmosphere/T-R`` (which changes along the climb). aeroid's Mach from the
logged temperature, ``V / sqrt(gamma R T)`` (:func:`aeroid.model.speed_of_sound_at`),
equals JSBSim's within 1.4e-6 (measured), its gas constant's rounding: JSBSim's
``R = 1716.56 ft lbf / (slug R)`` is 287.0536 J/(kg K) against aeroid's 287.05287. The
Mach an ISA fit would assume is 3.3 % higher (``sqrt(T / T_ISA)``).
"""

from __future__ import annotations

import tempfile

import numpy as np
import pytest

from aeroid.model import isa_temperature, speed_of_sound_at

from ._aircraft import FT, FlightConfig, write_aircraft
from ._engine import _initial_condition

jsbsim = pytest.importorskip("jsbsim", reason="the cross-engine tests need JSBSim")

#: ISA + 20 K, in JSBSim's Rankine.
DELTA_T_K = 20.0
RANKINE = 5.0 / 9.0
#: JSBSim's gas constant against aeroid's (the relative difference of the speeds of sound
#: is half that of R: 1.3e-6), with margin.
MACH_RTOL = 3e-6
#: JSBSim's temperature against the ISA's at its altitude plus the offset: its altitude
#: is geometric, the ISA formula's geopotential (0.4 m at 2.5 km: 0.003 K), with margin.
TEMPERATURE_ATOL_K = 0.02


def _fly(n_frames: int, every: int) -> np.ndarray:
    config = FlightConfig()
    rows = []
    with tempfile.TemporaryDirectory(prefix="aeroid-jsbsim-") as root:
        write_aircraft(config, root)
        fdm = jsbsim.FGFDMExec(root, None)
        fdm.set_debug_level(0)
        assert fdm.load_model(config.name)
        fdm.set_dt(1.0 / config.frame_rate_hz)
        _initial_condition(fdm, config)
        fdm["atmosphere/delta-T"] = DELTA_T_K / RANKINE
        assert fdm.run_ic()
        for n in range(n_frames):
            if n:
                fdm.run()
            if n % every == 0:
                rows.append([fdm["velocities/mach"], fdm["velocities/vt-fps"] * FT,
                             fdm["atmosphere/T-R"] * RANKINE, fdm["position/h-sl-ft"] * FT])
    return np.array(rows)


def test_jsbsim_mach_is_aeroids_from_the_logged_temperature():
    log = _fly(4000, 40)  # 0.25 s at 16 kHz, every 40th frame
    mach, speed, temperature, altitude = log.T
    assert np.ptp(temperature) > 0.1  # the climb changes the air temperature
    np.testing.assert_allclose(temperature, isa_temperature(altitude) + DELTA_T_K, rtol=0,
                               atol=TEMPERATURE_ATOL_K)
    np.testing.assert_allclose(speed / speed_of_sound_at(temperature), mach, rtol=MACH_RTOL)
    isa = speed / speed_of_sound_at(isa_temperature(altitude))
    assert np.all(isa / mach - 1.0 > 0.03)  # what a fit assuming the ISA would take
