"""What an aided output-error fit reports: residuals, ``info["aiding"]``, warnings (private).

Of :mod:`baselines._oe_aiding`'s fits (and the EKF's and UKF's warnings): each source's
residuals for the fit check against its stated sd, and a warning per source the flight
carries and the fit leaves out.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from aeroid.flights import Flight
from aeroid.model import OUTPUT_CHANNELS
from baselines._gauss_newton import Problem
from baselines._oe_aiding_samples import (
    AIDING,
    CHANNELS,
    LABELS,
    RESIDUAL_NAMES,
    SOURCES,
    aiding_sources,
)


def aiding_info(prob: Problem, e: np.ndarray) -> dict[str, Any]:
    """``info`` entries of an aided fit: the aiding residuals for the fit check (their
    yardstick the stated sd) and ``info["aiding"]``; empty for a fit without aiding."""
    if getattr(prob, "known_var", None) is None:  # not an AidedProblem
        return {}
    model = prob.model
    m = len(OUTPUT_CHANNELS)
    residuals = {c: e[:, j] for j, c in enumerate(OUTPUT_CHANNELS)}
    signals, noise_sd, per_source = {}, {}, {}
    for s, cols in zip(model.samples, model.cols, strict=True):
        names = RESIDUAL_NAMES[s.source]
        residuals.update({c: e[s.index, m + cols.start + j] for j, c in enumerate(names)})
        # the resolution floor's yardstick: the change over the flight (the initial
        # value is fitted), not the GNSS's 500 m/s (1e-3 of that is 5x the GNSS's sd)
        signals.update({c: s.z[:, j] - np.mean(s.z[:, j]) for j, c in enumerate(names)})
        noise_sd.update(dict(zip(names, s.sd.tolist(), strict=True)))
        per_source[s.source] = {"channels": names, "n_samples": int(s.index.size),
                                "times_s": model.base.t[s.index],
                                "sd": dict(zip(names, s.sd.tolist(), strict=True))}
    freed = ("phi0 theta0 psi0" if "ins" in per_source else "pitch and heading theta0 psi0"
             if "gnss" in per_source else "")
    if "gnss_position" in per_source:
        freed += " and the GNSS position's origin pn0 pe0 pd0"
    if "baro" in per_source:
        freed += " and the barometer's origin altitude baro_h0"
    return {"fit_residuals": residuals, "fit_signals": signals, "fit_noise_sd": noise_sd,
            "aiding": {"channels": tuple(signals), "sources": per_source,
                       "n_samples": sum(v["n_samples"] for v in per_source.values()),
                       "times_s": model.base.t[model.samples[0].index],
                       "noise": "the log's stated sd (not estimated)",
                       "wrapped": "INS angles compared on the circle (residual in (-pi, pi])"
                       if "ins" in per_source else "none",
                       "note": f"initial {freed.removeprefix(' and ')} estimated (no prior)",
                       "sd": noise_sd}}


def aiding_warnings(aiding: str, flight: Flight, owner: str = "output-error"
                    ) -> tuple[str, ...]:
    """A warning per aiding source the flight carries and the fit leaves out."""
    carried = flight.metadata.get("aiding")
    if not isinstance(carried, Mapping):
        return ()
    used = aiding_sources(aiding)
    return tuple(f"{owner}: the flight carries {LABELS[s]} samples (metadata aiding), not in "
                 f"this fit's likelihood ({_puts_in(s, owner)})"
                 for s in CHANNELS if s in carried and s not in used)


def _puts_in(source: str, owner: str) -> str:
    """What puts ``source`` in the likelihood: the filters take only GNSS velocity and INS."""
    option = {"gnss": "gnss-velocity", "ins": AIDING[-1]}.get(source) or word(source)
    if option in AIDING or owner == "output-error":
        return f"aiding = {option} puts them in"
    return f"output-error's aiding = {option} puts them in; {owner} cannot take them"


def word(source: str) -> str:
    """The option's word of ``source`` (``gnss_position`` -> ``gnss-position``)."""
    return next(w for w, s in SOURCES.items() if s == source)
