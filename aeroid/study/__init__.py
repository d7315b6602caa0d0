"""Monte Carlo studies: design files, a seeded resumable parallel runner, metrics, reports.

``load_study(path)`` validates a study file (:mod:`aeroid.study`), ``run_study``
runs it (:mod:`aeroid.study`), :mod:`aeroid.study` reduces the fits and
``write_report`` writes tables, figures and ``report.md`` (:mod:`aeroid.study`).
"""

from aeroid.study._design import EstimatorSpec, NoiseCondition, Study, load_study, loads_study
from aeroid.study._runner import StudyOutcome, read_results, run_study

__all__ = ["EstimatorSpec", "NoiseCondition", "Study", "StudyOutcome", "load_study",
           "loads_study", "read_results", "run_study", "write_report"]


def __getattr__(name: str):  # the report pulls in matplotlib: import it on first use
    if name == "write_report":
        from aeroid.study._report import write_report

        return write_report
    raise AttributeError(f"module 'aeroid.study' has no attribute {name!r}")
