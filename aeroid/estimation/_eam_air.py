"""EAM-PSO with logged air data: the simulation flies in the wind they imply (issue 26).

EAM-PSO simulates the whole record for every particle and compares the outputs with the
log. In moving air the model's loads see the air-relative velocity; the logged angles
(and airspeed) give the wind per sample that makes the model's air-relative angles equal
the logged ones (:func:`aeroid.estimation.air_data_wind`), Kalman-smoothed as
equation-error's and EBM-PSO's (one code path: :func:`aeroid.estimation.resolve_air_data`
through :mod:`aeroid.estimation._pso_air`, the same option ``air_data``, the same wind to
the bit). :class:`WindOutputErrorCost` is EAM's cost whose simulation takes that wind as
the model's exogenous wind columns (per sample, linear within each interval: what the
simulator flies, :func:`aeroid.estimation._predict_air.with_wind_series`), so every
particle flies in it. The wind is taken as exact: EAM-PSO has no standard errors to carry
its uncertainty in (as EBM-PSO, :mod:`aeroid.estimation._pso_air`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from aeroid.estimation._air_data import check_air_options
from aeroid.estimation._objectives import OutputErrorCost
from aeroid.estimation._predict_air import with_wind_series
from aeroid.flights import Flight
from aeroid.model import ForwardModel

__all__ = ["WindOutputErrorCost", "check_air_options"]


class WindOutputErrorCost(OutputErrorCost):
    """:class:`aeroid.estimation.OutputErrorCost` simulated in the wind ``wind`` (n, 3)
    NED [m/s] per sample (None: still air, the cost unchanged); other arguments as its."""

    def __init__(self, flight: Flight, wind: np.ndarray | None, **kwargs: Any) -> None:
        super().__init__(flight, **kwargs)
        if wind is None:
            return
        model = self.model
        self.record = with_wind_series(model.const, self.record, wind)
        self.model = ForwardModel(model.const, self.record, model.positions,
                                  substeps=model.substeps, backend=model.backend)
