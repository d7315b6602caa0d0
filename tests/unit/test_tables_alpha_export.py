"""Export of tables in the total angle of attack: CSV, a JSBSim fragment JSBSim evaluates."""

from __future__ import annotations

import io
import math

import numpy as np
import pandas as pd
import pytest

from aeroid.model import tables as mach_tables
from aeroid.report import fitted_tables, jsbsim_fragment, tables_csv, tables_figure

NAMES = ("Cx@M1.1", "Cx@M2.2", "Cza", "Cma@A0deg", "Cma@A1.5deg", "Cma@A4deg", "Cmq")
THETA = np.array([-1.1, -0.8, -11.8, -30.0, -33.0, -40.0, -2227.0])
STDERR = np.abs(THETA) * 0.01
ALPHA_KNOTS_RAD = np.radians([0.0, 1.5, 4.0])
#: JSBSim evaluates its trigonometric functions in double precision: the total angle's
#: two formulas (JSBSim's from alpha and beta, numpy's from u, v, w) agree to rounding.
ANGLE_TOL_RAD = 1e-12

#: The smallest aircraft JSBSim loads (tests/unit/test_tables_export.py's).
AIRCRAFT = """<?xml version="1.0"?>
<fdm_config name="tables" version="2.0" release="ALPHA">
  <metrics>
    <wingarea unit="FT2"> 1.0 </wingarea> <wingspan unit="FT"> 1.0 </wingspan>
    <chord unit="FT"> 1.0 </chord>
    <location name="AERORP" unit="IN"> <x> 0 </x> <y> 0 </y> <z> 0 </z> </location>
  </metrics>
  <mass_balance>
    <ixx unit="SLUG*FT2"> 1 </ixx> <iyy unit="SLUG*FT2"> 10 </iyy>
    <izz unit="SLUG*FT2"> 10 </izz> <emptywt unit="LBS"> 100 </emptywt>
    <location name="CG" unit="IN"> <x> 0 </x> <y> 0 </y> <z> 0 </z> </location>
  </mass_balance>
  <ground_reactions/>
  <propulsion/>
  <aerodynamics>
FRAGMENT
  </aerodynamics>
</fdm_config>
"""


def test_fitted_tables_and_csv_carry_the_angle_in_degrees():
    tables = fitted_tables(NAMES, THETA, STDERR)
    assert [(t.name, t.variable) for t in tables] == [("Cx", "mach"), ("Cma", "alpha")]
    np.testing.assert_allclose(tables[1].mach, [0.0, 1.5, 4.0], atol=1e-12)
    frame = pd.read_csv(io.StringIO(tables_csv(tables)))
    assert list(frame.columns) == ["coefficient", "mach", "alpha_deg", "value", "stderr",
                                   "low95", "high95"]
    row = frame.iloc[3]
    assert (row["coefficient"], row["alpha_deg"], row["value"]) == ("Cma", 1.5, -33.0)
    assert math.isnan(row["mach"]) and math.isnan(frame.iloc[0]["alpha_deg"])
    fig = tables_figure(tables)
    assert fig.get_axes()[1].get_xlabel() == "total angle of attack [deg]"


def test_jsbsim_loads_the_angle_table_and_evaluates_it(tmp_path):
    jsbsim = pytest.importorskip("jsbsim")
    folder = tmp_path / "aircraft" / "tables"
    folder.mkdir(parents=True)
    fragment = jsbsim_fragment(fitted_tables(NAMES, THETA, STDERR))
    (folder / "tables.xml").write_text(AIRCRAFT.replace("FRAGMENT", fragment))
    fdm = jsbsim.FGFDMExec(str(tmp_path), None)
    fdm.set_debug_level(0)
    assert fdm.load_model("tables")
    seen = []
    for alpha_deg, beta_deg in ((0.0, 0.0), (0.7, 0.0), (-1.0, 0.8), (2.0, -2.0),
                                (3.5, 1.0), (6.0, 3.0)):  # beyond the last knot too
        fdm["ic/h-sl-ft"] = 10000.0
        fdm["ic/mach"] = 1.6
        fdm["ic/alpha-deg"] = alpha_deg
        fdm["ic/beta-deg"] = beta_deg
        fdm.run_ic()
        u, v, w = (fdm[f"velocities/{c}-aero-fps"] for c in "uvw")
        total = math.atan2(math.hypot(v, w), u)  # the model's definition, a second formula
        assert fdm["aero/function/alpha_total_rad"] == pytest.approx(total, abs=ANGLE_TOL_RAD)
        want = mach_tables.table_value(np.array(total), tuple(ALPHA_KNOTS_RAD), THETA[3:6])
        assert fdm["aero/coefficient/Cma_alpha"] == pytest.approx(float(want), rel=1e-12)
        cx = mach_tables.table_value(np.array(fdm["velocities/mach"]), (1.1, 2.2), THETA[:2])
        assert fdm["aero/coefficient/Cx_mach"] == pytest.approx(float(cx), rel=1e-12)
        seen.append(total)
    assert max(seen) > ALPHA_KNOTS_RAD[-1] and min(seen) == pytest.approx(0.0, abs=1e-12)
