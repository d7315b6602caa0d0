"""A study's airframe constants drawn per run: ``[perturb]`` (issue 25).

A study file may hold::

    [perturb]
    mass_rel_sd = 0.03      # the flown mass of run i: the scenario's true mass
                            # (mass_kg x [initial_state] mass_scale) x (1 + 0.03 z_i)

Each run's truth is flown with its own mass, drawn from ``z_i ~ N(0, 1)`` on the run's
own seed child ``SeedSequence(seed, spawn_key=(i, 3))`` (:func:`perturb_seed`): the same
seed gives the same draw in any number of processes, and the flights' noise, the
estimators' draws and the prior (children 0, 1, 2) are those of the same study without
``[perturb]``. The estimators are told the airframe file's mass (and its ``mass_sd_kg``,
if given) as always: only the truth moves. Each record holds the run's draw
(``mass_scale``: the true mass over the file's ``mass_kg``; ``mass_kg_flown``) and the
report lists it (:func:`perturb_lines`).

Decisions:

- The draw multiplies the scenario's fixed ``mass_scale`` (kept as it was): a scenario at
  1.02 with ``mass_rel_sd = 0.03`` flies masses centred on 1.02 x the file's. To test the
  file's stated sd, centre the draws on the file's mass (a scenario with ``mass_scale``
  1) and give ``mass_rel_sd`` equal to the file's ``mass_sd_kg / mass_kg``.
- ``mass_rel_sd`` is at most :data:`MAX_MASS_REL_SD`, and the scenario's mass_scale
  times ``1 +- 6 sd`` must be a mass scale the simulator accepts (checked on load).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from aeroid.errors import AirframeError, StudyError

#: Keys of ``[perturb]``.
PERTURB_KEYS = ("mass_rel_sd",)
#: Largest relative sd of the flown mass accepted (a 10 % mass uncertainty is already a
#: coast mass nobody weighed).
MAX_MASS_REL_SD = 0.1
#: Draws checked on load: the scenario's mass scale times ``1 +- SPAN_SD x sd`` must be
#: accepted by :class:`aeroid.flights.Manoeuvre` (a draw beyond it: ~2e-9 per run).
SPAN_SD = 6.0
#: The seed child of a run's perturbations (flights 0, estimators 1, prior 2).
PERTURB_CHILD = 3


def check_perturb(table: Any, scenario: Any, source: str) -> float | None:
    """Return ``[perturb] mass_rel_sd`` (None when not given) after checking it.

    Raises
    ------
    StudyError
        One line naming the file and the key: not a table, an unknown key, a value that
        is not a finite number in (0, MAX_MASS_REL_SD], or draws the simulator refuses.
    """
    where = f"{source}: [perturb]"
    if not isinstance(table, Mapping):
        raise StudyError(f"{where} must be a table")
    unknown = sorted(set(table) - set(PERTURB_KEYS))
    if unknown:
        raise StudyError(f"{where} has unknown key(s) {', '.join(unknown)} "
                         f"(allowed: {', '.join(PERTURB_KEYS)})")
    if "mass_rel_sd" not in table:
        return None
    sd = table["mass_rel_sd"]
    if (isinstance(sd, bool) or not isinstance(sd, int | float)
            or not math.isfinite(float(sd)) or not 0.0 < float(sd) <= MAX_MASS_REL_SD):
        raise StudyError(f"{where} mass_rel_sd must be a number in (0, {MAX_MASS_REL_SD:g}] "
                         f"(the flown mass's sd over the true mass), got {sd!r}")
    sd = float(sd)
    base = scenario.manoeuvre.mass_scale
    for z in (-SPAN_SD, SPAN_SD):
        try:
            dataclasses.replace(scenario.manoeuvre, mass_scale=base * (1.0 + z * sd))
        except AirframeError as exc:
            raise StudyError(f"{where} mass_rel_sd = {sd:g} with the scenario's mass_scale "
                             f"{base:g}: a {z:+g}-sd draw is refused ({exc})") from None
    return sd


def perturb_seed(seed: int, run: int) -> np.random.SeedSequence:
    """Return the seed of run ``run``'s drawn airframe constants."""
    return np.random.SeedSequence(seed, spawn_key=(run, PERTURB_CHILD))


def run_mass_scale(study: Any, run: int) -> float | None:
    """Return run ``run``'s true mass over the file's ``mass_kg`` (None without a draw).

    ``mass_scale (1 + mass_rel_sd z)``, ``z`` the first standard normal of
    :func:`perturb_seed`.
    """
    sd = getattr(study, "mass_rel_sd", None)
    if sd is None:
        return None
    z = np.random.default_rng(perturb_seed(study.seed, run)).standard_normal()
    return float(study.scenario.manoeuvre.mass_scale * (1.0 + sd * z))


def run_scenario(study: Any, run: int) -> Any:
    """Return the scenario run ``run`` flies: the study's, its mass drawn when asked."""
    scale = run_mass_scale(study, run)
    if scale is None:
        return study.scenario
    scenario = study.scenario
    return dataclasses.replace(scenario, manoeuvre=dataclasses.replace(
        scenario.manoeuvre, mass_scale=scale))


def perturb_fields(study: Any, run: int) -> dict[str, float]:
    """Return a record's fields of the run's draw (``{}`` without ``[perturb]``)."""
    scale = run_mass_scale(study, run)
    if scale is None:
        return {}
    return {"mass_scale": scale,
            "mass_kg_flown": scale * float(study.scenario.airframe.mass_kg)}


def perturb_lines(records: Sequence[Mapping[str, Any]], study: Any) -> list[str]:
    """Return the report's section on the drawn masses (markdown lines; [] without them).

    One row per run: the drawn mass scale, the flown mass and its relative deviation from
    the scenario's; and a line comparing the draws' sd with the stated one.
    """
    sd = getattr(study, "mass_rel_sd", None)
    if sd is None:
        return []
    runs = sorted({int(r["run"]) for r in records if "mass_scale" in r})
    if not runs:
        return []
    scale = {int(r["run"]): float(r["mass_scale"]) for r in records if "mass_scale" in r}
    base = study.scenario.manoeuvre.mass_scale
    rel = np.array([scale[i] / base - 1.0 for i in runs])
    mass = float(study.scenario.airframe.mass_kg)
    given = getattr(study.scenario.airframe, "mass_sd_kg", None)
    lines = ["## The flown mass, drawn per run ([perturb])", "",
             f"Each run's truth flies mass_kg x {base:g} x (1 + {sd:g} z), z ~ N(0, 1) from "
             f"the run's seed; the estimators are told the file's {mass:g} kg"
             + (f" +- {given:g} kg." if given else " (no sd given)."),
             f"Over {len(runs)} runs: relative deviation mean {rel.mean():+.4f}, sd "
             f"{rel.std(ddof=1) if rel.size > 1 else math.nan:.4f} (stated {sd:g}).", "",
             "| run | mass scale [-] | flown mass [kg] | deviation [-] |", "|---|---|---|---|"]
    lines += [f"| {i} | {scale[i]:.5f} | {scale[i] * mass:.4f} | {r:+.4f} |"
              for i, r in zip(runs, rel, strict=True)]
    return [*lines, ""]


__all__ = ["MAX_MASS_REL_SD", "PERTURB_CHILD", "PERTURB_KEYS", "check_perturb",
           "perturb_fields", "perturb_lines", "perturb_seed", "run_mass_scale",
           "run_scenario"]
