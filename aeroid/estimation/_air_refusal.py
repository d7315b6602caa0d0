"""Turbulence without an airspeed channel: a fit with logged angles refused (issue 26).

When the air-data verdict (:mod:`aeroid.estimation._air_verdict`) says turbulence and the
log has no airspeed channel, the gusts along the path change the dynamic pressure sample
by sample, which the angles cannot see, and the fit is wrong by more than its standard
errors say while the fit check often passes it (measured in
``benchmarks/bench_air_verdict.py``: Dryden sd 1 m/s fits ~8x the still-air error
accepted by the fit check). Written once here for every method that regresses on the
logged angles: equation-error (:mod:`baselines._ee_air`), EBM-PSO and SEBM-PSO
(:mod:`aeroid.estimation._pso_air`).
"""

from __future__ import annotations

import dataclasses

from aeroid.estimation._air_data import has_airspeed
from aeroid.estimation._result import EstimationResult
from aeroid.flights import Flight

__all__ = ["refuse_unseen_gusts"]


def refuse_unseen_gusts(result: EstimationResult, flight: Flight, owner: str
                        ) -> EstimationResult:
    """``result`` refused (``success = False``, a one-line message) when its
    ``info["air_data_verdict"]`` says turbulence and the log has no airspeed channel
    (module docstring); unchanged otherwise, and when it has already failed."""
    verdict = result.info.get("air_data_verdict")
    if (not result.success or verdict is None or verdict["kind"] != "turbulence"
            or has_airspeed(flight)):
        return result
    return dataclasses.replace(result, success=False, message=(
        f"{owner}: the air data show turbulence (gusts of {verdict['gust_rms_mps']:.2g} m/s "
        f"RMS beyond the probe noise, above {verdict['gust_limit_mps']:.2g}) and the log has "
        "no airspeed channel: the gusts along the path change the dynamic pressure sample "
        "by sample, unseen by the angles; log an airspeed channel"))
