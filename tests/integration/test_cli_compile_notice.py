"""The compile notice: said only when a command compiles, naming what and how long.

numba announces a real compilation (not a load from its disk cache) with a
``numba:compile`` event; the command line listens for the whole command
(:func:`aeroid.model.compile_clock`) and prints one line as a compilation starts and one
with its measured time as it ends. A command whose kernels are all cached says nothing.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time

import pytest

from aeroid.cli import _simulate
from aeroid.cli import main as cli_main
from aeroid.model import HAVE_NUMBA

pytestmark = pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")

CLI = [sys.executable, "-c", "import sys; from aeroid.cli import main; sys.exit(main())"]
#: Seconds for one `aeroid simulate` that compiles the serial RK4 kernel from nothing
#: (~12 s of CPU, measured; the machine is shared), with room.
COMPILE_TIMEOUT_S = 600
TIMED = re.compile(r"^aeroid: compiled (\w+) in ([0-9.]+) s$", re.MULTILINE)


def _simulate_in(cache_dir, out):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache_dir)}
    return subprocess.run([*CLI, "simulate", "--seed", "1", "-o", str(out)], env=env,
                          capture_output=True, text=True, timeout=COMPILE_TIMEOUT_S,
                          check=False)


# Two whole processes compiling numba's kernels from an empty disk cache: 26 s of the
# fast suite's time, which a fresh clone's .ci/run had brought to 902 s (limit 15 min);
# the notice's wording stays fast below (test_a_command_names_the_function_it_compiles)
@pytest.mark.slow
def test_a_fresh_cache_compiles_once_and_says_so_then_never_again(tmp_path):
    first = _simulate_in(tmp_path / "cache", tmp_path / "a.csv")
    assert first.returncode == 0, first.stderr
    # the simulator integrates one coefficient set: the serial kernel, nothing else
    assert "aeroid: compiling the numba kernel propagate_serial (once: cached on disk " \
           "for later runs)" in first.stderr
    ((name, seconds),) = TIMED.findall(first.stderr)
    assert name == "propagate_serial" and float(seconds) > 0.5
    second = _simulate_in(tmp_path / "cache", tmp_path / "b.csv")
    assert second.returncode == 0, second.stderr
    assert "compil" not in second.stderr  # loaded from the disk cache: no notice
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


def test_a_command_names_the_function_it_compiles(tmp_path, capsys, monkeypatch):
    import numba

    def probe_kernel(x):
        return 3.0 * x

    probe = numba.njit(probe_kernel)  # a new dispatcher: its first call compiles
    original = _simulate.simulate

    def simulate(args):
        assert probe(2.0) == 6.0
        return original(args)

    monkeypatch.setattr(_simulate, "simulate", simulate)
    assert cli_main(["simulate", "--seed", "1", "-o", str(tmp_path / "f.csv")]) == 0
    err = capsys.readouterr().err
    assert "aeroid: compiling the numba kernel probe_kernel (once" in err
    assert [name for name, _ in TIMED.findall(err)] == ["probe_kernel"]
    # compiled in memory now: the same command says nothing
    assert cli_main(["simulate", "--seed", "1", "-o", str(tmp_path / "g.csv")]) == 0
    assert "compil" not in capsys.readouterr().err


def test_quiet_drops_the_notice(tmp_path, capsys, monkeypatch):
    import numba

    from aeroid.cli import _estimate

    flight = tmp_path / "f.csv"
    assert cli_main(["simulate", "--seed", "1", "-o", str(flight)]) == 0
    capsys.readouterr()
    probe = numba.njit(lambda x: x + 1.0)
    original = _estimate.estimate
    monkeypatch.setattr(_estimate, "estimate", lambda args: (probe(1.0), original(args))[1])
    assert cli_main(["estimate", str(flight), "--method", "equation-error", "--json",
                     "--quiet"]) in (0, 1)
    assert "compil" not in capsys.readouterr().err


def test_a_build_announced_by_aeroid_is_named_and_timed(tmp_path, capsys, monkeypatch):
    from aeroid.model import compiling

    original = _simulate.simulate

    def simulate(args):
        with compiling("the C model"):
            time.sleep(0.2)
        return original(args)

    monkeypatch.setattr(_simulate, "simulate", simulate)
    assert cli_main(["simulate", "--seed", "1", "-o", str(tmp_path / "f.csv")]) == 0
    err = capsys.readouterr().err
    assert "aeroid: compiling the C model (once: cached on disk for later runs)" in err
    (seconds,) = re.findall(r"aeroid: compiled the C model in ([0-9.]+) s", err)
    assert 0.2 <= float(seconds) < 5.0


def test_the_c_model_build_is_named_timed_and_left_out_once_cached(tmp_path, monkeypatch):
    """Output-error's one-time C compile announces itself (:func:`compiling`): the
    compile clock a study runs each fit under counts it as compile time, not fit time."""
    import casadi as ca
    import numpy as np

    from aeroid.model import compile_clock, symbolic

    if not (os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")):
        pytest.skip("no C compiler: CasADi's virtual machine is used")
    monkeypatch.setenv("AEROID_CASADI_CACHE", str(tmp_path / "casadi"))
    x = ca.SX.sym("x", 3)
    function = ca.Function("probe_c", [x], [ca.sin(x) * ca.sumsqr(x)])
    lines = []
    with compile_clock(lines.append) as clock:
        (built,) = symbolic.compile_functions([function], "aeroid_probe")
    ((name, seconds),) = clock.compiled
    assert name == "the C model" and seconds > 0.0
    assert lines == ["compiling the C model (once: cached on disk for later runs)",
                     f"compiled the C model in {seconds:.1f} s"]
    point = np.array([0.3, -1.2, 2.0])  # the library computes what CasADi's VM computes
    np.testing.assert_allclose(np.asarray(built(point)).ravel(),
                               np.sin(point) * np.sum(point**2), rtol=1e-14)
    with compile_clock() as again:  # from the disk cache: nothing compiles
        assert symbolic.compile_functions([function], "aeroid_probe") is not None
    assert again.compiled == []
