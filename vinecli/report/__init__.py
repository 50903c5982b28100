"""Reports of runs for people and for CI (``vinecli report``).

Public API: :func:`build_report` -> :class:`ReportResult`; :func:`load_runs`; :class:`Tolerance`
and :data:`DEFAULT_TOLERANCES` for ``--baseline`` comparisons; the figure functions live in
:mod:`vinecli.report.plots`.
"""

from vinecli.report.assemble import FORMATS, ReportResult, build_report
from vinecli.report.baseline import DEFAULT_TOLERANCES, Tolerance
from vinecli.report.loader import Run, load_runs

__all__ = ["DEFAULT_TOLERANCES", "FORMATS", "ReportResult", "Run", "Tolerance", "build_report", "load_runs"]
