"""EBM-PSO's and SEBM-PSO's air data: the step-2 regressors' wind, as equation-error's.

The option ``air_data`` is resolved by :func:`aeroid.estimation.resolve_air_data`, the
one code path equation-error uses, so the same flight gives both the same wind to the
bit: with ``air_data_window_s = None`` (the default, as equation-error's) the wind the
logged angles (and airspeed) imply, Kalman-smoothed with its gust intensity by maximum
likelihood (:mod:`aeroid.estimation._air_smoother`); a number keeps the Savitzky-Golay
window of that many seconds (0.1 the former default; 0: none). The airspeed channel is
used where logged; turbulence without one is refused as equation-error refuses it
(:func:`aeroid.estimation.refuse_unseen_gusts`).

What is not carried: equation-error adds the smoothed wind's record-mean uncertainty to
its covariance as a consider term (:mod:`baselines._ee_air`). The PSO methods report no
covariance or standard errors (``stderr`` None; ``info["information"]`` is the cost's
curvature, of unknown scale), so there is nothing to add it to, and none is made up.
"""

from __future__ import annotations

import dataclasses
import logging
from typing import Any

from aeroid.estimation._air_data import AirData, ignored_air_data_warning, resolve_air_data
from aeroid.estimation._air_refusal import refuse_unseen_gusts
from aeroid.estimation._air_verdict import air_data_verdict, with_air_verdict
from aeroid.estimation._result import EstimationResult
from aeroid.flights import Flight

__all__ = ["step_one_air", "with_step_one_air"]


def step_one_air(est: Any, flight: Flight) -> AirData:
    """The aerodynamic angles of the step-2 regression for the estimator's ``air_data``
    and ``air_data_window_s`` (module docstring); the note logged (logger ``aeroid``,
    INFO) when they are not the inertial ones."""
    air = resolve_air_data(flight, est.air_data, est.name, est.air_data_window_s)
    if air.source != "inertial":
        logging.getLogger("aeroid").info(air.note)  # what was done, as equation-error says it
    return air


def with_step_one_air(result: EstimationResult, est: Any, flight: Flight, air: AirData
                      ) -> EstimationResult:
    """``result`` with what its air data did, as equation-error records it.

    ``info``: ``air_data`` (the source), ``air_data_note`` (the one line), with the
    Kalman smoother ``air_data_wind_intensity`` [(m/s)^2/s], with the logged angles
    ``air_data_verdict``. Warnings: the inertial angles' warning that the flight's air
    data are ignored, or the airspeed assumption's, and the verdict's line. With the
    logged angles, turbulence without an airspeed channel is ``success = False``.
    """
    info = {**result.info, "air_data": air.source, "air_data_note": air.note}
    if air.smoothed is not None:
        info["air_data_wind_intensity"] = air.smoothed.intensity
    line = ignored_air_data_warning(flight, est.name) if air.source == "inertial" \
        else air.warning
    result = dataclasses.replace(result, info=info,
                                 warnings=(*result.warnings, *([line] if line else [])))
    if air.source != "measured":
        return result
    return refuse_unseen_gusts(with_air_verdict(result, air_data_verdict(flight, est.name)),
                              flight, est.name)
