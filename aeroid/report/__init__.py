"""Reports: what a fit looks like against its data, and several methods side by side.

This layer sits above estimation and flights (it uses their faces and the model's) and
below the command line:

- :func:`write_report`: ``report.md`` (or ``report.html``: :func:`html_page`) and PNG
  figures of one fit in a folder (``aeroid estimate LOG --method M --report DIR``);
- :func:`report_figures`: the same figures as matplotlib objects (notebooks, tests);
- :func:`compare_results` / :func:`comparison_text`: every method on one log in one
  table (``aeroid estimate LOG --method all``);
- :func:`write_reconstruction_report` / :func:`reconstruction_figures`: a flight-path
  reconstruction's innovations, states and instrument errors (``aeroid reconstruct LOG
  -o OUT --report DIR``).

Modules: ``_files`` (atomic writes), ``_figures`` (the figures), ``_fit`` (one fit's
report), ``_fit_views`` (what its channel figures draw: the model in the fit's air, or
the filter's one-step predictions), ``_compare`` (several methods), ``_html`` (a report
as one HTML page),
``_reconstruction`` (a reconstruction's report), ``_windows`` (a fit of several windows:
:func:`write_windows_report`, one set of model panels per window), ``_tables`` (fitted
coefficient tables in Mach: CSV, JSBSim fragment, figure), ``_reference_curve`` (a
fitted drag against a design tool's Cd curve).
"""

from aeroid.report._compare import (
    compare_results,
    comparison_markdown,
    comparison_text,
    options_note,
    result_notes,
)
from aeroid.report._figures import (
    BAND_SD,
    autocorrelation,
    autocorrelation_figure,
    channel_figure,
    correlation_figure,
    deflection_figure,
    wind_figure,
)
from aeroid.report._files import (
    make_directory,
    write_bytes_atomic,
    write_figure_atomic,
    write_text_atomic,
)
from aeroid.report._fit import REPORT_NAME, report_figures, report_markdown, write_report
from aeroid.report._fit_views import FitView, fit_view
from aeroid.report._html import FORMATS, html_page, report_name
from aeroid.report._log_fit import write_log_report
from aeroid.report._reconstruction import (
    RECONSTRUCTION_REPORT,
    reconstruction_figures,
    write_reconstruction_report,
)
from aeroid.report._reference_curve import (
    REFERENCE_FILES,
    ReferenceCurve,
    cd_from_cx,
    conversion_note,
    fitted_cx,
    flight_mach,
    mach_range,
    overlap_note,
    read_reference_curve,
    reference_curve_figure,
    reference_lines,
)
from aeroid.report._tables import (
    FittedTable,
    fitted_tables,
    jsbsim_fragment,
    tables_csv,
    tables_figure,
)
from aeroid.report._windows import window_view, write_windows_report

__all__ = [
    "FittedTable",
    "fitted_tables",
    "jsbsim_fragment",
    "tables_csv",
    "tables_figure",
    "REFERENCE_FILES",
    "ReferenceCurve",
    "cd_from_cx",
    "conversion_note",
    "fitted_cx",
    "flight_mach",
    "mach_range",
    "overlap_note",
    "read_reference_curve",
    "reference_curve_figure",
    "reference_lines",
    "BAND_SD",
    "FORMATS",
    "RECONSTRUCTION_REPORT",
    "REPORT_NAME",
    "autocorrelation",
    "autocorrelation_figure",
    "channel_figure",
    "compare_results",
    "comparison_markdown",
    "comparison_text",
    "correlation_figure",
    "deflection_figure",
    "wind_figure",
    "FitView",
    "fit_view",
    "html_page",
    "make_directory",
    "options_note",
    "reconstruction_figures",
    "report_figures",
    "report_markdown",
    "report_name",
    "result_notes",
    "write_bytes_atomic",
    "write_figure_atomic",
    "write_reconstruction_report",
    "write_report",
    "write_text_atomic",
    "window_view",
    "write_windows_report",
    "write_log_report",
]
