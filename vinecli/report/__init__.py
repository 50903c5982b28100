"""Reports of runs for people and for CI (``vinecli report``).

Public API: :func:`build_report` (:mod:`~vinecli.report.assemble`) -> :class:`ReportResult`; :func:`load_runs`
(:mod:`~vinecli.report.loader`); :class:`Tolerance` and :data:`DEFAULT_TOLERANCES` for ``--baseline`` comparisons
(:mod:`~vinecli.report.baseline`). The formats: :mod:`~vinecli.report.html`, :mod:`~vinecli.report.markdown`,
:mod:`~vinecli.report.junit`; the figures: :mod:`~vinecli.report.plots` and the ``*_plots`` modules.

Reads run directories and ``batch.json`` only through :mod:`vinecli.runs` (their file names and readers). May
import every floor below it; never the batch (the batch imports the report for ``run compare``'s figure).
"""

from vinecli.report.assemble import FORMATS, ReportResult, build_report
from vinecli.report.baseline import DEFAULT_TOLERANCES, Tolerance
from vinecli.report.loader import Run, load_runs

__all__ = ["DEFAULT_TOLERANCES", "FORMATS", "ReportResult", "Run", "Tolerance", "build_report", "load_runs"]
