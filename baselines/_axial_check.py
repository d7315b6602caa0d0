"""The axial-drag fit's verdict: residuals the size of the stated noise, priors not contradicted.

Three tests, on the residuals weighted by the log's noise sd (so about 1 when the model and
the noise sd are right):

* each channel's RMS (accelerometer, each GNSS axis, barometer) at most
  :data:`RMS_LIMIT`;
* the accelerometer's gain ``1 + scale`` positive (a reading of the opposite sign of the
  force is a flipped mounting, however well a scale factor of -2 fits);
* each prior's normalized residual (the accelerometer's bias against a given calibration,
  its scale factor against 0) at most :data:`PRIOR_LIMIT` in size: data that push a
  calibration that far contradict it (a bias given with the wrong sign, a mounting whose
  axial sign is flipped: its scale factor would have to be -2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PRIOR_LIMIT", "RMS_LIMIT", "Verdict", "fit_check"]

#: A channel's weighted residual RMS above this fails the fit. Measured on right-model fits
#: of the rocket coast's axial-only log (benchmarks/bench_axial.py, 8 seeds): accelerometer
#: 0.99-1.02, GNSS axes 0.89-1.09, barometer 0.96-1.05; an RMS of N samples of a right
#: model is 1 +- 1/sqrt(2N) (0.06 for the 151 GNSS fixes), so 1.5 is 8 of those sd. The
#: toolkit's fit check allows 3 for a noise level it estimates; here the sd is the log's.
RMS_LIMIT = 1.5
#: A prior residual (estimate - mean) / sd beyond this fails the fit (a 3-sigma contradiction).
PRIOR_LIMIT = 3.0


@dataclass(frozen=True)
class Verdict:
    """The fit check: ``passed``, one-line ``message`` (empty when passed), the RMS ratio
    per channel and the normalized prior residuals."""

    passed: bool
    message: str
    ratios: dict[str, float]
    priors: dict[str, float]

    @property
    def info(self) -> dict[str, object]:
        """The result's ``info["fit_check"]`` (``ratio``, ``worst``, ``limit`` as the
        toolkit's fit check; ``priors``, ``prior_limit``)."""
        return {"ratio": dict(self.ratios), "worst": max(self.ratios, key=self.ratios.get),
                "limit": RMS_LIMIT, "priors": dict(self.priors), "prior_limit": PRIOR_LIMIT,
                "passed": self.passed}


def fit_check(residuals: np.ndarray, channels: list[str], sizes: list[int],
              priors: tuple[str, ...], gain: float = 1.0) -> Verdict:
    """Return the verdict on the weighted residuals.

    Parameters
    ----------
    residuals : ndarray, shape (sum(sizes) + len(priors),)
        Residuals divided by their sd, channel after channel, then the priors'.
    channels, sizes : list
        Each channel's name and number of samples, in the order of ``residuals``.
    priors : tuple of str
        Names of the prior residuals at the end.
    gain : float
        The accelerometer's fitted ``1 + scale``: at or below 0 its reading has the
        opposite sign of the force (a flipped mounting), whatever the residuals say.
    """
    ratios: dict[str, float] = {}
    start = 0
    for name, size in zip(channels, sizes, strict=True):
        part = residuals[start:start + size]
        ratios[name] = float(np.sqrt(np.mean(part * part)))
        start += size
    prior = {n: float(abs(r)) for n, r in zip(priors, residuals[start:], strict=True)}
    failed = [f"{n} {r:.3g}" for n, r in ratios.items() if not r <= RMS_LIMIT]
    against = [f"{n} {r:.3g} sd from its prior" for n, r in prior.items() if not r <= PRIOR_LIMIT]
    parts = []
    if not gain > 0:
        parts.append(f"the accelerometer's fitted 1 + scale is {gain:.3g}: its reading has "
                     "the opposite sign of the axial force (is the mounting's axial sign "
                     "flipped?)")
    if failed:
        parts.append(f"residual RMS / noise sd above {RMS_LIMIT:g}: {', '.join(failed)}")
    if against:
        parts.append(f"the data contradict the priors (beyond {PRIOR_LIMIT:g} sd): "
                     f"{', '.join(against)}")
    message = ("fit check: " + "; ".join(parts) + " (the model does not fit this log: "
               "mounting sign, bias calibration, noise sd?)") if parts else ""
    return Verdict(not parts, message, ratios, prior)
