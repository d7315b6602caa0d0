"""A third-party estimator for the plug-in tests: the centre of the search box.

It uses only aeroid's public API, as a real plug-in would.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from aeroid import EstimationResult, Estimator, Flight, prior_bounds


@dataclass(frozen=True, kw_only=True)
class PriorMeanEstimator(Estimator):
    """Return the centre of the prior search box (``scale`` x prior), a trivial estimator.

    Options
    -------
    scale : float
        Half-width of the box as a fraction of the prior (the box is prior x [1 - scale,
        1 + scale]). Its centre is the prior whatever the scale.
    """

    name: ClassVar[str] = "test-plugin-mean"
    description: ClassVar[str] = "test plug-in: centre of the prior search box"

    scale: float = 0.5

    def run(self, flight: Flight, rng: np.random.Generator) -> EstimationResult:
        """Return the box centre; touches every measured channel so NaN cannot pass."""
        if not np.all(np.isfinite(flight.accelerations())):
            raise ValueError("non-finite accelerations")
        box = prior_bounds(flight.airframe, scale=(1 - self.scale, 1 + self.scale))
        return EstimationResult(estimator=self.name, theta=box.mean(axis=1), cost=0.0,
                                message="box centre")
