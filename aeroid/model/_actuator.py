"""The digital ON-OFF fin actuator (paper section 4; notes, "Actuator and excitation").

Decision (notes): ``delta = delta_max * sign(sin(2 phi) + A sin(phi + phi0))`` with
``phi`` the roll angle: a guidance command fixed in the non-rolling frame plus a
dither at twice the roll frequency. ``sign(0) = +1``. The relay is evaluated at each
sample instant and held until the next (reference/README.md: "relay latched at the
2 ms sample instants"), so the recorded ``delta`` is exactly the held value.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, kw_only=True)
class RelayActuator:
    """ON-OFF relay driven by the roll angle.

    Attributes
    ----------
    delta_max_rad : float
        Fin deflection when ON [rad].
    command_amplitude : float
        ``A``, amplitude of the guidance command relative to the dither.
    command_phase_rad : float
        ``phi0`` [rad].
    """

    delta_max_rad: float
    command_amplitude: float = 0.5
    command_phase_rad: float = float(np.radians(60.0))

    def switching_function(self, phi: np.ndarray | float) -> np.ndarray:
        """Return ``sin(2 phi) + A sin(phi + phi0)`` (the relay switches at its zeros)."""
        phi = np.asarray(phi, dtype=float)
        return np.sin(2.0 * phi) + self.command_amplitude * np.sin(phi + self.command_phase_rad)

    def __call__(self, phi: np.ndarray | float) -> np.ndarray:
        """Return the fin deflection [rad] for roll angle(s) ``phi`` [rad]."""
        s = self.switching_function(phi)
        return np.where(s >= 0.0, self.delta_max_rad, -self.delta_max_rad)
