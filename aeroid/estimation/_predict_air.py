"""The air a prediction is drawn in: the wind the fit used (issue 26, "see the fit").

A fit in moving air compares its model with the data in some wind; its prediction
(:func:`aeroid.estimation.predict`) is drawn in the same one, or the report would show the
wind's effect instead of the fit. What the fit used is read from its ``info`` (JSON types
only; nothing per sample needs storing):

* ``info["wind_ned_mps"]``: a fitted steady wind (output-error's ``estimate_wind``, the
  EKF/UKF's and filter-error's wind states): the model constants' wind
  (:func:`aeroid.model.with_steady_wind`);
* ``info["air_data"]`` ``"measured"`` or ``"reconstruction"`` (equation-error, EBM-PSO,
  SEBM-PSO, EAM-PSO): the per-sample wind the logged air data imply (smoothed as the fit
  smoothed it: its options ``air_data_window_s`` and ``air_data_smoother``) or the
  reconstruction's steady wind, made again from the flight by the fit's own code path
  (:func:`aeroid.estimation.resolve_air_data`: the same flight gives the same wind to the
  bit), as the model's exogenous wind columns ``wind_n, wind_e, wind_d`` (per sample,
  linear within each interval);
* otherwise still air.

``air = "still"`` draws any fit in still air (the report's second trace, to show what the
wind did).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from aeroid.errors import EstimatorError
from aeroid.estimation._air_data import resolve_air_data
from aeroid.model import EXOGENOUS, Record, exogenous_table, with_steady_wind

if TYPE_CHECKING:
    from aeroid.flights import Flight
    from aeroid.model import Constants

__all__ = ["AIR_CHOICES", "WIND_NAMES", "PredictionAir", "prediction_air", "with_wind_series"]

#: The option ``air`` of :func:`aeroid.estimation.predict`: the fit's air, or still air.
AIR_CHOICES: tuple[str, ...] = ("fit", "still")
#: The model's exogenous wind columns (north, east, down [m/s]).
WIND_NAMES: tuple[str, ...] = tuple(name for name in EXOGENOUS if name.startswith("wind_"))
#: ``info["air_data"]`` values whose wind the model is drawn in.
USED_AIR_DATA = ("measured", "reconstruction")


@dataclass(frozen=True)
class PredictionAir:
    """The air of a prediction: ``source`` ``"still"``, ``"steady"`` (a fitted steady
    wind, ``steady`` (3,) NED [m/s]) or ``"measured"`` / ``"reconstruction"`` (``wind``
    (n, 3) NED [m/s] per sample); ``label``: the air in a few words (a figure's legend)."""

    source: str
    label: str
    steady: np.ndarray | None = None
    wind: np.ndarray | None = None

    def apply(self, const: Constants, record: Record) -> tuple[Constants, Record]:
        """The model's constants and record in this air."""
        if self.steady is not None:
            return with_steady_wind(const, record, self.steady.tolist())
        if self.wind is not None:
            return const, with_wind_series(const, record, self.wind)
        return const, record

    def series(self, n: int) -> np.ndarray:
        """The wind at ``n`` samples, shape (n, 3) NED [m/s] (zeros in still air)."""
        if self.wind is not None:
            return np.array(self.wind, dtype=float)
        return np.tile(np.zeros(3) if self.steady is None else self.steady, (n, 1))


def with_wind_series(const: Constants, record: Record, wind: np.ndarray) -> Record:
    """``record`` with the per-sample wind ``wind`` (n, 3) NED [m/s] as its exogenous
    wind columns (the total wind: it replaces the constants' and any per-sample one)."""
    wind = np.asarray(wind, dtype=float)
    n = record.delta.size
    if wind.shape != (n, len(WIND_NAMES)) or not np.all(np.isfinite(wind)):
        raise EstimatorError(f"a prediction's wind must be {n} x {len(WIND_NAMES)} finite "
                             f"values [m/s], got shape {wind.shape}")
    if record.exogenous is None:
        table = exogenous_table(const, n, dict(zip(WIND_NAMES, wind.T, strict=True)))
    else:
        table = record.exogenous.copy()
        for j, name in enumerate(WIND_NAMES):
            table[:, EXOGENOUS.index(name)] = wind[:, j]
    return Record(record.dt, record.delta, record.pieces, table)


def _steady_label(wind: np.ndarray, what: str) -> str:
    return f"{what} N {wind[0]:+.2f}, E {wind[1]:+.2f}, D {wind[2]:+.2f} m/s"


def prediction_air(result: Any, flight: Flight, air: str = "fit") -> PredictionAir:
    """The air ``result``'s prediction on ``flight`` is drawn in (module docstring).

    Raises
    ------
    EstimatorError
        One line: ``air`` not one of :data:`AIR_CHOICES`, a ``wind_ned_mps`` that is not
        three finite numbers.
    """
    if air not in AIR_CHOICES:
        raise EstimatorError(f"{result.estimator}: air must be one of "
                             f"{', '.join(AIR_CHOICES)}, got {air!r}")
    still = PredictionAir("still", "in still air")
    if air == "still":
        return still
    info = result.info
    steady = info.get("wind_ned_mps")
    if steady is not None:
        wind = np.asarray(steady, dtype=float).reshape(-1)
        if wind.size != len(WIND_NAMES) or not np.all(np.isfinite(wind)):
            raise EstimatorError(f"{result.estimator}: info['wind_ned_mps'] must be "
                                 f"{len(WIND_NAMES)} finite numbers [m/s], got {steady!r}")
        return PredictionAir("steady", _steady_label(wind, "in the fitted steady wind"), wind)
    source = info.get("air_data")
    if not isinstance(source, str) or source not in USED_AIR_DATA:
        return still
    options = info.get("options")
    options = options if isinstance(options, dict) else {}
    window = options.get("air_data_window_s")
    smoother = options.get("air_data_smoother", "random-walk")
    used = resolve_air_data(flight, source, result.estimator,
                            None if window is None else float(window), str(smoother))
    assert used.wind is not None  # measured and reconstruction give one or raise
    if source == "reconstruction":
        label = _steady_label(used.wind[0], "in the reconstruction's steady wind")
    elif window is None:
        label = "in the wind the air data imply (Kalman-smoothed)"
    else:
        label = f"in the wind the air data imply (smoothed over {float(window):g} s)"
    return PredictionAir(source, label, wind=used.wind)
