"""The Cramér-Rao floors of a study: per channel and per sample, with uncertain positions.

For every noise condition the runner computes two floors once (:func:`study_floors`),
stores them in ``floors.json`` beside the results, and the report reads them:

- **per-channel**: one noise level per channel (the RMS of that channel's noise), what
  an estimator that learns a constant diagonal noise covariance can exploit (output-
  error and the filters with ``noise_model = "channel"``, the PSO methods' ``noise``
  weighting, equation-error);
- **per-sample**: the noise variance of every sample, ``a_c + b_c yhat_kc^2`` (the
  paper's eq. 43: ``a = 0``, ``b = xi^2 / 3``; Gaussian noise: ``b = 0``), what the
  ``noise_model = "signal"`` estimators model (output-error, EKF, UKF).

Both are the output-error information matrix of :mod:`aeroid.estimation._floor` (the
same model, noise law and sensitivities as ``aeroid.cramer_rao_sd``), evaluated at the
truth on the scenario's noise-free flight (the flight of every run before its noise:
all runs share it), both triads and p, q, r, with the initial rates p, q, r as nuisance
parameters (every estimator starts from measured rates). When the noise model makes
the estimator's sensor positions uncertain (``NoiseModel.position_sd``: the paper's 10 %
error, a Gaussian ``position_sd_m``), the six position components are nuisance
parameters too, under their Gaussian prior (information ``1 / sd^2``): the floor of an
estimator that is told how uncertain the positions are, as the simulated flights tell
it (:func:`aeroid.flights.record_flight`). Their output sensitivities are central
differences of the same model's outputs (exact: the accelerometers are linear in the
positions). Noise-free conditions have no floor (an entry with the reason).

Under eq. 43 the per-sample floor rests on the samples near a zero crossing of a
channel, measured almost exactly; it is that sensitive: measured on the reference
flight (paper noise, uncertain positions), a 1e-3 relative change of the initial q, r
moves it by ~1 %, and with ``a_c`` floored at 1e-4 of the channel's mean variance (as
output-error's noise re-estimation does) it is 1.2-1.8x higher on every coefficient
but Cx (Clp 1.49 % against 0.92 % of truth). It is the bound, not a promise.
"""

from __future__ import annotations

import copy
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from aeroid.study._spec import Study
from aeroid.study._store import FLOORS_FILE, write_atomic

#: Initial-state components estimated with the coefficients (nuisance parameters).
FLOOR_NUISANCE_STATES = ("p", "q", "r")
#: Step of the position sensitivities [m] (the outputs are linear in the positions).
POSITION_STEP_M = 1e-3
#: The two floors: key, noise form of :func:`aeroid.estimation._floor.model_noise_sd`.
FLOOR_FORMS = {"per_channel": "homoscedastic", "per_sample": "heteroscedastic"}
#: Estimator ``noise_model`` option values whose fits can reach the per-sample floor.
PER_SAMPLE_NOISE_MODELS = ("signal",)


def noise_free_flight(study: Study) -> Any:
    """Return the scenario's flight without sensor noise (the truth every run records)."""
    from aeroid.flights import NoNoise, record_flight
    from aeroid.study._fits import scenario_truth

    s = study.scenario
    return record_flight(s.airframe, s.coefficient_vector, s.manoeuvre, scenario_truth(s),
                         NoNoise(), rng=0)


def position_sensitivities(airframe: Any, theta: np.ndarray, inputs: Any,
                           positions: np.ndarray, components: list[int]) -> np.ndarray:
    """Return ``d y_kc / d r_i`` of the listed position components, shape (n, n_outputs, m).

    ``components`` index ``[x1, y1, z1, x2, y2, z2]``; central differences of
    :func:`aeroid.estimation._floor.model_outputs` with a step of :data:`POSITION_STEP_M`.
    """
    from aeroid.estimation import model_outputs

    columns = []
    for c in components:
        step = np.zeros(6)
        step[c] = POSITION_STEP_M
        up = model_outputs(airframe, theta, inputs, positions=positions + step.reshape(2, 3))
        down = model_outputs(airframe, theta, inputs, positions=positions - step.reshape(2, 3))
        columns.append((up - down) / (2.0 * POSITION_STEP_M))
    from aeroid.model import OUTPUT_CHANNELS

    if not columns:
        return np.zeros((len(inputs.delta), len(OUTPUT_CHANNELS), 0))
    return np.stack(columns, axis=-1)


def floors_of(flight: Any, noise: Any) -> dict[str, Any]:
    """Return both floors of a noise-free ``flight`` under ``noise`` (JSON-ready).

    Returns
    -------
    dict
        ``per_channel`` and ``per_sample``: Cramér-Rao sd of the nine coefficients
        (:data:`aeroid.model.NAMES` order, coefficient units); ``position_sd_m``: the
        prior sd of the six position components (2 x 3 [m], zeros when known);
        ``nuisance``: the other estimated parameters.
    """
    from aeroid.estimation import (
        coefficient_information,
        information_from_sensitivities,
        inputs_from_flight,
        model_noise_sd,
        model_outputs,
        output_sensitivities,
    )

    theta = np.asarray(flight.true_coefficients, dtype=float)
    positions = np.asarray(flight.metadata["true_accel_positions_m"], dtype=float)
    inputs = inputs_from_flight(flight)
    outputs = model_outputs(flight.airframe, theta, inputs, positions=positions)
    position_sd = np.asarray(noise.position_sd(positions), dtype=float).reshape(-1)
    uncertain = [int(c) for c in np.flatnonzero(position_sd > 0)]
    jac = output_sensitivities(flight.airframe, theta, inputs, positions=positions,
                                      estimate_initial=FLOOR_NUISANCE_STATES)
    jac = np.concatenate([jac, position_sensitivities(flight.airframe, theta, inputs,
                                                      positions, uncertain)], axis=-1)
    out: dict[str, Any] = {"position_sd_m": position_sd.reshape(2, 3).tolist(),
                           "nuisance": [f"{s}0" for s in FLOOR_NUISANCE_STATES]}
    for key, form in FLOOR_FORMS.items():
        sd = model_noise_sd(noise, outputs, noise_form=form)
        info = information_from_sensitivities(jac, sd)
        first = info.shape[0] - len(uncertain)
        info[first:, first:] += np.diag(1.0 / position_sd[uncertain] ** 2)  # the prior
        cov = np.linalg.inv(coefficient_information(info))
        out[key] = np.sqrt(np.diag(cov)).tolist()
    return out


#: Why a sensor-suite condition has no floor.
SUITE_NO_FLOOR = ("a sensor-suite log: its IMU errors, its rate and the reconstruction's "
                  "initial state are not in the floor's model")

#: Floors computed in this process: (scenario key, noise settings) -> floors_of(...).
_CACHE: dict[tuple[str, str], dict[str, Any]] = {}


#: Why a turbulent scenario has no floor.
TURBULENCE_NO_FLOOR = ("turbulence: every run flies its own gusts, so there is no common "
                       "noise-free flight to compute a floor on")


def study_floors(study: Study) -> dict[str, Any]:
    """Return the floors of every noise condition (what ``floors.json`` holds).

    Returns
    -------
    dict
        ``fingerprint`` (the design's), ``description`` (how they were computed) and
        ``conditions``: one entry per noise condition with ``label`` and either the
        fields of :func:`floors_of` or ``reason`` (why there is no floor, e.g. no noise).
    """
    from aeroid.study._fits import scenario_key, turbulent
    from aeroid.study._tables import TABLES_NO_FLOOR, has_tables

    flight = None
    conditions = []
    for cond in study.noise:
        if turbulent(study.scenario):  # every run's truth is its own
            conditions.append({"label": cond.label, "reason": TURBULENCE_NO_FLOOR})
            continue
        if cond.suite is not None or has_tables(study):
            conditions.append({"label": cond.label, "reason": SUITE_NO_FLOOR if
                               cond.suite is not None else TABLES_NO_FLOOR})
            continue
        key = (scenario_key(study.scenario), json.dumps(cond.model.to_dict(), sort_keys=True))
        if key not in _CACHE:
            flight = noise_free_flight(study) if flight is None else flight
            try:
                _CACHE[key] = floors_of(flight, cond.model)
            except Exception as exc:  # a floor is an extra: never let it stop a study
                _CACHE[key] = {"reason": " ".join(f"{type(exc).__name__}: {exc}".split())}
        conditions.append({"label": cond.label, **copy.deepcopy(_CACHE[key])})
    return {"fingerprint": study.fingerprint(), "description": FLOOR_DESCRIPTION,
            "conditions": conditions}


def write_floors(out_dir: str | Path, floors: Mapping[str, Any]) -> None:
    """Write ``floors.json`` (atomically)."""
    write_atomic(Path(out_dir) / FLOORS_FILE, (json.dumps(floors, indent=2) + "\n").encode())


def read_floors(out_dir: str | Path, fingerprint: str) -> dict[str, Any] | None:
    """Return the stored floors of the design ``fingerprint``, or None.

    None when ``floors.json`` is missing, unreadable, not JSON, of another design or
    without a ``conditions`` list (the caller computes them again).
    """
    try:
        data = json.loads((Path(out_dir) / FLOORS_FILE).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    if (not isinstance(data, dict) or data.get("fingerprint") != fingerprint
            or not isinstance(data.get("conditions"), list)):
        return None
    return data


def reachable_floor(options: dict[str, Any]) -> str:
    """Return ``"per_sample"`` or ``"per_channel"``: the floor an estimator can reach.

    ``options`` are its options in use (``study.json``): a ``noise_model`` of ``signal``
    models every sample's variance; every other estimator weights by one level per
    channel at best.
    """
    return ("per_sample" if options.get("noise_model") in PER_SAMPLE_NOISE_MODELS
            else "per_channel")


# --------------------------------------------------------------------------------------
# For the report
# --------------------------------------------------------------------------------------
FLOOR_NAMES = {"per_channel": "per-channel", "per_sample": "per-sample"}


def report_floors(study: Study, out_dir: Path) -> tuple[dict[str, dict[str, Any]], str]:
    """Return noise label -> floors entry (:func:`study_floors`) of a study's folder.

    Read from ``floors.json``; computed here when it is missing or of another design.
    The second value says where they come from.
    """
    stored = read_floors(out_dir, study.fingerprint())
    where = "floors.json"
    if stored is None:
        stored, where = study_floors(study), "computed for this report (no valid floors.json)"
    return {c.get("label"): c for c in stored["conditions"]}, where


def reachable_floors(study: Study) -> dict[str, str]:
    """Estimator label -> the floor it can reach (``per_channel`` or ``per_sample``)."""
    return {e["label"]: reachable_floor(e["options"]) for e in study.describe()["estimators"]}


def floor_paragraph(entry: Mapping[str, Any] | None, where: str,
                    reach: Mapping[str, str]) -> list[str]:
    """Return the report's floors paragraph of one noise condition (markdown lines)."""
    if entry is None or "per_channel" not in entry:
        why = "not computed" if entry is None else entry.get("reason", "not computed")
        return [f"Cramér-Rao floors: no floor for this condition ({why}).", ""]
    sd = np.asarray(entry.get("position_sd_m", np.zeros((2, 3))), dtype=float)
    positions = (f"{int(np.sum(sd > 0))} accelerometer-position components uncertain "
                 f"(prior sd {1e3 * sd[sd > 0].min():.3g}-{1e3 * sd.max():.3g} mm), "
                 "estimated with the coefficients under that prior" if np.any(sd > 0)
                 else "sensor positions known")
    reaches = "; ".join(f"{label}: {FLOOR_NAMES[key]}"
                        + (" (noise_model = signal)" if key == "per_sample" else "")
                        for label, key in reach.items())
    return [f"Cramér-Rao floors ({where}): per-channel (one noise level per channel) and "
            "per-sample (each sample's noise variance a_c + b_c yhat^2), at the truth with "
            f"the initial rates estimated; {positions}.", "",
            f"Floor each estimator can reach: {reaches}.", ""]


def floor_pct(entry: Mapping[str, Any] | None, key: str, truth: np.ndarray) -> np.ndarray:
    """One floor of an entry in % of |truth| (NaN when there is none), shape (9,)."""
    if entry is None or key not in entry:
        return np.full(truth.size, np.nan)
    return np.asarray(entry[key], dtype=float) / np.abs(truth) * 100.0


FLOOR_DESCRIPTION = (
    "output-error information matrix at the truth (aeroid.estimation._floor: both triads "
    "and p, q, r, noise-free flight of the scenario), initial p, q, r estimated; "
    "per-channel: one noise level per channel (its RMS); per-sample: each sample's noise "
    "variance a_c + b_c yhat^2; uncertain sensor positions estimated under their Gaussian "
    "prior when the noise model has a position error")


__all__ = ["FLOOR_DESCRIPTION", "FLOOR_FORMS", "floor_paragraph", "floor_pct", "floors_of",
           "noise_free_flight", "position_sensitivities", "reachable_floor",
           "reachable_floors", "read_floors", "report_floors", "study_floors", "write_floors"]
