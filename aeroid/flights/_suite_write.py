"""Writing a suite log: the log TOML and one CSV per group (:mod:`._suite_log` reads it).

Moved out of :mod:`._suite_log` unchanged (that module was at the 400-line limit).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from aeroid.errors import FlightError
from aeroid.flights._mounting import TRIADS, ZERO_ENTRY, unmount
from aeroid.flights._suite_log import SI_UNITS, SensorGroup, SuiteLog
from aeroid.model import save_airframe

__all__ = ["write_suite_log"]


def write_suite_log(log: SuiteLog, path: str | Path) -> list[Path]:
    """Write ``log`` as a log TOML at ``path`` with one CSV per group beside it (SI units).

    The CSVs are ``<stem>-<group>.csv`` with a ``t`` column [s] (logged time: true time
    minus the group's offset) and one column per channel, 17 significant digits; the
    airframe (if any) is ``<stem>-airframe.toml``. Returns the files written.
    """
    path = Path(path)
    if not path.parent.is_dir():
        raise FlightError(f"{path}: folder {path.parent} does not exist")
    written = []
    lines = []
    if log.airframe is not None:
        airframe_file = path.with_name(f"{path.stem}-airframe.toml")
        save_airframe(log.airframe, airframe_file)
        written.append(airframe_file)
        lines += ["[log]", f"airframe = {json.dumps(airframe_file.name)}", ""]
    for name, group in log.groups.items():
        file = path.with_name(f"{path.stem}-{name}.csv")
        logged = group.sensor_channels or unmount(group.channels, group.mounting)
        frame = pd.DataFrame({"t": group.t - group.offset_s, **logged})
        frame.to_csv(file, index=False, float_format="%.17g")
        written.append(file)
        lines += [f"[groups.{name}]", f"file = {json.dumps(file.name)}", 'time = ["t", "s"]',
                  f"offset_s = {float(group.offset_s)!r}"]  # numpy floats repr as np.float64()
        lines += [f"{key} = {float(value)!r}" for key, value in group.ranges.items()]
        if group.probe_position_m is not None:  # an air group's probe [m]
            lines += [f"probe_position_m = {json.dumps(list(group.probe_position_m))}"]
        lines += [f'temperature = "{group.temperature_of}"'] * ("temperature" in logged)
        lines += ["", f"[groups.{name}.columns]"]
        lines += [f'{c} = ["{c}", "{SI_UNITS[c]}"]' for c in logged] + [""]
        if group.mounting is not None:
            lines += [f"[groups.{name}.mounting]"]
            lines += [f"{k} = {json.dumps(v)}" for k, v in group.mounting.to_table().items()]
            lines += [""]
        # a noise-free simulation's sd of 0 is no statement (the reader takes sd > 0 only)
        sensor_sd = {c: sd for c, sd in _sensor_sd(group).items() if sd > 0}
        if sensor_sd:
            lines += [f"[groups.{name}.noise_sd]"]
            lines += [f"{c} = {float(sd)!r}" for c, sd in sensor_sd.items()] + [""]
    truth = log.metadata.get("truth") or {}
    if truth:
        lines += ["[truth]"] + [f"{k} = {json.dumps(_plain(v))}" for k, v in truth.items()]
    path.write_text("\n".join(lines) + "\n")
    return [path, *written]


def _sensor_sd(group: SensorGroup) -> dict[str, float]:
    """The noise sd of the logged (sensor-axis) channels.

    Unmounted, or mounted by an axis map: the sd of the body channel the sensor axis
    enters. A general rotation mixes them: one sd per triad, else refused.
    """
    if group.mounting is None:
        return dict(group.noise_sd)
    out: dict[str, float] = {}
    c = group.mounting.rotation
    for body, sd in group.noise_sd.items():
        for triad in TRIADS:
            if body in triad:
                i = triad.index(body)
                for j in np.flatnonzero(np.abs(c[i]) > ZERO_ENTRY):
                    if out.setdefault(triad[j], sd) != sd:
                        raise FlightError(f"{group.source}: cannot write the noise sd of "
                                          f"{triad[j]}: its body axes differ")
                break
        else:
            out[body] = sd
    return out


def _plain(value: Any) -> Any:
    """Return numbers and (nested) lists of numbers as Python floats (TOML-writable)."""
    return np.asarray(value, dtype=float).tolist()
