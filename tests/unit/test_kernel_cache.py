"""numba's disk cache follows an edit of the equations the kernels inline.

numba stamps a cached kernel with its defining file only; aeroid's kernels inline
:mod:`aeroid.model._equations`, so their cache is also stamped with the hash of every
inlined source (:func:`aeroid.model._compiled.cached_kernel`). Checked on a copy of the
package: warm the cache, double the axial-force term in the copy's equations, run again in
a new process; the compiled kernel must give the edited numpy path's numbers.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import aeroid
from aeroid.model import HAVE_NUMBA

#: numba (fast-math) versus numpy through a short record: rounding only (the backends
#: agree to 1e-12 of each channel's range, tests/unit/test_integrate.py). A stale kernel
#: differs by ~10 m/s (measured on main before this fix: 9.8).
BACKEND_RTOL = 1e-12
#: Seconds for one subprocess: compiling the serial RK4 kernel from nothing (~30 s on a
#: shared 2-core machine), with room.
COMPILE_TIMEOUT_S = 600

_PROBE = """
import json, numpy as np
from aeroid.model import STATE_NAMES, constants, nominal, propagate, reference_airframe
from aeroid.model import _compiled
const = constants(reference_airframe())
x0 = np.zeros(len(STATE_NAMES))
x0[0] = 200.0
delta = np.full(200, 0.02)
fast = propagate(x0, nominal(), delta, 0.01, const, backend="numba", parallel=False)
slow = propagate(x0, nominal(), delta, 0.01, const, backend="numpy")
scale = np.max(np.abs(slow), axis=(0, 1))
scale = np.where(scale > 0, scale, 1.0)
hits = sum(_compiled.propagate_serial.stats.cache_hits.values())
print(json.dumps({"error": float(np.max(np.abs(fast - slow) / scale)),
                  "u_end": float(slow[0, -1, 0]), "cached": hits > 0,
                  "sources": [p.split("aeroid")[-1] for p in _compiled.INLINED_SOURCES]}))
"""

#: The axial force of eq. 2 as written in the equations, and the edit applied to the copy.
AXIAL = "        qs * c.Cx,\n"
AXIAL_DOUBLED = "        2.0 * qs * c.Cx,\n"


def _run(root: Path, cache_dir: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(root), "NUMBA_CACHE_DIR": str(cache_dir)}
    done = subprocess.run([sys.executable, "-c", _PROBE], cwd=root, env=env, text=True,
                          capture_output=True, timeout=COMPILE_TIMEOUT_S, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")
def test_an_edit_of_the_equations_recompiles_the_cached_kernels(tmp_path):
    package = Path(aeroid.__file__).parent
    shutil.copytree(package, tmp_path / "aeroid",
                    ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    cache_dir = tmp_path / "numba-cache"
    before = _run(tmp_path, cache_dir)
    assert before["error"] < BACKEND_RTOL
    assert not before["cached"]
    # the cache is warm: a second process loads the kernels
    warm = _run(tmp_path, cache_dir)
    assert warm["cached"] and warm["error"] < BACKEND_RTOL
    assert any(s.endswith("_equations.py") for s in warm["sources"])

    equations = tmp_path / "aeroid" / "model" / "_equations.py"
    text = equations.read_text()
    assert text.count(AXIAL) == 1, "the axial-force line moved: update this test's edit"
    equations.write_text(text.replace(AXIAL, AXIAL_DOUBLED))

    after = _run(tmp_path, cache_dir)
    assert not after["cached"]  # the stamp no longer matches: compiled anew
    # the edit changed the physics (the numpy path) and the kernel followed it
    assert abs(after["u_end"] - before["u_end"]) > 1.0
    assert after["error"] < BACKEND_RTOL
    # the recompiled kernels overwrote their cache files: nothing accumulates
    files = sorted(p.name for p in cache_dir.rglob("*.nbc"))
    assert len(files) == len(set(files))
    assert all(".1.nbc" in name for name in files), files
