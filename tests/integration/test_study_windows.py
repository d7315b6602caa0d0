"""Studies of several windows: ``windows = "5-5.4,5.6-6"`` in ``[study]``.

Reference: a study fit equals the estimator's own fit of the run's flight cut into the
same windows (:func:`aeroid.flights.cut_windows`), with the run's estimator seed.
"""

import numpy as np
import pytest

from aeroid.errors import StudyError
from aeroid.flights import Windows, cut_windows
from aeroid.study import _fits, loads_study

SPEC = "5-5.4,5.6-6"


def _study(windows: str | None = f'"{SPEC}"', method: str = "equation-error"):
    line = "" if windows is None else f"windows = {windows}\n"
    return loads_study(f"""
[study]
name = "windows"
runs = 2
seed = 5
{line}
[[noise]]
label = "gauss"
model = "gaussian"

[[estimators]]
label = "E"
method = "{method}"
""")


def test_a_study_fit_is_the_fit_of_the_runs_windows():
    study = _study()
    assert study.windows == SPEC and study.describe()["windows"] == SPEC
    record, _ = _fits.fit_task(study, (1, 0, 0))
    assert record["success"], record["message"]
    flight = _fits.simulate_run(study, 1, 0)
    windows = cut_windows(flight, SPEC)
    assert isinstance(windows, Windows) and len(windows) == 2
    alone = study.estimators[0].estimator.fit(
        windows, rng=np.random.default_rng(_fits.estimator_seed(study.seed, 1)))
    np.testing.assert_array_equal(record["theta"], alone.theta)
    # the whole flight gives another answer: the windows were used
    whole = study.estimators[0].estimator.fit(flight)
    assert not np.array_equal(whole.theta, alone.theta)


def test_windows_enter_the_fingerprint_only_when_given():
    assert _study().fingerprint() != _study(None).fingerprint()
    assert "windows" not in _study(None).describe() or _study(None).windows is None


@pytest.mark.parametrize(("windows", "method", "says"), [
    ('"4-5.4"', "equation-error", "outside the log"),
    ('"5-5.4,5.3-6"', "equation-error", "overlap"),
    ('"five"', "equation-error", "not START-END"),
    ("[5, 6]", "equation-error", "must be a string"),
    (f'"{SPEC}"', "sebm-pso", "cannot fit several windows")])
def test_bad_study_windows_are_refused_on_load_in_one_line(windows, method, says):
    with pytest.raises(StudyError, match=says) as err:
        _study(windows, method)
    assert "\n" not in str(err.value)
