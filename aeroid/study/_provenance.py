"""Which code computed a study's numbers: aeroid's version, a hash of its source, key packages.

A study's results depend on its design (:meth:`aeroid.study.Study.fingerprint`) and on
the code that ran it. :func:`code_identity` describes the code: the aeroid version, a
SHA-256 of every ``.py`` file of the ``aeroid`` and ``baselines`` packages as
installed (path and content, so an edited checkout with an unchanged version number is
told apart) and of the modules that define the study's estimator classes (plug-ins
included), the Python version and the versions of the packages that decide the numbers
(:data:`KEY_PACKAGES`). The runner writes it into ``study.json`` and stamps each record
with its short form (:func:`code_id`), so results of two code versions are never
mixed silently: ``--resume`` under other code refuses, and a Dask worker running other
code stops the study.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import inspect
import platform
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from aeroid._version import __version__

#: Distributions whose versions can change a study's numbers (the numerical stack, the
#: JIT compiler and the baselines' libraries). ``None`` stands for "not installed".
KEY_PACKAGES = ("aeroid-toolkit", "numpy", "scipy", "numba", "llvmlite", "pandas",
                "casadi", "filterpy", "pyswarms")
#: Packages whose source is hashed (importable names).
SOURCE_PACKAGES = ("aeroid", "baselines")


def package_versions(names: Iterable[str] = KEY_PACKAGES) -> dict[str, str | None]:
    """Return ``{distribution: version or None}`` of the installed distributions."""
    out: dict[str, str | None] = {}
    for name in names:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = None
    return out


def _package_files(package: str) -> list[tuple[str, Path]]:
    try:
        module = __import__(package)
    except ImportError:
        return []
    root = Path(inspect.getfile(module)).parent
    return [(f"{package}/{p.relative_to(root).as_posix()}", p)
            for p in sorted(root.rglob("*.py"))]


@functools.lru_cache(maxsize=8)
def source_hash(extra_files: tuple[str, ...] = ()) -> str:
    """Return the SHA-256 (hex, 16 characters) of aeroid's and the baselines' source.

    Parameters
    ----------
    extra_files : tuple of str
        Further source files to include (the modules of plug-in estimators).
    """
    digest = hashlib.sha256()
    files = [f for package in SOURCE_PACKAGES for f in _package_files(package)]
    files += [(Path(f).name, Path(f)) for f in sorted(set(extra_files))
              if not any(Path(f) == p for _, p in files)]
    for name, path in files:
        digest.update(name.encode() + b"\0")
        try:
            digest.update(path.read_bytes())
        except OSError:
            digest.update(b"<unreadable>")
        digest.update(b"\0")
    return digest.hexdigest()[:16]


def estimator_sources(classes: Iterable[type]) -> tuple[str, ...]:
    """Return the source files of estimator classes defined outside aeroid and baselines."""
    out = []
    for cls in classes:
        try:
            path = inspect.getsourcefile(cls)
        except TypeError:
            continue
        if path and Path(path).is_file():
            out.append(str(Path(path).resolve()))
    return tuple(sorted(set(out)))


@functools.lru_cache(maxsize=1)
def cpu_name() -> str:
    """Return the CPU that numba compiles for (LLVM's name, e.g. ``znver3``), or ``?``.

    The RK4 kernel is compiled with fast-math (fused multiply-add, reassociation), so
    its last bits depend on the instruction set, and EAM-PSO's search amplifies them
    into different estimates (measured: a generic x86-64 target and an AMD ``znver3``
    give different simulated flights and EAM-PSO answers on the same run; compiled
    without fast-math they agree to the bit). Recorded, not compared: the CPU explains
    digits, it does not make a study wrong.
    """
    try:
        import llvmlite.binding as llvm

        return f"{platform.machine()} {llvm.get_host_cpu_name()}"
    except Exception:  # llvmlite missing or too old: the numbers do not use it then
        return f"{platform.machine()} ?"


def code_identity(estimator_classes: Iterable[type] = ()) -> dict[str, Any]:
    """Return the description of the running code (JSON-ready).

    Keys: ``aeroid`` (version), ``source`` (:func:`source_hash`), ``python``,
    ``platform``, ``cpu`` (:func:`cpu_name`), ``packages`` (:func:`package_versions`)
    and ``id`` (:func:`code_id`: version, source and packages, not the CPU).
    """
    source = source_hash(estimator_sources(estimator_classes))
    packages = package_versions()
    return {"aeroid": __version__, "source": source,
            "python": platform.python_version(), "platform": sys.platform,
            "cpu": cpu_name(), "packages": packages,
            "id": _short(__version__, source, packages)}


def _short(version: str, source: str, packages: dict[str, str | None]) -> str:
    text = "|".join([version, source, *(f"{k}={v}" for k, v in sorted(packages.items()))])
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def code_id(estimator_classes: Iterable[type] = ()) -> str:
    """Return the 12-character identity of the running code (stamped on each record)."""
    return str(code_identity(estimator_classes)["id"])


def code_differences(old: dict[str, Any], new: dict[str, Any]) -> list[str]:
    """Return what differs between two :func:`code_identity` dicts, as short phrases."""
    out = []
    for key in ("aeroid", "source", "python"):
        if old.get(key) != new.get(key):
            out.append(f"{key} {old.get(key)} -> {new.get(key)}")
    old_p, new_p = old.get("packages") or {}, new.get("packages") or {}
    for name in sorted(set(old_p) | set(new_p)):
        if old_p.get(name) != new_p.get(name):
            out.append(f"{name} {old_p.get(name)} -> {new_p.get(name)}")
    return out


__all__ = ["KEY_PACKAGES", "code_differences", "code_id", "code_identity", "cpu_name",
           "estimator_sources", "package_versions", "source_hash"]
