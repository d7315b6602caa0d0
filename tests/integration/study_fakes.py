"""Cheap stand-in estimators for the study-store tests, and a script that runs a study
and kills itself (SIGKILL) at a chosen point.

Run as ``python study_fakes.py OUT_DIR KILL_POINT [--jobs N] [--runs N] [--resume]``:
KILL_POINT is ``none``, ``fit:N`` (SIGKILL before the N-th fit starts),
``history:N`` (after the N-th history file is on disk, before its record),
``record:N`` (after half of the N-th record line is written) or ``tmp:N`` (after
half of the N-th history's temporary file is written). The kills are real: the
process ends with signal 9 in the middle of the store's work, as a ``kill -9`` or the
out-of-memory killer would end it. The hooks wrap the store's own functions in this
script only; nothing in aeroid knows about them.
"""

from __future__ import annotations

import os
import signal
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from aeroid import EstimationResult, Estimator

STUDY = """
[study]
name = "store"
runs = 3
seed = 11

[[noise]]
label = "paper"
model = "paper"

[[noise]]
label = "gauss"
model = "gaussian"

[[estimators]]
label = "J1"
method = "jitter"

[[estimators]]
label = "J2"
method = "jitter"
options = { scale = 0.02 }
"""


#: Record fields that differ between equal runs (timing, worker id).
VOLATILE = ("wall_time_s", "compile_time_s", "worker")


def stable(records):
    """Records without :data:`VOLATILE` fields, in (run, noise, estimator) order."""
    return sorted(({k: v for k, v in r.items() if k not in VOLATILE} for r in records),
                  key=lambda r: (r["run"], r["noise"], r["estimator"]))


def _die() -> None:
    os.kill(os.getpid(), signal.SIGKILL)


@dataclass(frozen=True, kw_only=True)
class Jitter(Estimator):
    """Prior x (1 + scale N(0, 1)) plus a term from the flight's data; a short history."""

    name: ClassVar[str] = "jitter"
    scale: float = 0.01

    def run(self, flight, rng):
        prior = flight.airframe.prior_vector()
        data = 1e-3 * np.mean(flight["ax1"]) + 1e-4 * np.mean(flight["p"])
        theta = prior * (1.0 + self.scale * rng.standard_normal(prior.size)) + data
        steps = np.arange(4)
        return EstimationResult(
            estimator=self.name, theta=theta, stderr=np.abs(prior) * self.scale,
            cost=float(data**2), n_evaluations=7, n_iterations=4,
            history={"axis": "iteration", "step": steps,
                     "theta": theta + 0.1 * (3 - steps)[:, None], "cost": 1.0 / (1.0 + steps)})


@dataclass(frozen=True, kw_only=True)
class Killer(Jitter):
    """A Jitter whose process dies (SIGKILL) on some fits.

    It draws u ~ U(0, 1) from its rng first (the same u for every estimator of a run)
    and dies when ``u < victim_below``; with a ``marker`` file it dies only in the
    process that creates the marker (once in the whole study).
    """

    name: ClassVar[str] = "killer"
    victim_below: float = 1.0
    marker: str = ""

    def run(self, flight, rng):
        u = rng.random()
        if u < self.victim_below:
            if not self.marker:
                _die()
            try:
                os.close(os.open(self.marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
                _die()
            except FileExistsError:
                pass
        return super().run(flight, rng)


@dataclass(frozen=True, kw_only=True)
class Echo(Estimator):
    """Returns the prior it was given (``flight.airframe.prior_vector()``) and a draw."""

    name: ClassVar[str] = "echo"

    def run(self, flight, rng):
        prior = flight.airframe.prior_vector()
        return EstimationResult(estimator=self.name, theta=prior, stderr=np.abs(prior) * 0.1,
                                cost=float(rng.random()), n_evaluations=1, n_iterations=1)


REGISTRY = {"jitter": Jitter, "killer": Killer, "echo": Echo}


def _install(point: str) -> None:
    """Wrap one of the store's functions so the process SIGKILLs itself at ``point``."""
    from aeroid.study import _executors, _histories, _runner, _store

    if point == "none":
        return
    what, n = point.split(":")
    target = int(n)
    calls = {"n": 0}

    def hit() -> bool:
        calls["n"] += 1
        return calls["n"] == target

    if what == "fit":
        original = _executors.fit_task

        def fit(study, task):
            if hit():
                _die()
            return original(study, task)

        _executors.fit_task = fit
    elif what == "history":
        original_save = _runner.save_history

        def save(out_dir, name, history):
            original_save(out_dir, name, history)
            if hit():
                _die()

        _runner.save_history = save
    elif what == "record":
        original_write = _store._write_all

        def write(fd, data):
            if data.startswith(b'{"run"') and hit():
                os.write(fd, data[:len(data) // 2])
                _die()
            original_write(fd, data)

        _store._write_all = write
    elif what == "tmp":
        def savez(path, arrays):
            if hit():
                path.write_bytes(b"PK\x03\x04 half a zip file")
                _die()
            original_savez(path, arrays)

        original_savez = _histories._savez
        _histories._savez = savez
    else:
        raise SystemExit(f"unknown kill point {point!r}")


def main(argv: list[str]) -> int:
    """Run the STUDY into argv[0] with the kill point argv[1]."""
    from aeroid.study import loads_study, run_study

    out, point = Path(argv[0]), argv[1]
    jobs = int(argv[argv.index("--jobs") + 1]) if "--jobs" in argv else 1
    study = loads_study(STUDY, registry=REGISTRY)
    if "--runs" in argv:
        study = study.with_runs(int(argv[argv.index("--runs") + 1]))
    _install(point)
    run_study(study, out, jobs=jobs, resume="--resume" in argv, progress=False)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
