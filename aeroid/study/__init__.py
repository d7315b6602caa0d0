"""Monte Carlo studies: design files, a seeded resumable parallel runner, metrics, reports.

``load_study(path)`` validates a study file, ``run_study`` runs it into a study folder
(the store: ``study.json``, ``floors.json`` (the Cramér-Rao floors), ``results.jsonl``,
``histories/``), ``read_results`` and ``load_history`` read that folder back, and
``write_report`` writes tables, figures and ``report.md``.
"""

from aeroid.study._design import load_study, loads_study
from aeroid.study._executors import check_scheduler
from aeroid.study._folder import check_out_dir
from aeroid.study._histories import load_history
from aeroid.study._lock import study_lock
from aeroid.study._provenance import code_identity
from aeroid.study._runner import StudyOutcome, run_study
from aeroid.study._spec import EstimatorSpec, NoiseCondition, Study
from aeroid.study._store import read_design, read_results

__all__ = ["EstimatorSpec", "NoiseCondition", "Study", "StudyOutcome", "check_out_dir",
           "check_scheduler", "code_identity",
           "load_history", "load_study", "loads_study", "read_design", "read_results",
           "run_study", "study_lock", "write_report"]


def __getattr__(name: str):  # the report pulls in matplotlib: import it on first use
    if name == "write_report":
        from aeroid.study._report import write_report

        return write_report
    raise AttributeError(f"module 'aeroid.study' has no attribute {name!r}")
