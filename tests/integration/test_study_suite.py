"""Studies on sensor-suite logs: ``[[noise]] model = "suite"`` (aeroid/study/_suite.py).

A tiny study (2 runs, output-error fitting the IMU's errors on the raw IMU) runs; its
flights are the reconstruction of ``simulate_suite`` drawn from the run's flight seed
(checked against the flights layer's own functions), its records name the suite
condition and carry the drawn IMU errors, and the same seed gives the same records in
one process and in two.
"""

import numpy as np
import pytest
from study_fakes import stable

from aeroid.errors import StudyError
from aeroid.flights import simulate_suite
from aeroid.reconstruction import reconstruct
from aeroid.study import _runner as study_runner
from aeroid.study import loads_study, run_study
from aeroid.study._report import write_report

#: The issue's check on a fit of the suite: every coefficient and IMU error within 3 sd.
Z_LIMIT = 3.0

STUDY = """
[study]
name = "suite-tiny"
runs = 2
seed = 5

[[noise]]
label = "suite, raw IMU"
model = "suite"
imu = "raw"
{extra}

[[estimators]]
label = "OE imu"
method = "output-error"
[estimators.options]
imu_errors = "bias+scale"
estimate_initial_velocity = true
initial_velocity_prior = "flight"
"""


@pytest.fixture(scope="module")
def study():
    return loads_study(STUDY.format(extra=""))


@pytest.fixture(scope="module")
def serial(study, tmp_path_factory):
    return run_study(study, tmp_path_factory.mktemp("serial"), progress=False)


def test_suite_flight_is_the_reconstruction_of_the_run_seed_log(study):
    """The runner's flight equals simulate_suite -> reconstruct -> to_flight(imu="raw")."""
    ours = study_runner.simulate_run(study, 1, 0)
    cond = study.noise[0]
    sim = simulate_suite(study.scenario.airframe, study.scenario.coefficient_vector,
                         study.scenario.manoeuvre, cond.suite,
                         rng=np.random.default_rng(study_runner.flight_seed(study.seed, 1)))
    ref = reconstruct(sim.log).to_flight(imu="raw")
    assert ours.data.equals(ref.data)
    assert len(ours.data) == round(np.ptp(study.scenario.manoeuvre.window_s)
                                   * cond.suite.imu_rate_hz) + 1  # the IMU's rate
    truth = ours.metadata["suite_errors"]
    np.testing.assert_array_equal([truth["bax1"], truth["sr"]],
                                  [sim.errors["accel_bias"][0, 0], sim.errors["gyro_scale"][2]])
    # another run draws another suite
    assert not study_runner.simulate_run(study, 0, 0).data.equals(ours.data)


def test_records_name_the_suite_condition_and_score_the_imu_errors(study, serial):
    assert serial.n_new == 2 and serial.n_failed == 0
    for r in serial.records:
        assert r["noise"] == "suite, raw IMU" and r["estimator"] == "OE imu"
        truth = np.array(r["truth"])
        theta, sd = np.array(r["theta"]), np.array(r["stderr"])
        assert np.max(np.abs(theta - truth) / sd) <= Z_LIMIT
        true, fitted, err = r["imu_errors_true"], r["imu_errors"], r["imu_error_stderr"]
        assert set(fitted) == set(true) == set(err) and len(true) == 18
        z = [abs(fitted[k] - true[k]) / err[k] for k in true]
        assert max(z) <= Z_LIMIT
        # the drawn biases lie in the suite's ranges (a record of the truth, not of the fit)
        lo, hi = study.noise[0].suite.accel_bias_mps2
        assert all(lo <= abs(true[k]) <= hi for k in true if k.startswith("ba"))
    assert serial.records[0]["imu_errors_true"] != serial.records[1]["imu_errors_true"]


def test_two_processes_give_the_same_records(study, serial, tmp_path):
    parallel = run_study(study, tmp_path, jobs=2, progress=False)
    assert stable(parallel.records) == stable(serial.records)


def test_report_has_the_suite_section_and_no_floor(study, serial):
    text = write_report(study, serial.out_dir, figures=False).read_text()
    assert "- noise **suite, raw IMU**: model=suite, imu=raw, imu_rate_hz=1000.0" in text
    assert "## Sensor-suite conditions: the fitted IMU errors" in text
    assert "| suite, raw IMU | OE imu | 2 |" in text
    assert "a sensor-suite log" in text  # why the condition has no Cramer-Rao floor


def test_ideal_conditions_keep_their_fingerprint():
    """A study without a suite condition describes its noise as before (resume works)."""
    text = STUDY.format(extra="").replace('model = "suite"\nimu = "raw"', 'model = "gaussian"')
    cond = loads_study(text).noise[0]
    assert cond.suite is None and cond.describe() == {"label": cond.label,
                                                      **cond.model.to_dict()}


@pytest.mark.parametrize("extra, expected", [
    ("gnss_hz = 5.0", "unknown sensor-suite option(s) gnss_hz (allowed: imu, imu_rate_hz"),
    ('imu = "cooked"', "imu must be one of raw, corrected, got 'cooked'"),
    ("accel_bias_mps2 = [0.2, 0.02]", "accel_bias_mps2 must be (low, high) with 0 <= low"),
    ("gnss_rate_hz = 7.0", "gnss_rate_hz = 7 must divide imu_rate_hz = 1000"),
    ('baro_channels = "pressure"', "baro_channels = 'pressure' has the wrong type"),
    ("imu_rate_hz = true", "imu_rate_hz = True has the wrong type"),
    ('gyro_noise_radps = "low"', "gyro_noise_radps = 'low' has the wrong type"),
    ("accel_noise_mps2 = -0.1", "accel_noise_mps2 must be finite numbers >= 0, got -0.1"),
    ("gnss_velocity_sd_mps = nan", "gnss_velocity_sd_mps must be finite numbers >= 0"),
])
def test_bad_suite_options_are_one_line_errors(extra, expected):
    text = STUDY.format(extra=extra)
    if extra.startswith("imu ="):
        text = text.replace('imu = "raw"\n', "")
    with pytest.raises(StudyError) as info:
        loads_study(text, source="s.toml")
    message = str(info.value)
    assert "\n" not in message and expected in message
    assert message.startswith("s.toml: [[noise]] #1 (suite, raw IMU): ")


def test_a_corrected_imu_is_not_scored_against_the_drawn_errors(study):
    """The corrected IMU keeps only what the correction left: no drawn errors recorded."""
    text = STUDY.format(extra="").replace('imu = "raw"', 'imu = "corrected"')
    corrected = loads_study(text)
    flight = study_runner.simulate_run(corrected, 1, 0)
    assert "suite_errors" not in flight.metadata
    raw = study_runner.simulate_run(study, 1, 0)
    assert "suite_errors" in raw.metadata
    # same run, same suite draws: the two flights share their reconstructed states
    np.testing.assert_array_equal(flight.data["u"], raw.data["u"])
    assert not np.array_equal(flight.data["ax1"], raw.data["ax1"])
