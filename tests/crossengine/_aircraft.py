"""The cross-engine flight configuration and its JSBSim aircraft definition.

A :class:`FlightConfig` names everything a JSBSim flight needs: the airframe (SI), the
true coefficients, the fin law, the initial condition, the recording, and the engine's
world (planet, integrators, frame rate). :func:`write_aircraft` fills the XML template
``rolling_airframe.xml`` (same folder) with it, in JSBSim's native units converted from
SI with exact factors (JSBSim's own unit table is rounded: 1 m = 3.2808399 ft, 1 N =
0.22482 lbf, 1 kg m^2 = 1/1.35594 slug ft^2, off by up to 8e-5).

Planets (``FlightConfig.planet``), each a documented JSBSim ``<planet>`` definition:

* ``"flat"``: a sphere of radius :data:`FLAT_RADIUS_M` (157 Earth radii) with no
  rotation and standard gravity g0 = 9.80665 m/s^2 at its surface (``GM = g0 R^2``,
  ``J2 = 0``): over a 1 km climb g changes by 2e-6 relative and the local vertical turns
  by V/R = 5e-7 rad/s, the nearest JSBSim comes to aeroid's flat non-rotating earth.
* ``"sphere"``: a non-rotating sphere of the Earth's mean radius with g0 at sea level:
  gravity falls by 3.1e-7 per metre of altitude and the local vertical turns by V/R
  (transport rate, ~8e-5 rad/s here).
* ``"earth"``: JSBSim's default WGS84 Earth (ellipsoid, J2 gravity, rotation
  7.292e-5 rad/s, Coriolis and centripetal terms).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from string import Template
from typing import Literal

import numpy as np

from aeroid.model import G0, NAMES, as_vector

TEMPLATE = Path(__file__).with_name("rolling_airframe.xml")

# Exact unit factors (SI per JSBSim unit).
FT = 0.3048                      # m per ft
LBF = 4.4482216152605            # N per lbf
SLUG = LBF / FT                  # kg per slug (= 14.593902937206...)
SLUG_FT2 = SLUG * FT * FT        # kg m^2 per slug ft^2
SLUG_FT3 = SLUG / FT**3          # kg/m^3 per slug/ft^3
#: JSBSim turns the weight [lbs] into a mass with its own constant (FGJSBBase::slugtolb),
#: so the weight written is ``mass_slug * JSBSIM_SLUGTOLB``: the mass JSBSim uses is exact.
JSBSIM_SLUGTOLB = 32.174049

FLAT_RADIUS_M = 1.0e9
EARTH_MEAN_RADIUS_M = 6_371_000.0

#: JSBSim integrator codes (``simulation/integrator/...`` properties, FGPropagate).
INTEGRATORS = {"euler": 1, "trapezoidal": 2, "ab2": 3, "ab3": 4, "ab4": 5}

#: The cross-engine airframe's true coefficients (not the reference airframe's).
TRUE_COEFFICIENTS: dict[str, float] = {
    "Cx": -0.55, "Cza": -13.2, "Czd": -1.9, "Czq": -118.0, "Cl0": 0.034,
    "Clp": -4.4, "Cma": -26.5, "Cmd": -14.8, "Cmq": -1630.0,
}
#: The pre-flight prediction each estimator starts from: truth times these factors
#: (8-15 % off, mixed signs), deterministic.
PRIOR_FACTORS: tuple[float, ...] = (1.10, 0.90, 1.15, 0.88, 1.12, 0.90, 1.08, 0.92, 1.12)


@dataclass(frozen=True, kw_only=True)
class FlightConfig:
    """One JSBSim flight of the rolling airframe.

    Attributes
    ----------
    name : str
        Aircraft name (file ``aircraft/<name>/<name>.xml`` in a temporary root).
    diameter_m, length_m, mass_kg : float
        Reference diameter D [m] (S = pi D^2/4), length [m] (unused by the model), mass [kg].
    ix_kgm2, iy_kgm2, iz_kgm2 : float
        Principal inertias [kg m^2]; aeroid's model is exact for ``iy == iz``.
    thrust_n : float
        Constant thrust on body +x through the c.g. [N].
    delta_max_deg, command_amplitude, command_phase_deg : float
        Fin law ``delta = delta_max sign(sin 2phi + A sin(phi + phi0))``.
    accel1_position_m, accel2_position_m : tuple of 3 float
        Accelerometer triads from the c.g., body axes [m].
    coefficients : mapping
        True coefficients by name.
    prior_factors : tuple of 9 float
        Airframe prior = truth * factors.
    altitude_m, speed_mps, alpha_deg, beta_deg : float
        Initial altitude above sea level [m], airspeed [m/s], incidence [deg].
    phi_deg, theta_deg, psi_deg : float
        Initial attitude [deg].
    p_radps, q_radps, r_radps : float
        Initial body rates [rad/s].
    latitude_deg, longitude_deg : float
        Launch point (matters on the ``"earth"`` planet only).
    sample_rate_hz : float
        Log rate [Hz].
    frame_rate_hz : float
        JSBSim frame rate [Hz], an integer multiple of ``sample_rate_hz``; the fin law is
        evaluated once per frame.
    window_s : tuple of 2 float
        Recorded window from t = 0 (the initial condition) [s], both ends included.
    planet : {"flat", "sphere", "earth"}
        The engine's world (module docstring).
    integrator : {"euler", "trapezoidal", "ab2", "ab3", "ab4"}
        JSBSim integrator for all four state groups (rates and positions, rotational and
        translational); default Adams-Bashforth 3.
    switching : {"subframe", "frame"}
        How the flight control system renders the relay: ``"frame"`` switches at the
        first frame where the switching function has the new sign (a digital relay at the
        frame rate); ``"subframe"`` (default) gives the frame holding the zero the relay's
        mean over that frame (the ``rolling_airframe.xml`` header), which places the
        switch at the continuous relay's instant to second order.
    fin_delay_s : float
        Actuator transport delay [s], a whole number of frames:
        ``delta(t) = relay(phi(t - delay))``. Written as ``<delay type="frames"> N + 1``:
        JSBSim's ring buffer (FGFCSComponent::Delay) writes the new value, advances and
        then reads, so a buffer of N frames delays by N - 1 (measured; a test checks the
        switch instants).
    wind_ned_mps : tuple of 3 float
        Steady wind over the ground, north-east-down [m/s] (``atmosphere/wind-*-fps``);
        default still air.
    turbulence_severity : int
        JSBSim's MIL-F-8785C Dryden turbulence (``atmosphere/turb-type`` Milspec,
        ``atmosphere/turbulence/milspec/severity``): 0 (default) none, 1-7 the
        probability-of-exceedance curves (3 light, 4 moderate, 6 severe).
    random_seed : int
        JSBSim's random generator seed (``simulation/randomseed``): the gusts.
    rotational_gusts : bool
        With turbulence, whether the damping terms see JSBSim's rotational gusts
        (``velocities/p-aero-rad_sec = p - p_turb``). Default False: the body rates, as
        aeroid's model (eqs. 2-7: only the velocity is air-relative). JSBSim's Milspec
        rotational gusts scale with 1/wingspan and with the frame rate (``q_turb`` is a
        frame-to-frame difference of the vertical gust): with this airframe's D = 0.152 m
        at 16 kHz they are 0.5 rad/s RMS (measured), white at the frame rate.
    fin : {"relay", "passive"}
        ``passive``: the fin does not move (``fcs/fin-rad`` is 0; a sounding rocket's fixed,
        canted fins: the roll moment Cl0 against the roll damping Clp); the flight's fin
        column is 0 and its airframe says ``fin = "passive"`` (a log written without
        the column reads back the same). Default ``relay``.
    """

    name: str = "xe_climb"
    diameter_m: float = 0.152
    length_m: float = 2.2
    mass_kg: float = 38.5
    ix_kgm2: float = 0.11
    iy_kgm2: float = 14.2
    iz_kgm2: float = 14.2
    thrust_n: float = 1350.0
    delta_max_deg: float = 6.0
    command_amplitude: float = 0.7
    command_phase_deg: float = 35.0
    accel1_position_m: tuple[float, float, float] = (0.42, 0.004, -0.003)
    accel2_position_m: tuple[float, float, float] = (-0.55, -0.006, 0.008)
    coefficients: Mapping[str, float] = field(default_factory=lambda: dict(TRUE_COEFFICIENTS))
    prior_factors: tuple[float, ...] = PRIOR_FACTORS
    altitude_m: float = 2500.0
    speed_mps: float = 560.0
    alpha_deg: float = 0.0
    beta_deg: float = 0.0
    phi_deg: float = 0.0
    theta_deg: float = 32.0
    psi_deg: float = 0.0
    p_radps: float = 30.0
    q_radps: float = 0.0
    r_radps: float = 0.0
    latitude_deg: float = 45.0
    longitude_deg: float = 0.0
    sample_rate_hz: float = 500.0
    frame_rate_hz: float = 16000.0
    window_s: tuple[float, float] = (0.3, 1.3)
    planet: Literal["flat", "sphere", "earth"] = "flat"
    integrator: Literal["euler", "trapezoidal", "ab2", "ab3", "ab4"] = "ab3"
    switching: Literal["subframe", "frame"] = "subframe"
    fin_delay_s: float = 0.0
    wind_ned_mps: tuple[float, float, float] = (0.0, 0.0, 0.0)
    turbulence_severity: int = 0
    random_seed: int = 0
    rotational_gusts: bool = False
    fin: Literal["relay", "passive"] = "relay"

    def __post_init__(self) -> None:
        ratio = self.frame_rate_hz / self.sample_rate_hz
        if ratio < 1 or abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(f"frame_rate_hz {self.frame_rate_hz} is not an integer multiple "
                             f"of sample_rate_hz {self.sample_rate_hz}")
        if self.planet not in ("flat", "sphere", "earth"):
            raise ValueError(f"planet must be flat, sphere or earth, got {self.planet!r}")
        if self.integrator not in INTEGRATORS:
            raise ValueError(f"integrator must be one of {', '.join(INTEGRATORS)}, "
                             f"got {self.integrator!r}")
        frames = self.fin_delay_s * self.frame_rate_hz
        if self.fin_delay_s < 0 or abs(frames - round(frames)) > 1e-6:
            raise ValueError(f"fin_delay_s {self.fin_delay_s} is not a whole number of frames "
                             f"at {self.frame_rate_hz} Hz")
        if self.switching not in ("subframe", "frame"):
            raise ValueError(f"switching must be subframe or frame, got {self.switching!r}")
        if self.fin not in ("relay", "passive"):
            raise ValueError(f"fin must be relay or passive, got {self.fin!r}")
        if self.turbulence_severity not in range(8):
            raise ValueError(f"turbulence_severity must be 0-7, got {self.turbulence_severity}")
        if not 0.0 <= self.window_s[0] < self.window_s[1]:
            raise ValueError(f"window_s must be 0 <= start < end, got {self.window_s}")

    # Derived ------------------------------------------------------------------------
    @property
    def coefficient_vector(self) -> np.ndarray:
        """True coefficients, shape (9,), in :data:`aeroid.model.NAMES` order."""
        return as_vector(dict(self.coefficients))

    @property
    def prior(self) -> tuple[float, ...]:
        """The airframe prior (truth times :attr:`prior_factors`)."""
        return tuple(float(x) for x in self.coefficient_vector * np.array(self.prior_factors))

    @property
    def area_m2(self) -> float:
        """Reference area S = pi D^2 / 4 [m^2]."""
        return math.pi * self.diameter_m**2 / 4.0

    @property
    def moving_air(self) -> bool:
        """Whether the flight has a wind or turbulence (then the logged ``alpha``, ``beta``
        are the air-relative angles, the engine's ``aero/alpha-rad``, ``aero/beta-rad``)."""
        return any(x != 0.0 for x in self.wind_ned_mps) or self.turbulence_severity > 0

    @property
    def delay_frames(self) -> int:
        """Actuator delay in frames."""
        return int(round(self.fin_delay_s * self.frame_rate_hz))

    @property
    def frames_per_sample(self) -> int:
        """JSBSim frames per log sample."""
        return int(round(self.frame_rate_hz / self.sample_rate_hz))


def _planet_xml(config: FlightConfig) -> str:
    if config.planet == "earth":
        return "  <!-- planet: JSBSim's default WGS84 Earth (rotating, J2 gravity) -->"
    radius_m = FLAT_RADIUS_M if config.planet == "flat" else EARTH_MEAN_RADIUS_M
    radius_ft = radius_m / FT
    gm_ft3s2 = (G0 / FT) * radius_ft**2  # surface gravity g0
    return (f'  <planet name="{config.planet}">\n'
            f'    <equatorial_radius unit="FT"> {radius_ft!r} </equatorial_radius>\n'
            f'    <polar_radius unit="FT"> {radius_ft!r} </polar_radius>\n'
            f'    <rotation_rate unit="RAD/SEC"> 0.0 </rotation_rate>\n'
            f'    <GM unit="FT3/SEC2"> {gm_ft3s2!r} </GM>\n'
            f'    <J2> 0.0 </J2>\n'
            f'  </planet>')


_FRAME_SWITCH = """\
      <switch name="fcs/fin-rad">
        <default value="-{dmax!r}"/>
        <test value="{dmax!r}"> fcs/switching-function GE 0.0 </test>{delay}
      </switch>"""

_PASSIVE_FIN = """\
      <fcs_function name="fcs/fin-rad">
        <!-- a passive fin: no deflection -->
        <function> <value> 0.0 </value> </function>
      </fcs_function>"""

_SUBFRAME_SWITCH = """\
      <fcs_function name="fcs/switching-rate">
        <!-- ds/dt = (2 cos(2 phi) + A cos(phi + phi0)) dphi/dt -->
        <function>
          <product>
            <sum>
              <product> <value> 2.0 </value>
                <cos> <product> <value> 2.0 </value> <property> attitude/phi-rad </property>
                      </product> </cos>
              </product>
              <product> <value> {amp!r} </value>
                <cos> <sum> <property> attitude/phi-rad </property> <value> {phase!r} </value>
                      </sum> </cos>
              </product>
            </sum>
            <sum>
              <property> velocities/p-rad_sec </property>
              <product>
                <sum>
                  <product> <property> velocities/q-rad_sec </property>
                    <sin> <property> attitude/phi-rad </property> </sin> </product>
                  <product> <property> velocities/r-rad_sec </property>
                    <cos> <property> attitude/phi-rad </property> </cos> </product>
                </sum>
                <tan> <property> attitude/theta-rad </property> </tan>
              </product>
            </sum>
          </product>
        </function>
      </fcs_function>
      <fcs_function name="fcs/fin-command-rad">
        <!-- delta_max clip(2 s / (|ds/dt| dt), -1, 1) -->
        <function>
          <product>
            <value> {dmax!r} </value>
            <max> <value> -1.0 </value>
              <min> <value> 1.0 </value>
                <quotient>
                  <product> <value> 2.0 </value> <property> fcs/switching-function </property>
                  </product>
                  <max>
                    <product> <abs> <property> fcs/switching-rate </property> </abs>
                              <value> {dt!r} </value> </product>
                    <value> 1e-300 </value>
                  </max>
                </quotient>
              </min>
            </max>
          </product>
        </function>
      </fcs_function>
      <actuator name="fcs/fin-rad">
        <!-- perfect actuator with an optional transport delay (JSBSim's fcs_function and
             pure_gain ignore <delay>) -->
        <input> fcs/fin-command-rad </input>{delay}
      </actuator>"""


def aircraft_xml(config: FlightConfig) -> str:
    """Return the JSBSim aircraft definition of ``config`` (the filled template)."""
    c = dict(zip(NAMES, config.coefficient_vector.tolist(), strict=True))
    mass_slug = config.mass_kg / SLUG
    fields = {
        "name": config.name,
        "planet": _planet_xml(config),
        "area_ft2": repr(config.area_m2 / FT**2),
        "diameter_ft": repr(config.diameter_m / FT),
        "ix_slugft2": repr(config.ix_kgm2 / SLUG_FT2),
        "iy_slugft2": repr(config.iy_kgm2 / SLUG_FT2),
        "iz_slugft2": repr(config.iz_kgm2 / SLUG_FT2),
        "weight_lbs": repr(mass_slug * JSBSIM_SLUGTOLB),
        "thrust_lbf": repr(config.thrust_n / LBF),
        "command_amplitude": repr(float(config.command_amplitude)),
        "command_phase_rad": repr(math.radians(config.command_phase_deg)),
        "fin_output": (_FRAME_SWITCH if config.switching == "frame" else _SUBFRAME_SWITCH).format(
            dmax=math.radians(config.delta_max_deg), amp=float(config.command_amplitude),
            phase=math.radians(config.command_phase_deg), dt=1.0 / config.frame_rate_hz,
            delay=(f'\n        <delay type="frames"> {config.delay_frames + 1} </delay>'
                   if config.delay_frames else "")),
        "neg_Czq": repr(-c["Czq"]),
        "neg_Cma": repr(-c["Cma"]),
        **{name: repr(value) for name, value in c.items()},
    }
    if config.fin == "passive":
        fields["fin_output"] = _PASSIVE_FIN
    xml = Template(TEMPLATE.read_text()).substitute(fields)
    if config.turbulence_severity and not config.rotational_gusts:  # damping on body rates
        for axis in "pqr":
            xml = xml.replace(f"velocities/{axis}-aero-rad_sec", f"velocities/{axis}-rad_sec")
    return xml


def write_aircraft(config: FlightConfig, root: str | Path) -> Path:
    """Write ``<root>/aircraft/<name>/<name>.xml`` and return its path."""
    path = Path(root) / "aircraft" / config.name / f"{config.name}.xml"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(aircraft_xml(config))
    return path
