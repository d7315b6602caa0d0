"""Flying a :class:`FlightConfig` in JSBSim and logging it (the engine side).

Frames: JSBSim's executive runs its models in a fixed order each frame (FGFDMExec:
FGPropagate first, then atmosphere, flight control, auxiliary, aerodynamics, external
forces, accelerations). So after ``run()`` number ``n`` the state is ``x_n`` at
``t_n = n dt``, and the fin law's output ``delta_n``, the density, the forces and moments
and the state derivative read at that moment all belong to ``x_n``; the next frame's
FGPropagate integrates with them. Frame 0 (the initial condition) is evaluated by
``run_ic``. The one exception is ``accelerations/a-pilot-*``: FGAuxiliary runs before
FGAccelerations and uses the previous frame's body acceleration (one frame late), which
is why the accelerometers are computed from the forces instead.

A log sample is taken every ``frames_per_sample`` frames; ``phi`` and ``psi`` are
unwrapped (aeroid's simulator integrates them unbounded). ``p, q, r`` are the inertial
rates a gyro measures (``velocities/pi-rad_sec``); the rates relative to the planet are
kept as ``p_ecef..`` (equal unless the planet rotates).
"""

from __future__ import annotations

import math
import tempfile

import numpy as np
import pandas as pd

from ._aircraft import FT, INTEGRATORS, LBF, SLUG, SLUG_FT2, SLUG_FT3, FlightConfig, write_aircraft

#: Logged JSBSim properties: channel -> (property, factor to SI).
PROPS: dict[str, tuple[str, float]] = {
    "u": ("velocities/u-fps", FT), "v": ("velocities/v-fps", FT),
    "w": ("velocities/w-fps", FT),
    "p": ("velocities/pi-rad_sec", 1.0), "q": ("velocities/qi-rad_sec", 1.0),
    "r": ("velocities/ri-rad_sec", 1.0),
    "p_ecef": ("velocities/p-rad_sec", 1.0), "q_ecef": ("velocities/q-rad_sec", 1.0),
    "r_ecef": ("velocities/r-rad_sec", 1.0),
    "phi": ("attitude/phi-rad", 1.0), "theta": ("attitude/theta-rad", 1.0),
    "psi": ("attitude/psi-rad", 1.0), "altitude": ("position/h-sl-ft", FT),
    "delta_frame": ("fcs/fin-rad", 1.0), "switching": ("fcs/switching-function", 1.0),
    "FAX": ("forces/fbx-aero-lbs", LBF), "FAY": ("forces/fby-aero-lbs", LBF),
    "FAZ": ("forces/fbz-aero-lbs", LBF),
    "FTX": ("forces/fbx-external-lbs", LBF), "FTY": ("forces/fby-external-lbs", LBF),
    "FTZ": ("forces/fbz-external-lbs", LBF),
    "MX": ("moments/l-aero-lbsft", LBF * FT), "MY": ("moments/m-aero-lbsft", LBF * FT),
    "MZ": ("moments/n-aero-lbsft", LBF * FT),
    "fz_per_delta": ("aero/sensitivity/fz-per-delta-lbs", LBF),
    "my_per_delta": ("aero/sensitivity/my-per-delta-lbsft", LBF * FT),
    "pdot": ("accelerations/pidot-rad_sec2", 1.0),
    "qdot": ("accelerations/qidot-rad_sec2", 1.0),
    "rdot": ("accelerations/ridot-rad_sec2", 1.0),
    "udot": ("accelerations/udot-ft_sec2", FT), "vdot": ("accelerations/vdot-ft_sec2", FT),
    "wdot": ("accelerations/wdot-ft_sec2", FT),
    "rho": ("atmosphere/rho-slugs_ft3", SLUG_FT3),
    "pressure": ("atmosphere/P-psf", LBF / FT**2), "temperature": ("atmosphere/T-R", 5.0 / 9.0),
    "gravity": ("accelerations/gravity-ft_sec2", FT),
    "alpha_jsbsim": ("aero/alpha-rad", 1.0), "beta_jsbsim": ("aero/beta-rad", 1.0),
    "qbar": ("aero/qbar-psf", LBF / FT**2),
    "a_pilot_x": ("accelerations/a-pilot-x-ft_sec2", FT),
    "a_pilot_y": ("accelerations/a-pilot-y-ft_sec2", FT),
    "a_pilot_z": ("accelerations/a-pilot-z-ft_sec2", FT),
    "wind_n": ("atmosphere/total-wind-north-fps", FT),
    "wind_e": ("atmosphere/total-wind-east-fps", FT),
    "wind_d": ("atmosphere/total-wind-down-fps", FT),
    "p_turb": ("atmosphere/p-turb-rad_sec", 1.0), "q_turb": ("atmosphere/q-turb-rad_sec", 1.0),
    "r_turb": ("atmosphere/r-turb-rad_sec", 1.0),
    "airspeed": ("velocities/vt-fps", FT),
    "mass": ("inertia/mass-slugs", SLUG), "ix": ("inertia/ixx-slugs_ft2", SLUG_FT2),
    "iy": ("inertia/iyy-slugs_ft2", SLUG_FT2), "iz": ("inertia/izz-slugs_ft2", SLUG_FT2),
}


#: ``atmosphere/turb-type`` of MIL-F-8785C Dryden turbulence (FGWinds::tType: none,
#: standard, culp, milspec, tustin).
MILSPEC = 3


class _CollectingLogger:
    """JSBSim log sink: keeps warnings and errors, drops the banner and debug output."""

    def __init__(self, jsbsim_module) -> None:
        base = jsbsim_module.FGLogger

        class Sink(base):
            def __init__(self) -> None:
                super().__init__()
                self.records: list[list] = []

            def set_level(self, level) -> None:
                self.records.append([int(level), ""])

            def message(self, text: str) -> None:
                if self.records:
                    self.records[-1][1] += text

            def file_location(self, filename: str, line: int) -> None:
                pass

            def format(self, fmt) -> None:
                pass

            def flush(self) -> None:
                pass

        self.sink = Sink()

    def errors(self) -> list[str]:
        """Messages of level ERROR (4) and FATAL (5)."""
        return [text.strip() for level, text in self.sink.records if level in (4, 5)]


def _initial_condition(fdm, config: FlightConfig) -> None:
    alpha, beta = math.radians(config.alpha_deg), math.radians(config.beta_deg)
    v = config.speed_mps / FT
    fdm["ic/lat-gc-deg"] = config.latitude_deg
    fdm["ic/long-gc-deg"] = config.longitude_deg
    fdm["ic/h-sl-ft"] = config.altitude_m / FT
    fdm["ic/phi-rad"] = math.radians(config.phi_deg)
    fdm["ic/theta-rad"] = math.radians(config.theta_deg)
    fdm["ic/psi-true-rad"] = math.radians(config.psi_deg)
    fdm["ic/u-fps"] = v * math.cos(alpha) * math.cos(beta)
    fdm["ic/v-fps"] = v * math.sin(beta)
    fdm["ic/w-fps"] = v * math.sin(alpha) * math.cos(beta)
    fdm["ic/p-rad_sec"] = config.p_radps
    fdm["ic/q-rad_sec"] = config.q_radps
    fdm["ic/r-rad_sec"] = config.r_radps


def _air(fdm, config: FlightConfig) -> None:
    """The steady wind and the Milspec Dryden turbulence of ``config`` (after ``run_ic``).

    ``run_ic`` gives the atmosphere the initial condition's wind, whose NED components
    are read-only properties in JSBSim 1.3 (``ic/vw-north-fps``; only a horizontal
    magnitude and direction are writable, and they keep the airspeed, not the ground
    velocity), so the wind is set after it: the initial state stays the configured one
    over the ground, and only frame 0's derivative (the first 1/16000 s) saw still air.

    JSBSim's FGWinds (MIL-F-8785C as in MIL-STD-1797A, Yeager 1998 eqs. 30-35): above
    2000 ft the intensity is the severity curve's at the altitude and the scale length
    1750 ft; the gusts are first-order filters of white noise advanced once per frame,
    started at zero, along and across the steady wind's direction (north without one);
    with them come rotational gusts ``p, q, r``-turb from the wingspan (here D).
    """
    north, east, down = (x / FT for x in config.wind_ned_mps)
    fdm["atmosphere/wind-north-fps"] = north
    fdm["atmosphere/wind-east-fps"] = east
    fdm["atmosphere/wind-down-fps"] = down
    if config.turbulence_severity:
        fdm["simulation/randomseed"] = config.random_seed
        fdm["atmosphere/turb-type"] = MILSPEC
        fdm["atmosphere/turbulence/milspec/severity"] = config.turbulence_severity


def run_jsbsim(config: FlightConfig) -> tuple[pd.DataFrame, np.ndarray, np.ndarray, float]:
    """Fly ``config`` in JSBSim and log the window.

    Returns
    -------
    log : DataFrame
        One row per log sample in the window: ``t`` and the :data:`STATE_PROPS` and
        :data:`FRAME_PROPS` channels in SI units.
    frame_t, frame_delta : ndarray, shape (n_frames,)
        Every frame's time [s] and fin-law output [rad], from t = 0 to the window's end.
    frame_dt : float
    """
    import jsbsim

    logger = _CollectingLogger(jsbsim)
    previous = jsbsim.get_logger()
    jsbsim.set_logger(logger.sink)
    try:
        with tempfile.TemporaryDirectory(prefix="aeroid-jsbsim-") as root:
            write_aircraft(config, root)
            fdm = jsbsim.FGFDMExec(root, None)
            fdm.set_debug_level(0)
            if not fdm.load_model(config.name):
                raise RuntimeError(f"JSBSim could not load {config.name}: {logger.errors()}")
            frame_dt = 1.0 / config.frame_rate_hz
            fdm.set_dt(frame_dt)
            code = INTEGRATORS[config.integrator]
            for group in ("rate/rotational", "rate/translational", "position/rotational",
                          "position/translational"):
                fdm[f"simulation/integrator/{group}"] = code
            if config.planet != "earth":
                fdm["simulation/gravity-model"] = 0  # spherical GM / r^2 (no J2 term)
            _initial_condition(fdm, config)
            if not fdm.run_ic():
                raise RuntimeError(f"JSBSim run_ic failed: {logger.errors()}")
            if config.moving_air:
                _air(fdm, config)
            return _fly(fdm, config, frame_dt, logger)
    finally:
        jsbsim.set_logger(previous)


def _fly(fdm, config: FlightConfig, frame_dt: float, logger: _CollectingLogger
         ) -> tuple[pd.DataFrame, np.ndarray, np.ndarray, float]:
    pm = fdm.get_property_manager()
    nodes = {k: (pm.get_node(p, False), f) for k, (p, f) in PROPS.items()}
    missing = [k for k, (node, _) in nodes.items() if node is None]
    if missing:
        raise RuntimeError(f"JSBSim has no property for {missing}")
    fin = nodes["delta_frame"][0]
    per = config.frames_per_sample
    k0 = int(round(config.window_s[0] * config.sample_rate_hz))
    k1 = int(round(config.window_s[1] * config.sample_rate_hz))
    n_frames = k1 * per + 1
    frame_delta = np.empty(n_frames)
    rows = []
    for n in range(n_frames):
        if n > 0:  # frame 0 is the initial condition, evaluated by run_ic
            fdm.run()
        frame_delta[n] = fin.get_double_value()
        if n % per == 0 and n // per >= k0:
            row = {"t": (n // per) / config.sample_rate_hz}
            row.update({k: node.get_double_value() * f for k, (node, f) in nodes.items()})
            rows.append(row)
    if logger.errors():
        raise RuntimeError(f"JSBSim reported errors: {logger.errors()}")
    log = pd.DataFrame(rows)
    log["phi"] = np.unwrap(log["phi"].to_numpy())
    log["psi"] = np.unwrap(log["psi"].to_numpy())
    return log, np.arange(n_frames) * frame_dt, frame_delta, frame_dt


