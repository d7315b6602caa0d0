"""The aerodynamic coefficients of the rolling airframe (paper, section 1).

The estimated vector is always ordered as :data:`NAMES`, the fields of
:class:`~aeroid.model._equations.Coefficients` (the paper's nine: ``Cx, Cza, Czd, Czq,
Cl0, Clp, Cma, Cmd, Cmq``); every count of coefficients in aeroid is ``len(NAMES)``.
The lateral (y, yaw) coefficients are not estimated: the cruciform symmetry of
eq. 1 ties them to the pitch-plane ones (:func:`lateral_from_pitch`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from aeroid.model._equations import Coefficients

#: Coefficient names, in the order of every coefficient vector in aeroid: the fields of
#: the equations' :class:`~aeroid.model._equations.Coefficients` (defined there, once).
NAMES: tuple[str, ...] = tuple(Coefficients._fields)
N_COEFFICIENTS = len(NAMES)

#: Nominal values of the paper (section 4) and of the reference scenario.
NOMINAL: dict[str, float] = {
    "Cx": -0.98,
    "Cza": -11.8,
    "Czd": -1.27,
    "Czq": -172.0,
    "Cl0": 0.041,
    "Clp": -5.13,
    "Cma": -33.8,
    "Cmd": -20.9,
    "Cmq": -2227.0,
}

#: Labels for tables and figures (matplotlib mathtext).
LABELS: dict[str, str] = {
    "Cx": r"$C_x$",
    "Cza": r"$C_{z\alpha}$",
    "Czd": r"$C_{z\delta}$",
    "Czq": r"$C_{zq}$",
    "Cl0": r"$C_{l0}$",
    "Clp": r"$C_{lp}$",
    "Cma": r"$C_{m\alpha}$",
    "Cmd": r"$C_{m\delta}$",
    "Cmq": r"$C_{mq}$",
}


def nominal() -> np.ndarray:
    """Return the nominal coefficient vector, shape (N_COEFFICIENTS,)."""
    return np.array([NOMINAL[n] for n in NAMES])


def as_vector(coefficients: Mapping[str, float] | Sequence[float] | np.ndarray) -> np.ndarray:
    """Return coefficients as a float vector of shape (..., N_COEFFICIENTS) in :data:`NAMES` order.

    Parameters
    ----------
    coefficients : mapping or array_like
        A mapping with exactly the names :data:`NAMES`, or an array whose last axis has
        length :data:`N_COEFFICIENTS`.

    Raises
    ------
    ValueError
        If a name is missing or unknown, or the last axis has another length.
    """
    if isinstance(coefficients, Mapping):
        unknown = sorted(set(coefficients) - set(NAMES))
        missing = [n for n in NAMES if n not in coefficients]
        if unknown or missing:
            raise ValueError(
                f"coefficients: missing {missing or 'none'}, unknown {unknown or 'none'}; "
                f"expected {', '.join(NAMES)}"
            )
        return np.array([float(coefficients[n]) for n in NAMES])
    array = np.asarray(coefficients, dtype=float)
    if array.ndim == 0 or array.shape[-1] != N_COEFFICIENTS:
        raise ValueError(f"coefficients: expected last axis of length {N_COEFFICIENTS} "
                         f"({', '.join(NAMES)}), got shape {array.shape}")
    return array


def as_dict(vector: np.ndarray) -> dict[str, float]:
    """Return a (N_COEFFICIENTS,) coefficient vector as a name -> value dict."""
    vector = as_vector(vector)
    return {n: float(v) for n, v in zip(NAMES, vector, strict=True)}


def lateral_from_pitch(vector: np.ndarray) -> dict[str, np.ndarray]:
    """Apply the symmetry ties of eq. 1.

    ``Cyb = Cza, Cyr = -Czq, Cydr = Czd, Cnb = -Cma, Cnr = Cmq, Cndr = -Cmd``.
    The reference airframe has one fin pair acting in pitch only, so the simulator
    uses no rudder term (``Cydr``, ``Cndr`` are given for completeness).
    """
    c = as_vector(vector)
    return {
        "Cyb": c[..., NAMES.index("Cza")],
        "Cyr": -c[..., NAMES.index("Czq")],
        "Cydr": c[..., NAMES.index("Czd")],
        "Cnb": -c[..., NAMES.index("Cma")],
        "Cnr": c[..., NAMES.index("Cmq")],
        "Cndr": -c[..., NAMES.index("Cmd")],
    }
