"""The report of a suite log's fit (aeroid.report.write_log_report; axial-drag's --report).

A hand-made result (no fit): a constant Cx's band drawn over the result's Mach range,
its Cd equal to ``-Cx S / S_ref`` computed here; a Cx table's ``tables.csv`` holding its
points; a failed fit's report written, saying there is no estimate and no figure; the
other parameters listed once each.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd

from aeroid.estimation import EstimationResult, failed_result
from aeroid.model import reference_airframe
from aeroid.report import ReferenceCurve, write_log_report

#: A CSV written with 10 significant digits (aeroid.report's DIGITS) against a float.
CSV_RTOL = 1e-9
CURVE = ReferenceCurve(mach=np.array([0.1, 0.5, 1.0]), cd=np.array([0.5, 0.45, 0.6]),
                       area_m2=0.01, source="design.csv")


def _log():
    return SimpleNamespace(source="axial-log/rocket.toml", airframe=reference_airframe())


def _result(names, theta, stderr, **info) -> EstimationResult:
    return EstimationResult(
        estimator="axial-drag", names=tuple(names), theta=np.array(theta),
        stderr=np.array(stderr), success=True,
        info={"nuisance": {"bax1": (0.1, 0.01), "h0": (1000.0, 0.2)},
              "imu_errors": {"bax1": 0.1, "sax1": 0.003},
              "imu_error_stderr": {"bax1": 0.01, "sax1": 0.001},
              "fit_check": {"ratio": {"accel": 1.01, "pn": 0.9}, "limit": 1.5,
                            "priors": {"bax1": 0.2}, "prior_limit": 3.0}, **info})


def test_a_constant_cx_is_a_band_over_the_results_mach_range(tmp_path) -> None:
    log = _log()
    result = _result(["Cx"], [-0.45], [0.002], mach_range=[0.2, 0.9], span_s=[0.0, 15.0])
    page = write_log_report(result, log, tmp_path, reference=CURVE)
    table = pd.read_csv(tmp_path / "drag_vs_reference.csv")
    np.testing.assert_allclose(table["mach"], [0.2, 0.9], rtol=CSV_RTOL)
    factor = log.airframe.area_m2 / CURVE.area_m2
    np.testing.assert_allclose(table["cd"], [0.45 * factor] * 2, rtol=CSV_RTOL)
    np.testing.assert_allclose(table["cd_hi"], [(0.45 + 1.96 * 0.002) * factor] * 2,
                               rtol=CSV_RTOL)
    text = page.read_text()
    assert "| Cx | -0.45 | 0.002 | -0.45392 .. -0.44608 |" in text
    assert "t = 0 .. 15 s" in text and "| accel | 1.01 |" in text
    assert text.count("| bax1 |") == 1 and "| sax1 | 0.003 | 0.001 |" in text  # once each
    assert not (tmp_path / "tables.csv").exists()


def test_a_table_writes_its_points(tmp_path) -> None:
    result = _result(["Cx@M0.2", "Cx@M0.9"], [-0.44, -0.46], [0.003, 0.004],
                     mach_range=[0.2, 0.9])
    write_log_report(result, _log(), tmp_path, fmt="html")
    table = pd.read_csv(tmp_path / "tables.csv")
    np.testing.assert_allclose(table["mach"], [0.2, 0.9])
    np.testing.assert_allclose(table["value"], [-0.44, -0.46], rtol=CSV_RTOL)
    assert (tmp_path / "tables.png").is_file() and (tmp_path / "report.html").is_file()


def test_a_failed_fit_is_reported_without_estimate_or_figure(tmp_path) -> None:
    result = failed_result("axial-drag", "ValueError: no track")
    page = write_log_report(result, _log(), tmp_path, reference=CURVE)
    text = page.read_text()
    assert "**FAILED**: ValueError: no track" in text
    assert "No estimate: the fit failed." in text
    assert "no figure: the fit gives no Mach range" in text
    assert not (tmp_path / "drag_vs_reference.png").exists()
