"""GNSS position in output-error's likelihood: the NED velocity integrated (private).

``aiding = "gnss-position"`` (alone or with the other sources) adds the GNSS receiver's
NED position ``pn pe pd`` [m] at its own samples (``metadata["aiding"]["gnss_position"]``:
``t``, ``pn``, ``pe``, ``pd``, ``sd``). The airframe model has no position state (its nine
states are the body velocity, rates and Euler angles), so the prediction is the origin plus
the integral of the model's NED velocity ``C_nb [u v w]`` over the record,

    p_ned(t_k) = p_0 + int_{t_0}^{t_k} C_nb(phi, theta, psi) [u v w] dt,

by the trapezoidal rule on the record's samples (``scipy.integrate.cumulative_trapezoid``;
its error ``dt^2 / 12 (a(t_k) - a(t_0))`` is ~1e-6 m on a 1 kHz record whose NED
acceleration changes by ~10 m/s^2, against the GNSS's 1.5 m sd). The origin ``p_0``
(``pn0_m pe0_m pd0_m``) is estimated, no prior, started at the first sample's position
less the integral to it (the GNSS's origin is not the flight's). Sensitivities: the same
integral of the NED velocity's exact sensitivities; 1 for the origin.

``aiding = "...+baro-altitude"`` adds the barometric altitude (``metadata["aiding"]["baro"]``:
``t``, ``altitude``, ``sd``) the same way: ``altitude = h0 - pd(t)``, ``pd`` the integral's
down component (from the GNSS position's origin when that is in, else from 0), ``h0``
(``baro_h0_m``) estimated, no prior: the barometer's altitude where ``pd = 0`` (the GNSS
origin's altitude; without the GNSS position, the record's first sample's), a constant
barometer bias in it. The model's density does not
follow the altitude (the airframe's atmosphere).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.integrate import cumulative_trapezoid

#: The position source's key in ``metadata["aiding"]`` and its origin's parameter names.
POSITION_SOURCE = "gnss_position"
ORIGIN_NAMES = ("pn0_m", "pe0_m", "pd0_m")
#: The barometer's source key and its origin altitude's parameter: ``altitude = h0 - pd``
#: (the pressure altitude of the record's first sample, with the barometer's bias).
BARO_SOURCE = "baro"
BARO_NAME = "baro_h0_m"
#: The origins' parameter scale [m].
ORIGIN_SCALE_M = 1.0


def integrated(t: np.ndarray, v: np.ndarray, dv: np.ndarray | None, index: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray | None]:
    """The integral of ``v`` (n, 3) from ``t[0]`` to ``t[index]``, (n_a, 3), and of its
    sensitivities ``dv`` (3, n, n_s) (or None), (3, n_a, n_s)."""
    y = cumulative_trapezoid(v, t, axis=0, initial=0.0)[index]
    if dv is None:
        return y, None
    return y, cumulative_trapezoid(dv, t, axis=1, initial=0.0)[:, index]


def origin_starts(t: np.ndarray, v: np.ndarray, position: Any, baro: Any
                  ) -> tuple[np.ndarray, float]:
    """The origins that put the predictions on the first samples of ``position`` and
    ``baro`` (:class:`~baselines._oe_aiding_samples.AidingSamples` or None), with the NED
    velocity ``v`` (n, 3) of the flight's states: ``p_0`` [m] (3,) and ``h0`` [m]."""
    origin = np.zeros(3)
    if position is not None:
        origin = position.z[0] - integrated(t, v, None, position.index[:1])[0][0]
    if baro is None:
        return origin, 0.0
    return origin, float(baro.z[0, 0] + origin[2] + integrated(t, v, None,
                                                               baro.index[:1])[0][0, 2])
