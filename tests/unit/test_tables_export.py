"""Export of fitted coefficient tables: CSV, a JSBSim fragment JSBSim evaluates, a figure."""

from __future__ import annotations

import io

import numpy as np
import pandas as pd
import pytest

from aeroid.errors import EstimatorError
from aeroid.model import tables as mach_tables
from aeroid.report import fitted_tables, jsbsim_fragment, tables_csv, tables_figure

NAMES = ("Cx@M1.1", "Cx@M1.6", "Cx@M2.2", "Cza", "Cmq@M1.2", "Cmq@M2")
THETA = np.array([-1.1, -0.95, -0.8, -11.8, -2500.0, -1900.0])
STDERR = np.abs(THETA) * 0.01

#: The smallest aircraft JSBSim loads: the fragment goes into its <aerodynamics>.
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


def test_fitted_tables_read_the_points_back():
    tables = fitted_tables(NAMES, THETA, STDERR)
    assert [t.name for t in tables] == ["Cx", "Cmq"]
    np.testing.assert_array_equal(tables[0].mach, [1.1, 1.6, 2.2])
    np.testing.assert_array_equal(tables[1].value, [-2500.0, -1900.0])
    with pytest.raises(EstimatorError, match="no table points"):
        fitted_tables(("Cx", "Cza"), THETA[:2], STDERR[:2])


def test_csv_has_every_point_with_its_interval_and_floor():
    floor = STDERR * 0.9
    frame = pd.read_csv(io.StringIO(tables_csv(fitted_tables(NAMES, THETA, STDERR, floor))))
    assert list(frame.columns) == ["coefficient", "mach", "value", "stderr", "low95", "high95",
                                   "floor"]
    assert len(frame) == 5
    row = frame.iloc[1]
    assert (row["coefficient"], row["mach"], row["value"]) == ("Cx", 1.6, -0.95)
    assert row["high95"] - row["low95"] == pytest.approx(2 * 1.96 * 0.0095)
    assert row["floor"] == pytest.approx(0.9 * 0.0095)


def test_jsbsim_loads_the_fragment_and_evaluates_the_tables(tmp_path):
    jsbsim = pytest.importorskip("jsbsim")
    folder = tmp_path / "aircraft" / "tables"
    folder.mkdir(parents=True)
    fragment = jsbsim_fragment(fitted_tables(NAMES, THETA, STDERR))
    (folder / "tables.xml").write_text(AIRCRAFT.replace("FRAGMENT", fragment))
    fdm = jsbsim.FGFDMExec(str(tmp_path), None)
    fdm.set_debug_level(0)
    assert fdm.load_model("tables")
    for mach in (0.9, 1.1, 1.35, 1.6, 1.9, 2.2, 2.6):  # beyond both ends too
        fdm["ic/h-sl-ft"] = 10000.0
        fdm["ic/mach"] = mach
        fdm.run_ic()
        assert fdm["velocities/mach"] == pytest.approx(mach, rel=1e-9)
        # the model's own table (the hat basis), a second implementation
        cx = mach_tables.table_value(np.array(mach), (1.1, 1.6, 2.2), THETA[:3])
        cmq = mach_tables.table_value(np.array(mach), (1.2, 2.0), THETA[4:])
        assert fdm["aero/coefficient/Cx_mach"] == pytest.approx(float(cx), rel=1e-12)
        assert fdm["aero/coefficient/Cmq_mach"] == pytest.approx(float(cmq), rel=1e-12)


def test_figure_has_a_panel_per_coefficient():
    fig = tables_figure(fitted_tables(NAMES, THETA, STDERR),
                        truth={"Cx": (np.array([1.1, 2.2]), np.array([-1.1, -0.8]))})
    axes = fig.get_axes()
    assert len(axes) == 2
    assert axes[0].get_xlabel() == "Mach" and "C_x" in axes[0].get_ylabel()
    assert len(axes[0].get_lines()) >= 2  # the fit and the truth


def test_a_table_result_gets_the_tables_report_and_predict_refuses_it(tmp_path):
    import aeroid
    from aeroid.report import write_report

    flight = aeroid.flights.simulate_scenario(aeroid.flights.reference_scenario(), rng=0)
    result = aeroid.EstimationResult(estimator="equation-error", names=NAMES, theta=THETA,
                                     stderr=STDERR)
    with pytest.raises(EstimatorError, match="predict integrates the nine constant"):
        result.predict(flight)
    page = write_report(result, flight, tmp_path / "rep")
    assert sorted(p.name for p in (tmp_path / "rep").iterdir()) == [
        "report.md", "tables.csv", "tables.png", "tables_jsbsim.xml"]
    text = page.read_text()
    assert "| Cx | 1.6 | -0.95 | 0.0095 |" in text and "| Cza | -11.8 | 0.118 |" in text
