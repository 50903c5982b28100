"""Reports of runs for people and for CI (``vinecli report``).

Public API: :func:`build_report` (:mod:`~vinecli.report.assemble`) -> :class:`ReportResult`; :func:`load_runs`
(:mod:`~vinecli.report.loader`); :class:`Tolerance` and :data:`DEFAULT_TOLERANCES` for ``--baseline`` comparisons
(:mod:`~vinecli.report.baseline`). The formats: :mod:`~vinecli.report.html`, :mod:`~vinecli.report.markdown`,
:mod:`~vinecli.report.junit`; the figures: :mod:`~vinecli.report.plots` and the ``*_plots`` modules. The names are
imported on first use: the light modules of the package (:mod:`vinecli.report.text`, what the command line prints
with) do not load the report machinery.

Reads run directories and ``batch.json`` only through :mod:`vinecli.runs` (their file names and readers). May
import every floor below it; never the batch (the batch imports the report for ``run compare``'s figure).
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from vinecli.report.assemble import FORMATS, ReportResult, build_report
    from vinecli.report.baseline import DEFAULT_TOLERANCES, Tolerance
    from vinecli.report.loader import Run, load_runs

__all__ = ["DEFAULT_TOLERANCES", "FORMATS", "ReportResult", "Run", "Tolerance", "build_report", "load_runs"]

_HOME = {"DEFAULT_TOLERANCES": "baseline", "Tolerance": "baseline", "FORMATS": "assemble", "ReportResult": "assemble",
         "build_report": "assemble", "Run": "loader", "load_runs": "loader"}


def __getattr__(name: str) -> Any:
    if name in _HOME:
        return getattr(import_module(f"vinecli.report.{_HOME[name]}"), name)
    raise AttributeError(f"module 'vinecli.report' has no attribute {name!r}")
